"""The gyro's offset through fmpy and the C ABI (fmu-src/vehicle-state-estimator/src/
yaw_rate_offset.rs): a car parked with its wheels turned, whose gyro reads an offset and noise.
Standing still its yaw rate is 0, so the learner is a scalar Kalman filter of the offset b, a
Gauss-Markov process, measured by yaw_rate_meas with the gyro's noise and the steering
geometry's uncertainty at the measured speed's noise: checked sample by sample against
filterpy's KalmanFilter as the oracle, on yaw_rate_offset_est. With yaw_rate_offset_std = 0 the
output stays 0 and yaw_rate_est is the unlearned gyro's."""

import numpy as np

import fmu_support as support

STEP = 0.01
SAMPLES = 200
OFFSET = 0.006  # rad/s
STEERING = 0.3  # rad, parked with the wheels turned
# yaw_rate_offset.rs, not FMU variables: the offset's correlation time, the steering geometry's
# error as a yaw rate while creeping
TIME_CONSTANT = 600.0
CREEP_REFERENCE_STD = 0.002


def gyro():
    rng = np.random.default_rng(21)
    return OFFSET + rng.normal(0.0, 0.0035, SAMPLES)


def run(estimator, estimator_dir, parameters):
    """The default estimator (the grip model's EKF) standing still; yaw_rate_offset_est after
    every sample."""
    filt = support.Slave(estimator, estimator_dir, "gyro_offset")
    rows = []
    try:
        filt.initialise({"sample_time": STEP, **parameters})
        outputs = filt.real_references(["yaw_rate_offset_est"])
        for k, yaw_rate in enumerate(gyro()):
            filt.set({"steering_angle": STEERING, "yaw_rate_meas": yaw_rate, "ay_meas": 0.02,
                      "omega_front_meas": 0.0, "omega_rear_meas": 0.0, "vx_meas": 0.0,
                      "ax_meas": 0.0})
            filt.fmu.doStep(currentCommunicationPoint=k * STEP, communicationStepSize=STEP)
            rows.append(filt.fmu.getReal(outputs)[0])
    finally:
        filt.free()
    return np.array(rows)


def oracle(estimator):
    """filterpy's filter of b: F = a = exp(-T / tau), Q = sigma_b^2 (1 - a^2), H = 1 and
    R = sigma_gyro^2 + (sigma_vx tan(delta) / l)^2 + CREEP_REFERENCE_STD^2 (the reference,
    vx tan(delta) / l at the measured speed 0, is 0), from b = 0 with variance sigma_b^2; each
    sample predicts, then updates."""
    wheelbase = estimator.start("cog_to_front_axle") + estimator.start("cog_to_rear_axle")
    speed_std = estimator.start("measurement_noise_std_vx")
    kf = support.gauss_markov_offset_filter(
        estimator.start("yaw_rate_offset_std"), TIME_CONSTANT, STEP,
        estimator.start("measurement_noise_std_yaw_rate")**2
        + (speed_std * np.tan(STEERING) / wheelbase)**2
        + CREEP_REFERENCE_STD**2)
    rows = []
    for z in gyro():
        kf.predict()
        kf.update(np.array([[z]]))
        rows.append(kf.x[0, 0])
    return np.array(rows)


def test_standing_still_the_offset_is_filterpys_kalman_filter(estimator, estimator_dir):
    assert estimator.start("yaw_rate_offset_std") == 0.005
    fmu = run(estimator, estimator_dir, {})
    np.testing.assert_allclose(fmu, oracle(estimator), rtol=1e-12, atol=1e-15)
    assert abs(fmu[-1] - OFFSET) < 0.001, fmu[-1]


def test_without_the_learner_the_output_stays_zero(estimator, estimator_dir):
    fmu = run(estimator, estimator_dir, {"yaw_rate_offset_std": 0.0})
    np.testing.assert_array_equal(fmu, np.zeros(SAMPLES))
