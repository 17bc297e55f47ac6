"""Tests on one `harness demo` run, asserted on the harness's own output: the seed-000 findings
(SPEC section 7, seed 000 ch. 7), the demo's findings table and the key numbers recomputed here
from its CSV recordings; and the model-mismatch study as shipped
(harness/studies/src/mismatch.rs): the demo runs its whole pipeline, and this module is the one
test of that pipeline (the Rust tests of harness/studies check its EM alone,
mismatch_identification.rs), so a test run computes it once.

The demo is the longest piece of the Python tests, so it runs a representative subset of its two
slowest studies: the mismatch campaigns on one car (`--cars ford_escort`: every manoeuvre and
reference model, 17 of the 51 runs; the other cars' runs are in the Rust tests of harness/studies
and in the committed docs/data/campaigns_sideslip.csv) and the model-mismatch EM cut to 4 of its
20 SQUAREM cycles (`--em-cycles 4`, after which every bound below holds with a margin of 0.08;
the EM's path is deterministic, so these are exactly the shipped study's first 4 cycles).
Everything that reads the demo is in this one module: with `pytest -n 2 --dist loadscope`
(tests/run.sh) one worker runs the demo once, and the marker `starts_first` (tests/conftest.py)
hands it out first, so the other worker runs the remaining modules meanwhile."""

import csv
import re

import numpy as np
import pytest

from harness_support import run_harness

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
    completed = run_harness(harness_binary, "demo", "--out", out, "--fmu-dir", fmu_dir,
                            "--cars", "ford_escort", "--em-cycles", "4", timeout=1800)
    (out / "console.txt").write_text(completed.stderr)
    return out


def test_demo_writes_both_reports_and_the_figures(demo):
    md = (demo / "report.md").read_text()
    html = (demo / "report.html").read_text()
    assert "Seed 000" in md and "<table>" in html
    pngs = list(demo.glob("*.png"))
    assert len(pngs) >= 10
    # Nothing outside the output folder: the extraction folder is gone too.
    assert not (demo / ".fmu-work").exists()


def test_the_report_opens_with_the_answer_and_its_figure(demo):
    """The first section is the accuracy summary: its figure exists and comes before the seeds'
    reproduction, and the rows it was drawn from are the accuracy CSV format."""
    md = (demo / "report.md").read_text()
    answer = md.index("## The answer")
    assert answer < md.index("## The seed experiments")
    assert md.index("](accuracy.png)") < md.index("## The seed experiments")
    assert (demo / "accuracy.png").stat().st_size > 10_000
    with open(demo / "accuracy_simulated.csv", newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["source", "case", "model", "estimator", "wheel_speeds", "rmse_deg", "nees",
                       "zero_rmse_deg", "yardstick_rmse_deg", "max_vx_error_mps"]
    assert len(rows) > 100 and {r[2] for r in rows[1:]} == {"A", "B", "A+grip"}
    assert {r[1].split()[0] for r in rows[1:]} == {"ford_escort"}
    assert "**Not the shipped campaigns**: on ford_escort only (`--cars`)." in md


def test_the_demo_prints_no_fmu_warning_and_reports_the_expected_ones(demo):
    """The project's own manoeuvres feed the FMUs nothing out of range; the robustness case that
    does so on purpose records its warnings in the report instead of on the console."""
    console = (demo / "console.txt").read_text()
    assert "[FMU" not in console, [line for line in console.splitlines() if "[FMU" in line][:5]
    md = (demo / "report.md").read_text()
    assert "Case `out_of_range` feeds inputs outside their declared range on purpose" in md
    assert "steering_angle" in md.split("Case `out_of_range` feeds inputs")[1][:5000]


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


# The model-mismatch study: model A's cornering-stiffness scales identified by EM from a model-B
# ReferenceVehicle run, scored with the EKF and UKF on the held-out manoeuvres (the seed-001 40°
# step steer and the ISO 3888-1 double lane change), all through the FMUs. The EM is nearly all of
# the study's time, so the demo's 4 cycles are its only run in a test run (no Rust test repeats
# it). Measured path of the shipped study (cycle: k_F, k_R): 1: 0.936, 1.033; 2: 0.904, 1.005;
# 3: 0.893, 0.991; 4: 0.885, 0.980; ... 20: 0.792, 0.845.
MISMATCH_VALIDATION_SCENARIOS = ["mismatch_validation_step_steer", "mismatch_validation_lane_change"]
MISMATCH_ESTIMATORS = ["EKF", "UKF"]


def mismatch_finding(demo):
    with open(demo / "findings.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f)
                if r["seed"] == "beyond" and r["experiment"].startswith("model mismatch")]
    assert len(rows) == 1, rows
    return rows[0]["we_measure"]


def test_mismatch_em_moves_both_scales_below_one_the_front_the_more(demo):
    # The EM with the study's 100 particles stops unconverged near k_F 0.79, k_R 0.85 after its 20
    # cycles and reaches 0.885, 0.980 after the 4 run here (mismatch.rs, `identification_config`,
    # records why). What must hold whatever it finds: it moves both
    # scales down from their start 1 (model B's load transfer softens both axles against model
    # A's linear tyre), the front the more. A failed study has no such line in the findings.
    measured = mismatch_finding(demo)
    match = re.search(r"identified k_F = ([0-9.]+), k_R = ([0-9.]+)", measured)
    assert match, measured
    front, rear = map(float, match.groups())
    assert 0.7 <= front < 0.97, measured
    assert 0.75 <= rear < 1.1, measured
    assert front < rear, measured


@pytest.mark.parametrize("scenario", MISMATCH_VALIDATION_SCENARIOS)
def test_mismatch_held_out_runs_are_scored_with_scales_1_and_the_identified_scales(demo, scenario):
    seed = read_columns(demo / "mismatch" / "seed_scales" / f"{scenario}.csv")
    identified = read_columns(demo / "mismatch" / "identified_scales" / f"{scenario}.csv")
    # The ReferenceVehicle's seed is the same in both runs: the same truth, the scales alone differ.
    truth = seed["vehicle.sideslip"]
    np.testing.assert_array_equal(identified["vehicle.sideslip"], truth)
    assert np.max(np.abs(truth)) > np.radians(0.1)
    for estimator in MISMATCH_ESTIMATORS:
        with_seed_scales = seed[f"{estimator}.sideslip_est"]
        with_identified = identified[f"{estimator}.sideslip_est"]
        # With the seed's tyre (scales 1) model A's EKF and UKF stay within a fraction of a
        # degree of model B's sideslip (measured 0.113 deg on the step steer, 0.023 deg on the
        # lane change); with the identified scales the run is scored too (finite errors).
        assert np.degrees(rmse(with_seed_scales, truth)) < 0.2, estimator
        assert np.isfinite(rmse(with_identified, truth)), estimator
        # The identified scales reached the estimator FMUs as parameters.
        assert not np.array_equal(with_identified, with_seed_scales), estimator


STATES = ("vx", "vy", "yaw_rate", "omega_front", "omega_rear", "sideslip")


def test_the_consistency_section_shows_the_kalman_filters_honest_and_at_the_bound(demo):
    """Consistency where the model is right, on the demo's Monte Carlo of the matched seed-000
    high-ay ramp: every state's ANEES of the EKF and both UKFs inside its 95 % band, their RMSE
    within 10 % of sqrt(PCRLB) and their mean NIS per row near 1; the LKF, linearised once at the
    start, is neither (seed 000's own finding). The scenario is named relative to the workspace."""
    md = (demo / "report.md").read_text()
    section = md.split("## Consistency and the Cramér-Rao bound")[1].split("\n## ")[0]
    assert "`harness/scenarios/seed000_ramp_high_ay.toml`" in section, section[:400]
    cells = [[c.strip() for c in line.strip().strip("|").split("|")]
             for line in section.splitlines() if line.startswith("| ")]
    states = {(r[0], r[1]): r for r in cells if len(r) == 8 and "±" in r[7]}
    nis = {r[0]: r for r in cells if len(r) == 3 and r[2].endswith("%")}
    for estimator in ("EKF", "UKF", "UKF_scaled"):
        for state in STATES:
            row = states[(estimator, state)]
            assert row[3] == "inside", row
            assert float(row[7].split("±")[0]) <= 1.10, row
        assert abs(float(nis[estimator][1]) - 1.0) < 0.1, nis[estimator]
    assert all(states[("LKF", state)][3] == "outside" for state in STATES)
