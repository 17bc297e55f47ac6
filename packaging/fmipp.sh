#!/usr/bin/env bash
# Builds FMI++'s Python package (fmipp, pinned with its hash in packaging/requirements-fmipp.txt)
# into the venv $1, for tests/fmipp. PyPI has only its source; its setup.py builds the
# Model Exchange integrators against SUNDIALS with -std=c++11, and Debian 12's SUNDIALS 6 needs
# C++14 and a newer API. The tests import co-simulation FMUs only, which need no integrator and
# no export wrapper, so the build leaves SUNDIALS out (the macro USE_SUNDIALS, its libraries and
# SWIG's -D) and the export modules, and compiles as C++14. Needs swig and Boost's headers and
# filesystem library (Debian: swig, libboost-dev, libboost-filesystem-dev;
# packaging/setup-test-tools.sh installs them).
set -euo pipefail
venv=$1
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$venv/bin/pip" download -q --disable-pip-version-check --no-deps --no-binary :all: \
    --require-hashes -r "$root/packaging/requirements-fmipp.txt" -d "$work"
tar -xzf "$work"/fmipp-2.1.0.tar.gz -C "$work"
setup="$work/fmipp-2.1.0/setup.py"
# Each edit must apply exactly as written; a changed setup.py stops here with a message.
edit() {
    PATTERN=$1 REPLACEMENT=$2 python3 - "$setup" <<'PY'
import os, sys
path = sys.argv[1]
text = open(path).read()
pattern = os.environ["PATTERN"]
if pattern not in text:
    sys.exit(f"packaging/fmipp.sh: {path} has no {pattern!r}; the build recipe needs updating")
open(path, "w").write(text.replace(pattern, os.environ["REPLACEMENT"]))
PY
}
edit "( 'USE_SUNDIALS', None )," ""
edit "'-lsundials_cvode'," ""
edit "'-lsundials_nvecserial'" ""
edit ", '-DUSE_SUNDIALS' ]" " ]"
edit "'-std=c++11'" "'-std=c++14'"
# Only the import wrapper (`import fmipp`): the tests export no FMU with FMI++.
edit "      import_wrapper,
      export_wrapper,
      fmi2_frontend,
      fmi1_frontend_lib
    ]," "      import_wrapper
    ],"
# -O0 after Python's own -O3 (CFLAGS comes last, and gcc takes the last -O): the tests call a few
# FMI functions through it, and the optimiser took most of the build's time on SWIG's wrapper.
CFLAGS="-O0" "$venv/bin/pip" install -q --disable-pip-version-check "$work/fmipp-2.1.0"
