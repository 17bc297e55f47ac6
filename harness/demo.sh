#!/usr/bin/env bash
# The project's main job (README): installs what is missing, builds and packages both FMUs, runs the
# seed experiments through the co-simulation master and writes out/demo/report.md and report.html.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash packaging/setup.sh
exec cargo run --release -p harness -- demo "$@"
