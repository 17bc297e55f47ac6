"""Robustness through fmpy and the C ABI: the VehicleStateEstimator with its defaults, on its default
model (the grip model) and on model A, on a car that is not the seed car, the Ford Escort (CommonRoad "vehicle 1", fmu-src/reference-vehicle/cars/
ford_escort.ssv), simulated by the ReferenceVehicle's model 3 (the full vehicle) with its sensor
noise. The estimator gets only the car's model-A parameters (mass, yaw inertia, axle distances,
wheel radius and inertias, brake split, static wheel loads) and is never told the torques.

Cases: torques unknown, wrong start speed, one glitch, a zero row, a 0.5 s outage, braking to a
stop, standing and pulling away; each checks the documented status bits."""

import numpy as np
import pytest

import fmu_support as support
from test_fmpy_reference_model3 import read_ssv

STEP = 0.01
ESCORT = support.ROOT / "fmu-src" / "reference-vehicle" / "cars" / "ford_escort.ssv"
STATUS = {"row_gated": 128, "readmitted": 256, "initialising": 512, "below_min_speed": 32}
TRUTH = ["vx", "vy", "sideslip"]
# Sensor noise of a series car (one sigma): yaw rate 0.2 deg/s, accelerations 0.1 m/s^2, wheel
# speeds 0.1 rad/s, reference speed 0.05 m/s.
SERIES_SENSOR_NOISE = {"noise_std_yaw_rate_meas": 0.0035, "noise_std_ay_meas": 0.1,
                       "noise_std_ax_meas": 0.1, "noise_std_omega_front_meas": 0.1,
                       "noise_std_omega_rear_meas": 0.1, "noise_std_vx_meas": 0.05}
ESTIMATE = ["vx_est", "vy_est", "sideslip_est", "sideslip_std"]
# The estimator models the cases run on: the default (model 3, the grip model) and model A.
MODELS = ["single_track_grip", "single_track_5_state"]


def on(estimator, model):
    """`estimator_extra` for `model`, an item name of the enumeration `model`."""
    return {"model": estimator.enumeration_value("model", model)}


def escort_estimator_parameters(vehicle, kind, extra=None):
    """The Escort's model-A parameters from its parameter file, `extra` on top; everything else
    at its default."""
    parameters = model_a_parameters(read_ssv(ESCORT, vehicle))
    parameters["sample_time"] = STEP
    parameters["estimator"] = support.ESTIMATOR_KINDS[kind]
    parameters.update(extra or {})
    return parameters


def model_a_parameters(car):
    """The estimator's model-A car parameters from a car's parameter-value file (as read_ssv
    reads it): mass, inertias, axle distances, radii, brake split, static wheel loads (the car
    file holds them for the ReferenceVehicle's models 1 and 2)."""
    parameters = {name: car[name] for name in (
        "mass", "yaw_inertia", "cog_to_front_axle", "cog_to_rear_axle",
        "wheel_inertia_front", "wheel_inertia_rear", "brake_distribution_front",
        "wheel_load_front", "wheel_load_rear")}
    # The car file has one radius for all wheels; the estimator takes one per axle.
    parameters["wheel_radius_front"] = parameters["wheel_radius_rear"] = car["wheel_radius"]
    return parameters


def cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, kind, vx0, duration, driver,
               corrupt=lambda t, sensors: None, estimator_extra=None):
    """Model 3 Escort drives `driver(t) -> {input: value}`; the estimator (`estimator_extra` on
    top of its defaults) gets the steering angle only (torques 0) and the sensors after
    `corrupt(t, sensors)`. Returns arrays per name."""
    truth = support.Slave(vehicle, vehicle_dir, "escort")
    filt = support.Slave(estimator, estimator_dir, "estimator")
    try:
        truth.initialise({**read_ssv(ESCORT, vehicle), **SERIES_SENSOR_NOISE, "noise": True,
                          "vx0": vx0, "seed": 5})
        filt.initialise(escort_estimator_parameters(vehicle, kind, estimator_extra))
        sensor_refs = truth.real_references(support.SENSOR_SIGNALS)
        truth_refs = truth.real_references(TRUTH)
        estimate_refs = filt.real_references(ESTIMATE)
        status_ref = [estimator.vr("status")]
        rows = []
        for k in range(int(round(duration / STEP))):
            t = k * STEP
            inputs = driver(t)
            truth.set(inputs)
            sensors = dict(zip(support.SENSOR_SIGNALS, truth.fmu.getReal(sensor_refs)))
            corrupt(t, sensors)
            filt.set({"steering_angle": inputs.get("steering_angle", 0.0), **sensors})
            truth.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            filt.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            rows.append([t + STEP, *truth.fmu.getReal(truth_refs), *filt.fmu.getReal(estimate_refs),
                         filt.fmu.getInteger(status_ref)[0]])
    finally:
        truth.free()
        filt.free()
    table = np.array(rows)
    return {name: table[:, i] for i, name in enumerate(["time", *TRUTH, *ESTIMATE, "status"])}


def sine_with_drive(t):
    """0.03 rad road-wheel sine at 0.5 Hz, the engine pulling with 200 N·m."""
    return {"steering_angle": 0.03 * np.sin(np.pi * t), "drive_torque": 200.0, "brake_torque": 0.0}


def bits(result):
    return int(np.bitwise_or.reduce(result["status"].astype(int)))


def relative_speed_error(result, after=0.0):
    late = result["time"] >= after
    return np.max(np.abs(result["vx_est"][late] - result["vx"][late]) / result["vx"][late])


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_torques_unknown_the_speed_stays_within_two_percent(vehicle, vehicle_dir, estimator,
                                                           estimator_dir, kind, model):
    result = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, kind, 20.0, 6.0,
                        sine_with_drive, estimator_extra=on(estimator, model))
    assert relative_speed_error(result) < 0.02
    # Not worse than reporting a sideslip of zero on another car with the seed car's tyres.
    assert support.rmse(result["sideslip_est"], result["sideslip"]) < support.rmse(0.0, result["sideslip"])
    assert bits(result) & STATUS["initialising"]


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("vx0", [5.0, 35.0, 55.0])
def test_a_wrong_start_speed_is_replaced_by_the_measured_one(vehicle, vehicle_dir, estimator,
                                                             estimator_dir, vx0, model):
    straight = lambda t: {"steering_angle": 0.0, "drive_torque": 0.0, "brake_torque": 0.0}
    result = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, "ekf", vx0, 2.0, straight,
                        estimator_extra=on(estimator, model))
    assert relative_speed_error(result) < 0.02


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("signal, value", [("ay_meas", 100.0), ("omega_front_meas", 1e4),
                                           ("yaw_rate_meas", 2.0), ("all", 0.0)])
def test_one_glitch_or_zero_row_is_gated_and_changes_nothing_much(vehicle, vehicle_dir, estimator,
                                                                  estimator_dir, signal, value,
                                                                  model):
    def glitch(t, sensors):
        if abs(t - 2.0) < 1e-9:
            for name in (support.SENSOR_SIGNALS if signal == "all" else [signal]):
                sensors[name] = value

    clean = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, "ekf", 20.0, 3.0,
                       sine_with_drive, estimator_extra=on(estimator, model))
    glitched = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, "ekf", 20.0, 3.0,
                          sine_with_drive, glitch, estimator_extra=on(estimator, model))
    assert bits(glitched) & STATUS["row_gated"]
    assert np.max(np.abs(glitched["vy_est"] - clean["vy_est"])) < 0.02
    assert np.max(np.abs(glitched["vx_est"] - clean["vx_est"])) < 0.05


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("signal", ["yaw_rate_meas", "ay_meas", "vx_meas", "omega_rear_meas"])
def test_after_a_half_second_outage_the_estimate_is_back_within_a_second(
        vehicle, vehicle_dir, estimator, estimator_dir, signal, model):
    def outage(t, sensors):
        if 1.5 <= t < 2.0:
            sensors[signal] = float("nan")

    clean = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, "ekf", 20.0, 4.0,
                       sine_with_drive, estimator_extra=on(estimator, model))
    cut = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, "ekf", 20.0, 4.0,
                     sine_with_drive, outage, estimator_extra=on(estimator, model))
    back = clean["time"] >= 3.0
    assert np.max(np.abs(cut["vy_est"][back] - clean["vy_est"][back])) < 0.02
    assert np.max(np.abs(cut["vx_est"][back] - clean["vx_est"][back])) < 0.01 * 20.0


@pytest.mark.parametrize("model", MODELS)
def test_braking_to_a_stop_standing_and_pulling_away(vehicle, vehicle_dir, estimator,
                                                     estimator_dir, model):
    def stop_and_go(t):
        if t < 14.0:
            return {"steering_angle": 0.0, "drive_torque": 0.0, "brake_torque": 2500.0}
        return {"steering_angle": 0.0, "drive_torque": 600.0, "brake_torque": 0.0}

    result = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, "ekf", 8.0, 18.0,
                        stop_and_go, estimator_extra=on(estimator, model))
    for name in ESTIMATE:
        assert np.all(np.isfinite(result[name])), name
    standing = (result["time"] > 4.0) & (result["time"] < 14.0)
    assert np.all(result["status"][standing].astype(int) & STATUS["below_min_speed"])
    assert np.max(np.abs(result["sideslip_est"])) < 0.2
    moving = (result["time"] > 16.0) & (result["vx"] > 2.0)
    assert np.any(moving)
    assert np.all(result["status"][moving].astype(int) & STATUS["below_min_speed"] == 0)
    assert np.max(np.abs(result["vx_est"][moving] - result["vx"][moving])) < 0.1 * np.max(result["vx"][moving])


def braking_in_a_turn(t):
    """The campaigns' braked corner (harness/scenarios/campaigns/campaigns.toml): 0.05 rad/s of
    road-wheel angle from 0.5 s up to 0.03 rad at 25 m/s, then 1800 N·m of brake torque ramped in
    over 0.5 s from 3 s and held while turning."""
    brake = 1800.0 * min(max((t - 3.0) / 0.5, 0.0), 1.0)
    return {"steering_angle": min(max(t - 0.5, 0.0) * 0.05, 0.03), "drive_torque": 0.0,
            "brake_torque": brake}


@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_the_grip_model_holds_a_braked_corner_with_the_torques_unknown(
        vehicle, vehicle_dir, estimator, estimator_dir, kind):
    """The grip model (model 3) with only the car's basic data, through fmpy: while the torques
    read 0 its tyre forces are those of freely rolling wheels (fmu-src/estimation/src/models/
    unknown_torques.rs), so the brake it is not told about does not pull its slip angles. Within
    the 0.3 deg a car's sideslip estimate must reach, well inside reporting zero and model A's error, and its std covers the
    error. Measured here: EKF 0.103 deg and UKF 0.099 deg, 96 % inside the 95 % bound, against
    model A's 0.44 / 0.58 deg and zero's 1.49 deg (the Rust campaign: 0.096 deg, NEES 1.03)."""
    grip = {"model": estimator.enumeration_value("model", "single_track_grip")}
    result = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, kind, 25.0, 7.0,
                        braking_in_a_turn, estimator_extra=grip)
    model_a = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, kind, 25.0, 7.0,
                         braking_in_a_turn, estimator_extra=on(estimator, "single_track_5_state"))
    error = result["sideslip_est"] - result["sideslip"]
    rmse = support.rmse(result["sideslip_est"], result["sideslip"])
    assert np.degrees(rmse) < 0.3
    assert rmse < 0.5 * support.rmse(0.0, result["sideslip"])
    assert rmse < support.rmse(model_a["sideslip_est"], model_a["sideslip"])
    inside = np.mean(np.abs(error) <= 1.96 * result["sideslip_std"])
    assert inside > 0.9
    assert relative_speed_error(result) < 0.02


def test_the_grip_model_keeps_the_speed_without_a_speed_sensor(vehicle, vehicle_dir, estimator,
                                                               estimator_dir):
    """No vx_meas at all (NaN), torques unknown, braking in a turn from 25 m/s to 9 m/s: the grip
    model's speed rests on the ax kinematics (its wheels keep their slip instead of tying vx to a
    spin balance against a brake torque told 0). Measured here: at most 0.18 m/s off, the ax
    integration's drift by the end (2 % of the last 9 m/s); model A, which keeps the spin
    balance, 31 % off at 4.5 s."""
    def no_speed_sensor(t, sensors):
        sensors["vx_meas"] = float("nan")

    grip = {"model": estimator.enumeration_value("model", "single_track_grip")}
    result = cosimulate(vehicle, vehicle_dir, estimator, estimator_dir, "ekf", 25.0, 7.0,
                        braking_in_a_turn, no_speed_sensor, estimator_extra=grip)
    assert np.max(np.abs(result["vx_est"] - result["vx"])) < 0.3
    assert support.rmse(result["sideslip_est"], result["sideslip"]) < 0.5 * support.rmse(
        0.0, result["sideslip"])
