"""A sensor input the master leaves unconnected is read as missing, never as a measurement of its
start value, whichever importer runs the FMU: the estimator's sensor inputs start at NaN, the
value it reads as "no sample".

ReferenceVehicle and VehicleStateEstimator at their defaults are coupled in a plain fmpy loop
(`libcosim_order_loop`, libcosim's call order, so that tests/libcosim can compare with the same
loop) with the wheel speeds, or in a second case the longitudinal accelerometer, never set. That
run must give the outputs, bit for bit, of the loop that sets those inputs to NaN at every step,
which a master does for a sensor it has no signal of; they differ from the run with every sensor
connected, so the inputs are in use and the comparison can fail. The estimates must still follow
the reference's truth. The first doStep tells the importer once which measurement-row sensor never
had a value, with the status fmi2OK: a warning status would stop importers such as FMI++ from
advancing their clock. vx_meas and ax_meas are optional (the filter falls back on the wheels and
on unknown torques), so leaving them out is no notice."""

import numpy as np
import pytest

import fmu_support as support

STEPS = 2500  # 2.5 s: the ramp to the high-ay angle and 0.8 s held there
OK = 0  # fmi2OK
# The sensors of the estimator's measurement rows, named by the first doStep when never set.
NOTIFIED = ("yaw_rate_meas", "ay_meas", "omega_front_meas", "omega_rear_meas")
UNCONNECTED = {
    "wheel_speeds": ("omega_front_meas", "omega_rear_meas"),
    "ax": ("ax_meas",),
}


def connected_sensors(vehicle, estimator, unconnected):
    return [name for name in support.sensor_connections(vehicle, estimator)
            if name not in unconnected]


def assert_estimates_follow_the_truth(rows, names):
    """The speed and sideslip estimates of a coupled run against the reference's truth: finite,
    the speed within 2 % at every step, and the sideslip's RMSE below a fifth of the zero-sideslip
    estimate's (the truth's RMS, which must be large enough to tell the two apart)."""
    column = {name: rows[:, index] for index, name in enumerate(names)}
    vx, vx_est = column[f"{support.VEHICLE}.vx"], column[f"{support.ESTIMATOR}.vx_est"]
    sideslip = column[f"{support.VEHICLE}.sideslip"]
    sideslip_est = column[f"{support.ESTIMATOR}.sideslip_est"]
    assert np.all(np.isfinite(vx_est)) and np.all(np.isfinite(sideslip_est))
    speed_error = np.max(np.abs(vx_est - vx) / vx)
    assert speed_error < 0.02, f"vx_est off by up to {speed_error:.2%} of vx, expected below 2 %"
    baseline = support.rmse(np.zeros_like(sideslip), sideslip)
    error = support.rmse(sideslip_est, sideslip)
    assert baseline > 0.01, f"the car hardly slips (sideslip RMS {baseline:.3g} rad)"
    assert error < 0.2 * baseline, (f"sideslip RMSE {error:.3g} rad, expected below a fifth of "
                                    f"zero sideslip's {baseline:.3g} rad")


@pytest.fixture(scope="module")
def connected(vehicle, estimator, vehicle_dir, estimator_dir):
    """The run with every sensor connected."""
    rows, _ = support.libcosim_order_loop(vehicle, estimator, vehicle_dir, estimator_dir, STEPS)
    return rows


@pytest.fixture(scope="module", params=list(UNCONNECTED))
def runs(request, vehicle, estimator, vehicle_dir, estimator_dir):
    """One case of UNCONNECTED: the run with the inputs never set and the run with them set to
    NaN, each with the estimator's log."""
    unconnected = UNCONNECTED[request.param]
    sensors = connected_sensors(vehicle, estimator, unconnected)
    unset_log, nan_log = support.LogRecorder(), support.LogRecorder()
    unset, unset_statuses = support.libcosim_order_loop(
        vehicle, estimator, vehicle_dir, estimator_dir, STEPS, sensors,
        estimator_callbacks=unset_log.callbacks)
    nan, nan_statuses = support.libcosim_order_loop(
        vehicle, estimator, vehicle_dir, estimator_dir, STEPS, sensors, missing=unconnected,
        estimator_callbacks=nan_log.callbacks)
    return {"unconnected": unconnected, "log": unset_log.lines, "nan_log": nan_log.lines,
            "unset": unset, "unset_statuses": unset_statuses, "nan": nan,
            "nan_statuses": nan_statuses}


def test_the_first_do_step_names_each_unconnected_sensor_once(runs):
    """The only message of the whole run (logging off, fmpy's default) comes from the first doStep,
    with the status fmi2OK, and names each unconnected measurement-row sensor once and no other
    sensor; a sensor set to NaN throughout, never having had a value either, gets the same."""
    assert runs["nan_log"] == runs["log"]
    expected = [name for name in runs["unconnected"] if name in NOTIFIED]
    assert len(runs["log"]) == (1 if expected else 0), runs["log"]
    for status, category, message in runs["log"]:
        assert status == OK, f"logged with status {status}, expected fmi2OK: {message}"
        assert category == "logStatusWarning", category
        assert message.startswith("fmi2DoStep at t = 0:"), message
        for name in support.SENSOR_SIGNALS:
            count = message.count(f"{name} not connected: treated as missing")
            assert count == (1 if name in expected else 0), f"{name} named {count} times: {message}"


def test_every_step_returns_ok(runs):
    for run in ("unset_statuses", "nan_statuses"):
        assert runs[run].shape == (STEPS, 2)
        assert np.all(runs[run] == OK), f"{run}: statuses {np.unique(runs[run]).tolist()}"


def test_an_unconnected_input_is_a_nan_on_every_step(runs, connected, vehicle, estimator):
    names = support.compared_output_names(vehicle, estimator)
    support.assert_bit_identical(runs["unset"], runs["nan"], names, "fmpy, inputs never set")
    estimates = [index for index, name in enumerate(names) if name.startswith(support.ESTIMATOR)]
    assert not np.array_equal(runs["unset"][:, estimates], connected[:, estimates]), \
        f"{runs['unconnected']} connected or not, the estimator's outputs are the same"


def test_the_estimates_follow_the_truth(runs, vehicle, estimator):
    names = support.compared_output_names(vehicle, estimator)
    assert_estimates_follow_the_truth(runs["unset"], names)
