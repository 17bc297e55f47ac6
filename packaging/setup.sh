#!/usr/bin/env bash
# Installs, where missing, what building and testing need on a fresh machine. Idempotent and quiet
# when there is nothing to do; `bash tests/run.sh` calls it first.
# Usage: packaging/setup.sh [--without-test-tools]
#  - packaging/setup-build.sh: what building needs (libclang), all `bash harness/demo.sh` needs.
#  - packaging/setup-test-tools.sh: FMI++ and chromium for the Python tests, left to the caller
#    with --without-test-tools (tests/run.sh installs them beside the build).
#  - .venv: the pinned Python packages of tests/requirements.txt (fmpy, filterpy, pytest, ...),
#    and of packaging/requirements-zig.txt (zig and cargo-zigbuild, for the Linux libraries that
#    load on glibc 2.17 and newer), installed by uv (packaging/requirements-uv.txt), with pip as
#    the fallback.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
case "${1:-}" in
"" | --without-test-tools) ;;
*)
    echo "packaging/setup.sh: unknown argument '$1'; expected none or --without-test-tools" >&2
    exit 2
    ;;
esac

bash "$root/packaging/setup-build.sh"

venv="$root/.venv"
if [ ! -x "$venv/bin/python" ]; then
    echo "setup: creating $venv" >&2
    python3 -m venv "$venv"
fi

# Installs the pinned requirement file $1 into .venv unless the stamp $2 already holds the same
# file. uv (itself pinned in packaging/requirements-uv.txt) downloads and installs in parallel and
# does not byte-compile; where uv cannot be installed or fails, pip does the same job, slower.
install_requirements() {
    local file=$1 stamp=$2
    cmp -s "$file" "$stamp" && return 0
    echo "setup: installing $file into $venv" >&2
    # UV_NATIVE_TLS: the system's certificate store, the one pip is configured with here.
    if [ -x "$venv/bin/uv" ] &&
        UV_NATIVE_TLS=1 "$venv/bin/uv" pip install --quiet --python "$venv/bin/python" -r "$file"; then
        :
    else
        echo "setup: uv unavailable or failed on $file; installing with pip" >&2
        "$venv/bin/pip" install -q --disable-pip-version-check -r "$file"
    fi
    cp "$file" "$stamp"
}

uv_stamp="$venv/.requirements-uv"
if ! cmp -s "$root/packaging/requirements-uv.txt" "$uv_stamp"; then
    if "$venv/bin/pip" install -q --disable-pip-version-check -r "$root/packaging/requirements-uv.txt"; then
        cp "$root/packaging/requirements-uv.txt" "$uv_stamp"
    else
        echo "setup: could not install uv (packaging/requirements-uv.txt); pip will install the rest" >&2
    fi
fi
install_requirements "$root/tests/requirements.txt" "$venv/.requirements"

# vse_campaign (harness/campaign, the Dask campaign runner) on .venv's path: a .pth file, no build step.
"$venv/bin/python" -c 'import site, sys; open(site.getsitepackages()[0] + "/vse_campaign.pth", "w").write(sys.argv[1] + "\n")' "$root/harness/campaign"

install_requirements "$root/packaging/requirements-zig.txt" "$venv/.requirements-zig"

# The other tools the Python tests use (FMI++, chromium), unless the caller installs them itself.
if [ "${1:-}" != --without-test-tools ]; then
    bash "$root/packaging/setup-test-tools.sh"
fi
