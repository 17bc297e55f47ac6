#!/usr/bin/env bash
# The project's main job (README): installs what building needs, builds the workspace once,
# packages both FMUs from that build, runs the experiments through the co-simulation master and
# writes out/demo/report.md and report.html. Each phase prints its wall time on stderr.
#
# One build: cargo unifies dependency features per invocation, so `cargo run -p harness` and then
# `cargo run -p packaging` (and packaging's own build of the FMU packages) would compile most
# dependencies two or three times. The workspace is built here with the selection tests/run.sh
# builds (`--workspace --all-targets`), packaging builds the FMU libraries with that same
# selection (`--with-workspace-targets`), so it compiles nothing again, and a later
# `bash tests/run.sh` reuses every compiled dependency. The demo's FMUs are built for this
# machine's glibc (`--host-glibc`); the portable ones for glibc 2.17 need zig, which the tests'
# setup installs, and a second build for that target.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

phase() {
    local started=$SECONDS
    echo "== $*" >&2
    "$@"
    echo "== $((SECONDS - started)) s: $*" >&2
}

phase bash packaging/setup-build.sh
phase cargo build --release --workspace --all-targets
target=$(cargo metadata --format-version 1 --no-deps |
    sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')
phase "$target/release/packaging" --host-glibc --with-workspace-targets
# Packaging leaves an archive whose bytes did not change as it was; mark both current, so the
# demo does not take them for older than the sources.
touch "$target/fmu/ReferenceVehicle.fmu" "$target/fmu/VehicleStateEstimator.fmu"
phase "$target/release/harness" demo --no-package "$@"
