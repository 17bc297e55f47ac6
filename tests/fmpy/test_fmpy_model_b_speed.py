"""Through fmpy and the C ABI: model B's speed with a measured ax, and the speed
model A reports, are the Kalman filter of dvx/dt = ax - b + r vy with the accelerometer's offset b
as a second state (fmu-src/vehicle-state-estimator/src/speed_filter.rs), checked sample by sample
against filterpy's KalmanFilter as the oracle on straight braking (r vy = 0, the car straight, so
the offset is updated and the filter is filterpy's with x = [vx, b], F = [[1, -T], [0, a]],
B = [T, 0], H = [1, 0]). Without ax_meas (its start value NaN, an unconnected input) model B's
vx_est is the measured speed and vx_std measurement_noise_std_vx."""

import pytest

import numpy as np
from filterpy.kalman import KalmanFilter

import fmu_support as support

STEP = 0.01
AX = -3.0
SPEED0 = 22.0
Q_STD = 0.005  # process_noise_std_vx, the FMU's default
R_STD = 0.1  # measurement_noise_std_vx, the FMU's default
OFFSET_STD = 0.2  # ax_offset_std, the FMU's default
# speed_filter::AX_OFFSET_TIME_CONSTANT, the offset's correlation time (not an FMU variable)
OFFSET_TIME_CONSTANT = 600.0
SAMPLES = 300


def measured_speeds():
    rng = np.random.default_rng(12)
    truth = SPEED0 + AX * STEP * np.arange(SAMPLES)
    return truth, truth + rng.normal(0.0, 0.05, SAMPLES)


def run_estimator(estimator, estimator_dir, ax, model="two_track_3_state"):
    """The EKF on `model` (default model B) at its defaults braking straight, the torques
    unknown; vx_est and vx_std after every sample."""
    model_b = estimator.enumeration_value("model", model)
    ekf = estimator.enumeration_value("estimator", "ekf")
    filt = support.Slave(estimator, estimator_dir, f"{model}_speed")
    _, measured = measured_speeds()
    rows = []
    try:
        filt.initialise({"model": model_b, "estimator": ekf, "sample_time": STEP})
        outputs = filt.real_references(["vx_est", "vx_std"])
        for k in range(SAMPLES):
            wheel = measured[k] / 0.3
            filt.set({"steering_angle": 0.0, "yaw_rate_meas": 0.0, "ay_meas": 0.0,
                      "omega_front_meas": wheel, "omega_rear_meas": wheel,
                      "vx_meas": measured[k], "ax_meas": ax})
            filt.fmu.doStep(currentCommunicationPoint=k * STEP, communicationStepSize=STEP)
            rows.append(filt.fmu.getReal(outputs))
    finally:
        filt.free()
    return np.array(rows), measured


def oracle(measured):
    """filterpy's Kalman filter of [vx, b], started at the first measured speed with variance R
    and the offset at 0 with variance OFFSET_STD^2, each output its one-step prediction (the
    FMU's outputs are the estimate for the next sample). The offset is a Gauss-Markov process,
    b' = a b with a = exp(-T / tau) and process noise OFFSET_STD^2 (1 - a^2)."""
    decay = np.exp(-STEP / OFFSET_TIME_CONSTANT)
    kf = KalmanFilter(dim_x=2, dim_z=1, dim_u=1)
    kf.F = np.array([[1.0, -STEP], [0.0, decay]])
    kf.B = np.array([[STEP], [0.0]])
    kf.H = np.array([[1.0, 0.0]])
    kf.Q = np.diag([Q_STD**2, OFFSET_STD**2 * (1.0 - decay**2)])
    kf.R = np.array([[R_STD**2]])
    kf.x = np.array([[measured[0]], [0.0]])
    kf.P = np.diag([R_STD**2, OFFSET_STD**2])
    rows = []
    for k, z in enumerate(measured):
        if k > 0:
            kf.predict(u=np.array([[AX]]))
            kf.update(np.array([[z]]))
        ahead = kf.x[0, 0] + STEP * (AX - kf.x[1, 0])
        prior = kf.F @ kf.P @ kf.F.T + kf.Q
        rows.append((ahead, np.sqrt(prior[0, 0])))
    return np.array(rows)


@pytest.mark.parametrize("model", ["two_track_3_state", "single_track_5_state"])
def test_the_speed_is_filterpys_kalman_filter_on_the_kinematics(estimator, estimator_dir, model):
    assert estimator.start("process_noise_std_vx") == Q_STD
    assert estimator.start("measurement_noise_std_vx") == R_STD
    assert estimator.start("ax_offset_std") == OFFSET_STD
    fmu, measured = run_estimator(estimator, estimator_dir, AX, model)
    expected = oracle(measured)
    np.testing.assert_allclose(fmu, expected, rtol=1e-12, atol=1e-12)
    truth, _ = measured_speeds()
    # vx_est is the estimate for the next sample instant
    filtered = support.rmse(fmu[100:-1, 0], truth[101:])
    raw = support.rmse(measured[100:], truth[100:])
    assert filtered < 0.5 * raw, (filtered, raw)


def test_without_ax_model_b_takes_the_measured_speed(estimator, estimator_dir):
    # An unconnected ax_meas starts at NaN: missing.
    assert np.isnan(estimator.start("ax_meas"))
    fmu, measured = run_estimator(estimator, estimator_dir, float("nan"))
    np.testing.assert_array_equal(fmu[:, 0], measured)
    np.testing.assert_array_equal(fmu[:, 1], np.full(SAMPLES, R_STD))
