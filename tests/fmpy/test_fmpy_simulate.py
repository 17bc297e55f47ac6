"""Each FMU simulated on its own with fmpy.simulate_fmu and input signals."""

import numpy as np
import pytest
from fmpy import simulate_fmu

import fmu_support as support

STEP = 1e-3


def drive(times, steering):
    zeros = np.zeros_like(times)
    return support.input_table(times, steering_angle=steering, drive_torque=zeros, brake_torque=zeros)


def simulate_vehicle(vehicle_fmu, vehicle, limit, noise, seed=None, step=STEP, outputs=None):
    times = np.arange(0.0, support.MANOEUVRE_DURATION + step / 2, step)
    start_values = support.seed000_vehicle_parameters(vehicle)
    start_values["noise"] = noise
    if seed is not None:
        start_values["seed"] = seed
    return simulate_fmu(str(vehicle_fmu), start_time=0.0, stop_time=support.MANOEUVRE_DURATION,
                        output_interval=step, start_values=start_values,
                        input=drive(times, support.steering_ramp(times, limit)),
                        output=outputs or (support.TRUTH_OUTPUTS + support.SENSOR_SIGNALS))


def test_vehicle_alone_moderate_ramp_without_noise(vehicle_fmu, vehicle):
    result = simulate_vehicle(vehicle_fmu, vehicle, support.MODERATE_RAMP_ANGLE, noise=False, step=0.01)
    time = result["time"]
    assert time[-1] == pytest.approx(support.MANOEUVRE_DURATION)
    for name in support.TRUTH_OUTPUTS + support.SENSOR_SIGNALS:
        assert np.all(np.isfinite(result[name])), f"{name} is not finite"
    # noise = false: the sensor signals are the truth, exactly (the parameter's description).
    for signal in ["yaw_rate", "ay", "omega_front", "omega_rear", "ax", "vx"]:
        assert np.array_equal(result[f"{signal}_meas"], result[signal]), signal
    straight = time < support.STEER_START_TIME
    assert np.max(np.abs(result["vy"][straight])) < 1e-9
    assert np.max(np.abs(result["yaw_rate"][straight])) < 1e-9
    assert result["vx"][straight] == pytest.approx(18.0, abs=1e-6)
    # Left steer, left turn (ISO 8855: positive yaw rate and lateral acceleration).
    end = -1
    assert result["yaw_rate"][end] > 0 and result["ay"][end] > 0
    # SPEC section 3 sanity figure: the moderate ramp settles at ay = 3.65 m/s^2 (000: about 3.7).
    assert result["ay"][end] == pytest.approx(3.65, rel=0.03)
    # Steady cornering: ay = vx * r, sideslip = atan2(vy, vx).
    assert result["ay"][end] == pytest.approx(result["vx"][end] * result["yaw_rate"][end], rel=1e-3)
    assert np.allclose(result["sideslip"], np.arctan2(result["vy"], result["vx"]), atol=1e-12)


def test_vehicle_alone_is_deterministic_per_seed(vehicle_fmu, vehicle):
    outputs = ["vy", "yaw_rate_meas", "ay_meas"]
    first = simulate_vehicle(vehicle_fmu, vehicle, support.HIGH_RAMP_ANGLE, noise=True, seed=7,
                             step=0.01, outputs=outputs)
    again = simulate_vehicle(vehicle_fmu, vehicle, support.HIGH_RAMP_ANGLE, noise=True, seed=7,
                             step=0.01, outputs=outputs)
    other = simulate_vehicle(vehicle_fmu, vehicle, support.HIGH_RAMP_ANGLE, noise=True, seed=8,
                             step=0.01, outputs=outputs)
    for name in outputs:
        assert np.array_equal(first[name], again[name]), f"{name} differs between equal seeds"
        assert not np.array_equal(first[name], other[name]), f"{name} ignores the seed"
    # With noise on, the sensors differ from the truth (white noise of SPEC section 7 size).
    truth = simulate_vehicle(vehicle_fmu, vehicle, support.HIGH_RAMP_ANGLE, noise=True, seed=7,
                             step=0.01, outputs=["yaw_rate", "yaw_rate_meas"])
    error = truth["yaw_rate_meas"] - truth["yaw_rate"]
    noise_std = vehicle.start("noise_std_yaw_rate_meas")
    assert 0.5 * noise_std < np.std(error) < 2.0 * noise_std


def test_estimator_alone_on_recorded_signals(vehicle_fmu, vehicle, estimator_fmu, estimator):
    """The estimator fed from a table: the reference recording of the high-ay ramp (noise on), with
    yaw_rate_meas missing (NaN) for half a second. The table is laid out as a plain co-simulation
    loop would feed it: during the step from t to t + h the estimator sees the driver input of t and
    the measurements the vehicle produced at t + h."""
    recording = simulate_vehicle(vehicle_fmu, vehicle, support.HIGH_RAMP_ANGLE, noise=True)
    times = recording["time"][:-1]
    signals = {name: recording[name][1:].copy() for name in support.SENSOR_SIGNALS}
    gap = (times >= 6.0) & (times < 6.5)
    signals["yaw_rate_meas"][gap] = np.nan
    zeros = np.zeros_like(times)
    table = support.input_table(times, steering_angle=support.steering_ramp(times, support.HIGH_RAMP_ANGLE),
                                drive_torque=zeros, brake_torque=zeros, **signals)
    result = simulate_fmu(str(estimator_fmu), start_time=0.0, stop_time=support.MANOEUVRE_DURATION,
                          output_interval=STEP, input=table,
                          start_values=support.seed000_estimator_parameters(estimator, vehicle, "ekf"),
                          output=support.ESTIMATE_OUTPUTS)
    assert len(result) == len(recording)
    for name in support.ESTIMATE_OUTPUTS:
        assert np.all(np.isfinite(result[name])), f"{name} became non-finite"
    status = result["status"].astype(int)
    # Status bit 1: a measurement row was skipped. Rows are indexed by the step that ends there.
    in_gap = np.concatenate([[False], gap])
    assert np.all(status[in_gap] & 1), "the missing yaw rate was not reported in status"
    assert not np.any(status[(recording["time"] < 6.0)] & 1)
    outside = ~((recording["time"] >= 6.0) & (recording["time"] < 7.0))
    error = support.rmse(result["vy_est"][outside], recording["vy"][outside])
    during = support.rmse(result["vy_est"][in_gap], recording["vy"][in_gap])
    print(f"EKF alone: vy RMSE {error:.3g} m/s outside the gap, {during:.3g} m/s while yaw rate missing")
    assert error < 1e-3, f"EKF vy RMSE {error:.3g} m/s on the recorded high-ay ramp"
    assert during < 1e-2, f"EKF vy RMSE {during:.3g} m/s while the yaw rate is missing"
