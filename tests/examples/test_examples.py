"""Every script in examples/ runs against the packaged FMUs and prints what it promises. The
examples are documentation a user copies; a change that breaks one breaks the docs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def fmu_directory() -> Path:
    """Where packaging writes the archives (as tests/fmpy/fmu_support.py finds them)."""
    if os.environ.get("FMU_DIR"):
        return Path(os.environ["FMU_DIR"]).resolve()
    target = os.environ.get("CARGO_TARGET_DIR")
    return ((ROOT / target) if target else (ROOT / "target")).resolve() / "fmu"


def run_python(script: str) -> str:
    for archive in ("VehicleStateEstimator.fmu", "ReferenceVehicle.fmu", "VehicleWithEstimator.ssp"):
        if not (fmu_directory() / archive).is_file():
            pytest.fail(f"{fmu_directory() / archive} does not exist: build the archives first with "
                        "`cargo run --release -p packaging`", pytrace=False)
    completed = subprocess.run([sys.executable, str(EXAMPLES / script), str(fmu_directory())],
                               cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert completed.returncode == 0, completed.stderr
    return completed.stdout


def degrees(pattern: str, text: str) -> float:
    match = re.search(pattern, text)
    assert match, f"{pattern!r} not in the output:\n{text}"
    return float(match.group(1))


def test_every_example_is_tested():
    tested = {"estimator_on_csv.py", "coupled_fmpy.py", "ssp_with_car.py", "master_on_scenario.sh",
              "fmi3_covariance.py"}
    shipped = {p.name for p in EXAMPLES.iterdir() if p.suffix in {".py", ".sh"}}
    assert shipped == tested


def test_estimator_on_csv_beats_answering_zero():
    out = run_python("estimator_on_csv.py")
    rmse = degrees(r"sideslip RMSE ([\d.]+) deg", out)
    zero = degrees(r"answering zero: ([\d.]+) deg", out)
    assert 0 < rmse < zero, out


def test_fmi3_example_reads_a_symmetric_covariance_of_the_running_model():
    out = run_python("fmi3_covariance.py")
    assert "state dimension 11;" in out, out
    assert "covariance symmetric: True" in out, out
    true = degrees(r"true (-?[\d.]+) deg", out)
    estimate = degrees(r"estimate (-?[\d.]+) deg", out)
    assert abs(true - estimate) < 0.05, out


def test_both_fmus_coupled_track_the_step_steer():
    out = run_python("coupled_fmpy.py")
    assert degrees(r"RMSE ([\d.]+) deg", out) < 0.05, out


def test_the_ssp_with_a_car_runs_the_full_vehicle():
    out = run_python("ssp_with_car.py")
    assert degrees(r"RMSE after 1 s ([\d.]+) deg", out) < 0.2, out


def test_the_master_runs_a_scenario_file(workspace_executables, tmp_path):
    harness = workspace_executables[("bin", "harness")]
    completed = subprocess.run(
        ["bash", str(EXAMPLES / "master_on_scenario.sh"), str(tmp_path / "out"), str(harness)],
        cwd=ROOT, capture_output=True, text=True, timeout=900,
        env={**os.environ, "FMU_DIR": str(fmu_directory())})
    assert completed.returncode == 0, completed.stderr
    written = {p.suffix for p in (tmp_path / "out").rglob("*")}
    assert {".csv", ".png"} <= written, sorted(p.name for p in (tmp_path / "out").rglob("*"))


def test_the_readme_fmpy_snippet_runs():
    """The README's fmpy block, run as written (with the archives where this build put them)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    (block,) = re.findall(r"```python\n(.*?)```", text, re.S)
    code = block.replace('"target/fmu/', f'"{fmu_directory()}/')
    completed = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                               text=True, timeout=600)
    assert completed.returncode == 0, completed.stderr
    assert 0 < degrees(r"sideslip RMSE ([\d.]+) deg", completed.stdout) < 90
