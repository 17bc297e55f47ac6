#!/usr/bin/env bash
# Installs, where missing, the other tools the Python tests use, and nothing else:
#  - FMI++ (fmipp), the third importer of the tests, built from its pinned source by
#    packaging/fmipp.sh into .venv, with swig and Boost from Debian;
#  - chromium (Debian): tests/harness/test_report_browser.py renders the HTML report in it.
# Needs .venv (packaging/setup.sh creates it). Idempotent and quiet when there is nothing to do.
# tests/run.sh runs it beside the build, since both are mostly downloads, unpacking and one C++
# build that the cargo build would otherwise wait for.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv="$root/.venv"

# Installs the Debian packages $@ (with sudo unless root), without the packages they only
# recommend: chromium alone recommends 88 more (udev, avahi, samba's libraries), which headless
# rendering does not use.
apt_install() {
    local sudo_cmd=""
    [ "$(id -u)" = 0 ] || sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

fmipp_stamp="$venv/.requirements-fmipp"
if ! cmp -s "$root/packaging/requirements-fmipp.txt" "$fmipp_stamp" ||
    ! cmp -s "$root/packaging/fmipp.sh" "$fmipp_stamp.sh"; then
    missing=()
    command -v swig >/dev/null || missing+=(swig)
    [ -e /usr/include/boost/version.hpp ] || missing+=(libboost-dev)
    compgen -G '/usr/lib/*/libboost_filesystem.so' >/dev/null || missing+=(libboost-filesystem-dev)
    if [ ${#missing[@]} -gt 0 ]; then
        echo "setup: installing ${missing[*]} (to build FMI++ for tests/fmipp)" >&2
        apt_install "${missing[@]}"
    fi
    echo "setup: building FMI++ (fmipp) into $venv" >&2
    bash "$root/packaging/fmipp.sh" "$venv"
    cp "$root/packaging/requirements-fmipp.txt" "$fmipp_stamp"
    cp "$root/packaging/fmipp.sh" "$fmipp_stamp.sh"
fi

if ! command -v chromium >/dev/null; then
    echo "setup: installing chromium (tests/harness/test_report_browser.py)" >&2
    apt_install chromium
fi
