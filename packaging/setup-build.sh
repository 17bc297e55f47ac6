#!/usr/bin/env bash
# Installs, where missing, what building the workspace needs on a fresh machine, and nothing
# else: `bash harness/demo.sh` calls it (packaging/setup.sh, for the tests, calls it first).
# Idempotent and quiet when there is nothing to do.
#  - libclang: the `fmi` crate (the harness's FMI importer) runs bindgen at build time.
set -euo pipefail

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
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends libclang-dev >/dev/null
fi
