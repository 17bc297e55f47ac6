"""The grip model's accelerometer gain through fmpy and the C ABI (fmu-src/estimation/src/models/
single_track_grip.rs, "The accelerometer's gain"; fmu-src/vehicle-state-estimator/README.md,
"The accelerometer gain in the grip filter"). The ReferenceVehicle's full vehicle, the Ford
Escort, with series sensor noise and an accelerometer that rolls with the body
(gravity_in_accelerometers), drives a step steer. The estimator (the grip model, the car's basic
data only) with ay_gain_std 0.1 estimates the gain as a state of its filter. The oracle for the
gain is the reference's own reading: the least-squares ratio of its ay_meas to its true ay in
the steady corner."""

import numpy as np
import pytest

import fmu_support as support
from test_fmpy_reference_model3 import read_ssv
from test_fmpy_robustness import ESCORT, SERIES_SENSOR_NOISE, STEP, model_a_parameters

SPEED = 65.0 / 3.6
STEER = 0.045  # rad at the road wheels, about 5 m/s^2 on the Escort
STEER_AT = 1.0
DURATION = 6.0
STEADY_FROM = 3.0


def step_steer(vehicle, vehicle_dir, estimator, estimator_dir, kind, ay_gain_std,
               yaw_moment_error_std=None):
    """The roll-gravity step steer; arrays per name: the truth's ay, ay_meas and sideslip and the
    estimator's sideslip_est and ay_gain_est, after every step."""
    truth = support.Slave(vehicle, vehicle_dir, "rolling_escort")
    filt = support.Slave(estimator, estimator_dir, "gain")
    names = ["ay", "ay_meas", "sideslip", "sideslip_est", "ay_gain_est"]
    try:
        car = read_ssv(ESCORT, vehicle)
        truth.initialise({**car, **SERIES_SENSOR_NOISE, "noise": True, "vx0": SPEED, "seed": 5,
                          "gravity_in_accelerometers": True})
        filt.initialise({**model_a_parameters(car), "sample_time": STEP,
                         "estimator": support.ESTIMATOR_KINDS[kind],
                         "model": estimator.enumeration_value("model", "single_track_grip"),
                         "ay_gain_std": ay_gain_std,
                         **({} if yaw_moment_error_std is None
                            else {"yaw_moment_error_std": yaw_moment_error_std})})
        sensor_refs = truth.real_references(support.SENSOR_SIGNALS)
        truth_refs = truth.real_references(names[:3])
        estimate_refs = filt.real_references(names[3:])
        rows = []
        for k in range(int(round(DURATION / STEP))):
            t = k * STEP
            steering = STEER if t >= STEER_AT else 0.0
            truth.set({"steering_angle": steering})
            sensors = dict(zip(support.SENSOR_SIGNALS, truth.fmu.getReal(sensor_refs)))
            filt.set({"steering_angle": steering, **sensors})
            truth.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            filt.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            rows.append([t + STEP, *truth.fmu.getReal(truth_refs),
                         *filt.fmu.getReal(estimate_refs)])
    finally:
        truth.free()
        filt.free()
    table = np.array(rows)
    return {name: table[:, i] for i, name in enumerate(["time", *names])}


@pytest.mark.parametrize("yaw_moment", ["off", "default"])
@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_the_grip_filter_learns_the_gain_the_reference_reads(vehicle, vehicle_dir, estimator,
                                                              estimator_dir, kind, yaw_moment):
    """Learned: ay_gain_est at the end within 0.03 of the reference's ratio, and the sideslip
    RMSE at most half the unlearned one's and below reporting zero. Not learned (ay_gain_std 0,
    the default): ay_gain_est is 0 throughout. Measured here: the reference reads ay 12.5 % high,
    ay_gain_est ends at 0.127; sideslip RMSE (EKF / UKF) with the yaw-moment error off
    (yaw_moment_error_std 0) learned 0.048 / 0.066 deg, ignored 0.289 / 0.290 deg, and at its
    default learned 0.093 / 0.019 deg, ignored 0.296 / 0.295 deg (reporting zero: 0.109 deg)."""
    fmus = (vehicle, vehicle_dir, estimator, estimator_dir, kind)
    yaw_moment_error_std = 0.0 if yaw_moment == "off" else None
    learned = step_steer(*fmus, 0.1, yaw_moment_error_std)
    ignored = step_steer(*fmus, 0.0, yaw_moment_error_std)
    steady = learned["time"] >= STEADY_FROM
    ay, ay_meas = learned["ay"][steady], learned["ay_meas"][steady]
    read = float(np.dot(ay_meas, ay) / np.dot(ay, ay)) - 1.0
    rmse = {name: support.rmse(run["sideslip_est"], run["sideslip"])
            for name, run in (("learned", learned), ("ignored", ignored))}
    zero = support.rmse(0.0, learned["sideslip"])
    degrees = {name: np.degrees(value) for name, value in rmse.items()}
    print(f"{kind}: the reference reads ay {read:+.4f} high; ay_gain_est at the end "
          f"{learned['ay_gain_est'][-1]:+.4f}; sideslip RMSE learned {degrees['learned']:.3f} "
          f"deg, ignored {degrees['ignored']:.3f} deg, zero {np.degrees(zero):.3f} deg")
    assert 0.08 < read < 0.16, read
    assert abs(learned["ay_gain_est"][-1] - read) < 0.03
    assert rmse["learned"] < 0.5 * rmse["ignored"]
    assert rmse["learned"] < zero
    np.testing.assert_array_equal(ignored["ay_gain_est"], np.zeros(len(ignored["time"])))
