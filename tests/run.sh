#!/usr/bin/env bash
# The project's one test command (README; .ci/run calls exactly this). Installs what is missing,
# checks formatting and lints, runs every Rust test, packages the FMUs and runs the Python tests
# (fmpy, filterpy, cross-tool) against them. Packaging comes before the Rust tests: the harness's
# co-simulation tests (e.g. the model-mismatch study) load the packaged FMUs from target/fmu.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash packaging/setup.sh

cargo fmt --all --check
cargo clippy --workspace --all-targets -- -D warnings
cargo run --release -p packaging
cargo test --workspace
"$root/.venv/bin/python" -m pytest tests -q
