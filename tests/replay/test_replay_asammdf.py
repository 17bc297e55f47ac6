"""An MDF4 log written by a mainstream tool (asammdf) replays through `harness replay`
exactly as the CSV it was made from: two channel groups at 10 ms and 20 ms with their own master
channels and units, read by the mf4-rs crate. A channel whose unit is not the map's is refused,
naming the channel."""

import os
import pathlib
import subprocess

import numpy as np
import pytest
from asammdf import MDF, Signal

ROOT = pathlib.Path(__file__).resolve().parents[2]
LOGS = ROOT / "harness" / "logs"
UNITS = {"steering_wheel_angle": "deg", "yaw_rate": "deg/s", "lateral_acceleration": "g",
         "vehicle_speed": "km/h", "wheel_speed_front": "rpm", "wheel_speed_rear": "rpm",
         "sideslip_ref": "deg", "vy_ref": "m/s", "yaw_rate_ref": "deg/s"}


def fmu_dir():
    target = os.environ.get("CARGO_TARGET_DIR")
    directory = ((ROOT / target) if target else (ROOT / "target")).resolve() / "fmu"
    if not (directory / "VehicleStateEstimator.fmu").is_file():
        pytest.fail(f"{directory} has no VehicleStateEstimator.fmu: `cargo run --release -p packaging`", pytrace=False)
    return directory


def write_mf4(path, units):
    """The example CSV as an MF4: the 10-ms signals in one group, the 20-ms wheel speeds in another."""
    log = np.genfromtxt(LOGS / "ford_escort_sis.csv", delimiter=",", names=True, dtype=float)
    fast, slow = [], []
    for name, unit in units.items():
        present = np.isfinite(log[name])
        signal = Signal(log[name][present], log["time"][present], name=name, unit=unit)
        (slow if name.startswith("wheel_speed") else fast).append(signal)
    mdf = MDF(version="4.10")
    mdf.append(fast, comment="10 ms")
    mdf.append(slow, comment="20 ms")
    mdf.save(path, overwrite=True, compression=0)


def replay(harness, log, out):
    return subprocess.run([str(harness), "replay", str(log), "--map", str(LOGS / "ford_escort_sis.toml"),
                           "--out", str(out), "--fmu-dir", str(fmu_dir()), "--no-plots"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)


def test_an_asammdf_log_replays_as_its_csv(workspace_executables, tmp_path):
    harness = workspace_executables[("bin", "harness")]
    mf4 = tmp_path / "drive.mf4"
    write_mf4(mf4, UNITS)
    from_mf4 = replay(harness, mf4, tmp_path / "mf4")
    assert from_mf4.returncode == 0, from_mf4.stderr
    from_csv = replay(harness, LOGS / "ford_escort_sis.csv", tmp_path / "csv")
    assert from_csv.returncode == 0, from_csv.stderr
    ours = np.genfromtxt(tmp_path / "mf4" / "estimates.csv", delimiter=",", names=True, deletechars="")
    theirs = np.genfromtxt(tmp_path / "csv" / "estimates.csv", delimiter=",", names=True, deletechars="")
    for name in ("time", "input.steering_angle", "input.omega_front_meas", "sideslip_est", "yaw_rate_est"):
        assert np.array_equal(ours[name], theirs[name], equal_nan=True), name


def test_a_channel_in_another_unit_than_the_map_says_is_refused(workspace_executables, tmp_path):
    mf4 = tmp_path / "radians.mf4"
    write_mf4(mf4, {**UNITS, "yaw_rate": "rad/s"})
    completed = replay(workspace_executables[("bin", "harness")], mf4, tmp_path / "out")
    assert completed.returncode != 0
    assert 'channel "yaw_rate" in "rad/s"' in completed.stderr and "ford_escort_sis.toml, line" in completed.stderr, completed.stderr
