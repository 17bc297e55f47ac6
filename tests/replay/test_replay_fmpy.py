"""The fmpy-only example script (harness/replay_with_fmpy.py) replays the shipped
example log through the VehicleStateEstimator FMU exactly as `harness replay` does (same map, same
alignment rule, same parameter file), so both give the same estimates bit for bit."""

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
LOGS = ROOT / "harness" / "logs"


def estimator_fmu():
    target = os.environ.get("CARGO_TARGET_DIR")
    fmu = ((ROOT / target) if target else (ROOT / "target")).resolve() / "fmu" / "VehicleStateEstimator.fmu"
    if not fmu.is_file():
        pytest.fail(f"{fmu} does not exist: build it with `cargo run --release -p packaging`", pytrace=False)
    return fmu


def test_fmpy_script_and_harness_replay_agree(workspace_executables, tmp_path):
    harness = workspace_executables[("bin", "harness")]
    fmu = estimator_fmu()
    # A parameter file as `harness fit` writes one: enumerations by item name, a fitted scale.
    ssv = tmp_path / "car.ssv"
    ssv.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="car">\n'
        "  <ssv:Parameters>\n"
        '    <ssv:Parameter name="estimator"><ssv:Enumeration value="ukf_scaled"/></ssv:Parameter>\n'
        '    <ssv:Parameter name="cornering_stiffness_scale_front"><ssv:Real value="0.95"/></ssv:Parameter>\n'
        "  </ssv:Parameters>\n</ssv:ParameterSet>\n")
    # The map sets estimator = 2 (EKF); the file is applied after it, so its UKF must win in both.
    map_path = LOGS / "ford_escort_sis.toml"
    log = LOGS / "ford_escort_sis.csv"
    out = tmp_path / "harness"
    subprocess.run([str(harness), "replay", str(log), "--map", str(map_path), "--parameters", str(ssv),
                    "--out", str(out), "--fmu-dir", str(fmu.parent), "--no-plots"],
                   cwd=ROOT, check=True, capture_output=True, text=True, timeout=120)
    fmpy_csv = tmp_path / "fmpy.csv"
    printed = subprocess.run([sys.executable, str(ROOT / "harness" / "replay_with_fmpy.py"), str(log), str(map_path),
                              str(ssv), "--fmu", str(fmu), "--out", str(fmpy_csv)],
                             cwd=ROOT, check=True, capture_output=True, text=True, timeout=120).stdout
    assert "sideslip: RMSE" in printed, printed
    ours = np.genfromtxt(out / "estimates.csv", delimiter=",", names=True)
    theirs = np.genfromtxt(fmpy_csv, delimiter=",", names=True)
    assert len(ours) == len(theirs) == 3000
    for name in ("vx_est", "yaw_rate_est", "sideslip_est", "sideslip_std"):
        assert np.array_equal(ours[name], theirs[name], equal_nan=True), name
    # The UKF of the file ran, not the map's EKF: its sideslip differs from a replay without the file.
    ekf = tmp_path / "ekf"
    subprocess.run([str(harness), "replay", str(log), "--map", str(LOGS / "ford_escort_sis.toml"), "--out", str(ekf),
                    "--fmu-dir", str(fmu.parent), "--no-plots"], cwd=ROOT, check=True, capture_output=True, timeout=120)
    assert not np.array_equal(np.genfromtxt(ekf / "estimates.csv", delimiter=",", names=True)["sideslip_est"],
                              ours["sideslip_est"])
