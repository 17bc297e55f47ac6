#!/usr/bin/env bash
# The project's one test command (README; .ci/run calls exactly this). Installs what is missing,
# checks formatting and lints, packages the FMUs, runs every Rust test and the Python tests
# (fmpy, filterpy, cross-tool, docs) against the packaged FMUs.
#
# Built once: clippy checks in the release profile, so the build scripts and proc macros it compiles
# (bindgen, serde_derive, clap_derive, ...: build-override, opt-level 0) are the ones the release
# build reuses; in the dev profile they were compiled a second time, and optimised (the dev
# profile's `package."*"` opt-level 2), which made clippy take 172 s instead of 91 s on a fresh
# target directory (issue 11). Then everything is compiled in one release build of every workspace target that `cargo test --workspace --release`
# needs. Packaging builds the shipped Linux libraries for glibc 2.17 with cargo zigbuild (another
# target, so a second release build of the two FMU packages, about two minutes; issue 15); with
# --host-glibc it would take them from that build (--with-workspace-targets). The Rust
# tests run in it, and the Python tests use its binaries (tests/conftest.py asks cargo for the
# same selection, which then compiles nothing). Cargo unifies dependency features per invocation,
# so a different selection (`-p packaging`, `-p harness`, a dev-profile example) would compile the
# dependencies again; that was most of the 22-30 minutes this took before (issue 11).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash packaging/setup.sh

# A fresh clone gains nothing from incremental compilation, it only writes more.
if [ "${CI:-}" = true ]; then
    export CARGO_INCREMENTAL=0
fi
phase() {
    local started=$SECONDS
    echo "== $*" >&2
    "$@"
    echo "== $((SECONDS - started)) s: $*" >&2
}

phase cargo fmt --all --check
phase cargo clippy --release --workspace --all-targets -- -D warnings
phase cargo build --release --workspace --lib --bins --tests --examples
target=$("$root/.venv/bin/python" -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])' \
    < <(cargo metadata --format-version 1 --no-deps))
phase "$target/release/packaging" --with-workspace-targets
phase cargo test --workspace --release
phase "$root/.venv/bin/python" -m pytest tests -q
