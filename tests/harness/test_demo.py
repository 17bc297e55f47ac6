"""Tests on one `harness demo` run, asserted on the harness's own output: the seed-000 findings
(SPEC section 7, seed 000 ch. 7), the demo's findings table and the key numbers recomputed here
from its CSV recordings.

The demo is the longest piece of the Python tests (about 75 s on a 2-core machine, most of it the
model-mismatch study's EM), so everything that reads it is in this one module: with
`pytest -n 2 --dist loadscope` (tests/run.sh) one worker runs the demo once, and the marker
`starts_first` (tests/conftest.py) hands it out first, so the other worker runs the remaining
modules meanwhile (issue 11 point 7)."""

import csv

import numpy as np
import pytest

from conftest import run_harness

pytestmark = pytest.mark.starts_first


def read_columns(path):
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        data = np.array([[float(x) for x in row] for row in reader])
    return {name: data[:, i] for i, name in enumerate(header)}


def rmse(a, b, mask=None):
    e = a - b
    if mask is not None:
        e = e[mask]
    return float(np.sqrt(np.mean(e * e)))


@pytest.fixture(scope="module")
def demo(fmu_dir, harness_binary, tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    run_harness(harness_binary, "demo", "--out", out, "--fmu-dir", fmu_dir, timeout=1800)
    return out


def test_demo_writes_both_reports_and_the_figures(demo):
    md = (demo / "report.md").read_text()
    html = (demo / "report.html").read_text()
    assert "Seed 000" in md and "<table>" in html
    pngs = list(demo.glob("*.png"))
    assert len(pngs) >= 10
    # Nothing outside the output folder: the extraction folder is gone too.
    assert not (demo / ".fmu-work").exists()


STEP_STEER = "7.3 2° steering step"


def seed000_findings(demo):
    with open(demo / "findings.csv", newline="") as f:
        return [r for r in csv.DictReader(f) if r["seed"] == "000"]


def test_seed000_findings_agree(demo):
    rows = seed000_findings(demo)
    assert len(rows) >= 6
    differing = [f"{r['experiment']}: {r['we_measure']}" for r in rows
                 if r["agrees"] != "yes" and r["experiment"] != STEP_STEER]
    assert not differing, differing


@pytest.mark.xfail(strict=True, reason="documented disagreement (report.md): at T = 50 ms our EKF and "
                   "UKF give the same vy error at the 2 deg step (EKF/UKF RMSE ratio 1.00 over 4-5 s), "
                   "the seed shows the EKF lagging; strict, so a change in the filters that makes it "
                   "agree is noticed")
def test_seed000_step_steer_ekf_lags_ukf_at_50ms(demo):
    row = next(r for r in seed000_findings(demo) if r["experiment"] == STEP_STEER)
    assert row["agrees"] == "yes", row["we_measure"]


def test_high_ay_ramp_numbers_from_the_recording(demo):
    c = read_columns(demo / "seed000_ramp_high_ay.csv")
    truth = c["vehicle.vy"]
    lkf, ekf, ukf = (rmse(c[f"{e}.vy_est"], truth) for e in ("LKF", "EKF", "UKF"))
    # LKF far off, EKF ~ UKF ~ truth (000 ch. 7.2).
    assert lkf > 10 * max(ekf, ukf)
    assert max(ekf, ukf) < 1e-3
    assert 0.5 < ekf / ukf < 2.0
    # Q = 1e-2 I: no significant improvement.
    assert rmse(c["LKF_Q1e-2.vy_est"], truth) > 0.5 * lkf


def test_moderate_ramp_lkf_drifts_slightly_after_6s(demo):
    c = read_columns(demo / "seed000_ramp_moderate_ay.csv")
    t, truth = c["time"], c["vehicle.vy"]
    before, after = rmse(c["LKF.vy_est"], truth, t < 6.0), rmse(c["LKF.vy_est"], truth, t >= 6.0)
    assert after > before
    assert rmse(c["LKF.vy_est"], truth) < 0.25 * np.max(np.abs(truth))
    # ay settles near 3.7 m/s2 (seed) / 3.65 (SPEC's independent implementation).
    assert abs(np.mean(c["vehicle.ay"][t >= 10.0]) - 3.65) < 0.2


def test_braking_makes_the_lkf_worse_after_9s(demo):
    braking = read_columns(demo / "seed000_ramp_high_ay_braking.csv")
    plain = read_columns(demo / "seed000_ramp_high_ay.csv")
    window = braking["time"] >= 9.0
    assert rmse(braking["LKF.vy_est"], braking["vehicle.vy"], window) > \
        rmse(plain["LKF.vy_est"], plain["vehicle.vy"], window)
    ax = np.mean(braking["vehicle.ax"][braking["time"] >= 11.0])
    assert -5.0 < ax < -3.0
