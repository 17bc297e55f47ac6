#!/usr/bin/env bash
# Installs, where missing, what building and testing need on a fresh machine. Idempotent and quiet
# when there is nothing to do; both README commands call it first.
#  - libclang: the `fmi` crate (the harness's FMI importer) runs bindgen at build time.
#  - .venv: the pinned Python packages of tests/requirements.txt (fmpy, filterpy, pytest, ...),
#    and of packaging/requirements-zig.txt (zig and cargo-zigbuild, for the Linux libraries that
#    load on glibc 2.17 and newer).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# bindgen loads libclang.so or libclang-<version>.so*; libclang-cpp.so (shipped by other LLVM
# packages) is a different library and does not count.
have_libclang() {
    ldconfig -p 2>/dev/null | grep -Eq 'libclang(-[0-9.]+)?\.so' ||
        compgen -G '/usr/lib/llvm-*/lib/libclang.so*' >/dev/null ||
        compgen -G '/usr/lib/llvm-*/lib/libclang-[0-9]*.so*' >/dev/null
}
if ! have_libclang; then
    echo "setup: installing libclang-dev (needed by bindgen in the fmi crate)" >&2
    sudo_cmd=""
    [ "$(id -u)" = 0 ] || sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq libclang-dev >/dev/null
fi

venv="$root/.venv"
stamp="$venv/.requirements"
if [ ! -x "$venv/bin/python" ] || ! cmp -s "$root/tests/requirements.txt" "$stamp"; then
    echo "setup: creating $venv from tests/requirements.txt" >&2
    python3 -m venv "$venv"
    "$venv/bin/pip" install -q --disable-pip-version-check -r "$root/tests/requirements.txt"
    cp "$root/tests/requirements.txt" "$stamp"
fi

# vse_campaign (harness/campaign, issue 16) on .venv's path: a .pth file, no build step.
"$venv/bin/python" -c 'import site, sys; open(site.getsitepackages()[0] + "/vse_campaign.pth", "w").write(sys.argv[1] + "\n")' "$root/harness/campaign"

zig_stamp="$venv/.requirements-zig"
if ! cmp -s "$root/packaging/requirements-zig.txt" "$zig_stamp"; then
    echo "setup: installing zig and cargo-zigbuild into $venv (packaging/requirements-zig.txt)" >&2
    "$venv/bin/pip" install -q --disable-pip-version-check -r "$root/packaging/requirements-zig.txt"
    cp "$root/packaging/requirements-zig.txt" "$zig_stamp"
fi
