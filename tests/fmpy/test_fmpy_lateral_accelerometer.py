"""The lateral accelerometer's offset through fmpy and the C ABI (fmu-src/vehicle-state-estimator/
src/lateral_accelerometer.rs): a car driving straight at 20 m/s whose ay_meas reads an offset and
noise. Straight, its lateral acceleration is the kinematic r vx with the gyro's r, so with the
gain not learned (ay_gain_std 0, the default) the learner is a scalar Kalman filter of the offset
b, a Gauss-Markov process, measured by ay_meas - r vx: checked sample by sample against
filterpy's KalmanFilter as the oracle, on ay_offset_est. The gyro's own learner is switched off
(yaw_rate_offset_std 0) so that r is yaw_rate_meas."""

import numpy as np

import fmu_support as support

STEP = 0.01
SAMPLES = 30_000  # five minutes: a road's crossfall hides an offset for seconds
SPEED = 20.0
OFFSET = 0.25  # m/s2
# lateral_accelerometer.rs, not FMU variables: the correlation time of the offset, what is left
# of dvy/dt in a quasi-steady state and a straight road's crossfall (std, correlation time)
TIME_CONSTANT = 600.0
QUASI_STEADY_STD = 0.1
QUASI_STEADY_TIME = 0.5
ROAD_CROSSFALL_ACCELERATION = 0.25
ROAD_CROSSFALL_TIME = 5.0


def sensors():
    rng = np.random.default_rng(31)
    yaw_rate = rng.normal(0.0, 0.0035, SAMPLES)
    ay = OFFSET + rng.normal(0.0, 0.1, SAMPLES)
    return yaw_rate, ay


def run(estimator, estimator_dir):
    """The default estimator (the grip model's EKF) driving straight; ay_offset_est and
    ay_gain_est after every sample."""
    filt = support.Slave(estimator, estimator_dir, "ay_offset")
    rows = []
    try:
        # the noise learner off: over five minutes its running variance of ay rises above the
        # parameter's now and then, and the learner then tests against it (the oracle's R is
        # the parameter's)
        filt.initialise({"sample_time": STEP, "yaw_rate_offset_std": 0.0,
                         "learn_measurement_noise": False})
        outputs = filt.real_references(["ay_offset_est", "ay_gain_est"])
        wheel = SPEED / estimator.start("wheel_radius_front")
        for k, (yaw_rate, ay) in enumerate(zip(*sensors())):
            filt.set({"steering_angle": 0.0, "yaw_rate_meas": yaw_rate, "ay_meas": ay,
                      "omega_front_meas": wheel, "omega_rear_meas": wheel, "vx_meas": SPEED,
                      "ax_meas": 0.01})
            filt.fmu.doStep(currentCommunicationPoint=k * STEP, communicationStepSize=STEP)
            rows.append(filt.fmu.getReal(outputs))
    finally:
        filt.free()
    return np.array(rows)


def oracle(estimator):
    """filterpy's filter of b: F = a = exp(-T / tau), Q = sigma_b^2 (1 - a^2), H = 1, the
    measurement ay_meas - r vx with R = sigma_ay^2 + (vx sigma_r)^2 + 2 tau_q sigma_q^2 / T
    + 2 tau_c sigma_c^2 / T (the crossfall), from b = 0 with variance sigma_b^2. The first sample only predicts: the quasi-steady test needs
    one sample to compare with."""
    kf = support.gauss_markov_offset_filter(
        estimator.start("ay_offset_std"), TIME_CONSTANT, STEP,
        estimator.start("measurement_noise_std_ay")**2
        + (SPEED * estimator.start("measurement_noise_std_yaw_rate"))**2
        + 2.0 * QUASI_STEADY_TIME * QUASI_STEADY_STD**2 / STEP
        + 2.0 * ROAD_CROSSFALL_TIME * ROAD_CROSSFALL_ACCELERATION**2 / STEP)
    rows = []
    for k, (yaw_rate, ay) in enumerate(zip(*sensors())):
        kf.predict()
        if k > 0:
            kf.update(np.array([[ay - yaw_rate * SPEED]]))
        rows.append(kf.x[0, 0])
    return np.array(rows)


def test_driving_straight_the_offset_is_filterpys_kalman_filter(estimator, estimator_dir):
    assert estimator.start("ay_offset_std") == 0.2
    assert estimator.start("ay_gain_std") == 0.0
    fmu = run(estimator, estimator_dir)
    np.testing.assert_allclose(fmu[:, 0], oracle(estimator), rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(fmu[:, 1], np.zeros(SAMPLES))
    assert abs(fmu[-1, 0] - OFFSET) < 0.1, fmu[-1, 0]
