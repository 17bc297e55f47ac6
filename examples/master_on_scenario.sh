#!/usr/bin/env bash
# The Rust co-simulation master on a scenario file: the seed-000 high-ay ramp, the reference
# vehicle and four estimators, scored against the truth.
#
#     bash examples/master_on_scenario.sh [OUT_DIR] [HARNESS]
#
# HARNESS defaults to the release build of the `harness` binary (built by `bash tests/run.sh` or
# `cargo build --release -p harness`); the scenario names its FMUs as {fmu_dir}/*.fmu, which
# `--fmu-dir` points at the packaged archives.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$root/out/example_scenario}
harness=${2:-$root/target/release/harness}
fmu_dir=${FMU_DIR:-$root/target/fmu}

# `run` writes every recorded signal (CSV), the scores (RMSE, NEES per estimator) and plots.
"$harness" run "$root/harness/scenarios/seed000_ramp_high_ay.toml" --fmu-dir "$fmu_dir" --out "$out"
ls "$out"
