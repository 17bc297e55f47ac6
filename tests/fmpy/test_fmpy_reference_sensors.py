"""Through fmpy: the ReferenceVehicle's CAN timing per channel (sample period and
latency of each *_meas signal) and the sensor_blanking input, one test per capability. Noise on
with every standard deviation zero, so the chain is deterministic and each value checkable against
the truth the same FMU reports; every value reference comes from the packaged
modelDescription.xml."""

import numpy as np

import fmu_support as support

STEP = 0.001
MEASURED = ["yaw_rate_meas", "ay_meas", "omega_front_meas", "omega_rear_meas", "ax_meas", "vx_meas"]
TRUTH = ["yaw_rate", "ay", "omega_front", "omega_rear", "ax", "vx"]
SILENT = {name: 0.0 for name in [
    "process_noise_std_vx", "process_noise_std_vy", "process_noise_std_yaw_rate",
    "process_noise_std_omega_front", "process_noise_std_omega_rear",
    "noise_std_yaw_rate_meas", "noise_std_ay_meas", "noise_std_omega_front_meas",
    "noise_std_omega_rear_meas", "noise_std_ax_meas", "noise_std_vx_meas"]}


def run(vehicle, vehicle_dir, parameters, steps=300, blanking=lambda t: 0):
    """Steering ramp from t = 0 (so every signal moves); the truth is read after the inputs of
    t_n are set (direct feed-through), the sensors after the step. Returns (truth, measured)
    arrays with one row per step."""
    slave = support.Slave(vehicle, vehicle_dir, "sensors")
    truth_rows, measured_rows = [], []
    try:
        slave.initialise({"noise": True, **SILENT, **parameters})
        truth_refs = slave.real_references(TRUTH)
        measured_refs = slave.real_references(MEASURED)
        for k in range(steps):
            t = k * STEP
            slave.set({"steering_angle": 0.2 * t, "drive_torque": 400.0,
                       "sensor_blanking": blanking(t)})
            truth_rows.append(slave.fmu.getReal(truth_refs))
            slave.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            measured_rows.append(slave.fmu.getReal(measured_refs))
    finally:
        slave.free()
    return np.array(truth_rows), np.array(measured_rows)


def update_steps(column):
    """The step numbers (1-based: after doStep k-1 -> k) at which a signal took a new value."""
    return [k + 1 for k in range(1, len(column)) if column[k] != column[k - 1]]


def test_each_channel_has_its_own_sample_period(vehicle, vehicle_dir):
    _, measured = run(vehicle, vehicle_dir, {
        "sample_period_yaw_rate_meas": 0.01, "sample_period_vx_meas": 0.1})
    yaw, ay, vx = measured[:, 0], measured[:, 1], measured[:, 5]
    assert update_steps(yaw) and all(k % 10 == 0 for k in update_steps(yaw))
    assert update_steps(vx) and all(k % 100 == 0 for k in update_steps(vx))
    # ay keeps the common sensor_sample_period (0: every integration step)
    assert len(update_steps(ay)) > 250


def test_each_channel_has_its_own_latency(vehicle, vehicle_dir):
    truth, measured = run(vehicle, vehicle_dir, {"latency_ay_meas": 0.02})
    delay = 20
    # ay: the truth of 20 steps earlier (the step that ended at k sampled the truth of t_k)
    np.testing.assert_array_equal(measured[delay:-1, 1], truth[1:-delay, 1])
    # yaw rate: the common latency (0) - the sample at the end of the step is the truth there
    np.testing.assert_array_equal(measured[:-1, 0], truth[1:, 0])


def test_the_blanking_input_gives_nan_or_the_stale_value(vehicle, vehicle_dir):
    blank_ay = lambda t: 2 if 0.1 <= t < 0.2 else 0
    for hold_last in (False, True):
        _, measured = run(vehicle, vehicle_dir, {"dropout_hold_last": hold_last},
                          steps=250, blanking=blank_ay)
        blanked = slice(100, 199)  # rows whose doStep started at 0.1 <= t < 0.199
        if hold_last:
            assert np.all(measured[blanked, 1] == measured[99, 1])
        else:
            assert np.all(np.isnan(measured[blanked, 1]))
        assert np.all(np.isfinite(measured[:100, 1])) and np.all(np.isfinite(measured[200:, 1]))
        assert np.all(np.isfinite(measured[:, [0, 2, 3, 4, 5]])), "only ay is blanked"
