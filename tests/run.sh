#!/usr/bin/env bash
# The project's one test command (README; .ci/run calls exactly this). Installs what is missing,
# checks formatting and lints, packages the FMUs, runs every Rust test and the Python tests
# (fmpy, filterpy, cross-tool, docs) against the packaged FMUs.
#
# Built once, linted while it is built: clippy-driver compiles the workspace's own crates
# (RUSTC_WORKSPACE_WRAPPER, the mechanism `cargo clippy` itself uses) in the one release build of
# every workspace target, so the crates are type-checked once instead of twice (a separate
# `cargo clippy` pass takes 91-218 s); dependencies are compiled by rustc.
# CLIPPY_ARGS is cargo-clippy's way of passing `-D warnings` to the driver. The variables stay
# exported for the rest of the script, so every later cargo call (packaging's host-side lookup,
# `cargo test`, tests/conftest.py asking cargo for the same binaries) sees the same compiler and
# compiles nothing again; a plain `cargo build --release` afterwards recompiles the workspace's
# crates. The shipped libraries are not built by the driver: packaging builds them for glibc 2.17
# with cargo zigbuild (another target, so a second release build of the two FMU packages) with
# the wrapper removed (packaging/src/cargo.rs), since clippy-driver is not meant to
# produce release artefacts. The Rust tests run in the one build, and the Python tests use its
# binaries. Cargo unifies dependency features per invocation, so a different selection
# (`-p packaging`, `-p harness`, a dev-profile example) would compile the dependencies again,
# which would double the build's share of the run.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash packaging/setup.sh --without-test-tools

# The Python tests' other tools (FMI++ and chromium: packaging/setup-test-tools.sh, mostly
# downloads, unpacking and one C++ build, about 2 min on a fresh machine) install beside the Rust
# build and tests, which need none of them; the Python tests wait for them.
test_tools_log=$(mktemp)
(
    started=$SECONDS
    bash packaging/setup-test-tools.sh
    echo "== $((SECONDS - started)) s: packaging/setup-test-tools.sh (beside the build)"
) >"$test_tools_log" 2>&1 &
test_tools_pid=$!
trap 'kill "$test_tools_pid" 2>/dev/null || true; rm -f "$test_tools_log"' EXIT
wait_for_test_tools() {
    local status=0
    wait "$test_tools_pid" || status=$?
    cat "$test_tools_log" >&2
    if [ "$status" != 0 ]; then
        echo "tests/run.sh: packaging/setup-test-tools.sh failed (exit $status), its output above" >&2
    fi
    return "$status"
}

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
clippy_driver="$(rustc --print sysroot)/bin/clippy-driver"
if [ ! -x "$clippy_driver" ]; then
    echo "tests/run.sh: $clippy_driver not found; install clippy: rustup component add clippy" >&2
    exit 1
fi
export RUSTC_WORKSPACE_WRAPPER="$clippy_driver"
export CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
phase cargo build --release --workspace --all-targets
target=$("$root/.venv/bin/python" -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])' \
    < <(cargo metadata --format-version 1 --no-deps))
phase "$target/release/packaging" --with-workspace-targets
phase cargo test --workspace --release
# Two xdist workers (pytest-xdist, tests/requirements.txt), each module in one of them (loadscope:
# module-scoped fixtures run once, the campaign tests share one Dask cluster). The module of
# `harness demo` (tests/harness/test_demo.py: the demo with a subset of its two slowest studies,
# about 110 s alone and 160 s beside the other worker) goes first, by its `starts_first` marker and
# the collection order (no reordering by size), so the other worker runs every other module
# meanwhile. Measured on this 2-core machine: the phase takes 188 s, the demo is its bound, and
# its EM already uses both cores in parts, so a third worker would not shorten it.
# (Not --dist loadgroup: xdist 3.8.0 tags a group by setting item._nodeid, which pytest 9.2 does
# not read, so the group's tests would be spread over both workers and the demo would run twice.)
phase wait_for_test_tools
phase "$root/.venv/bin/python" -m pytest tests -q -n 2 --dist loadscope --no-loadscope-reorder
