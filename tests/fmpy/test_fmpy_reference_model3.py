"""Through fmpy: the ReferenceVehicle's model 3 (the full vehicle), the sensor effects a car
has, and the cars' SSP parameter-value files. One test per capability; every value reference, item
and start value comes from the packaged modelDescription.xml, the cars from the .ssv files."""

import math
import pathlib
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest
from fmpy import simulate_fmu

import fmu_support as support

STEP = 0.01
GRAVITY = 9.81
CARS = sorted((support.ROOT / "fmu-src" / "reference-vehicle" / "cars").glob("*.ssv"))
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
WHEELS = ["front_left", "front_right", "rear_left", "rear_right"]


def model(vehicle, item):
    return vehicle.enumeration_value("model", item)


def run(vehicle, vehicle_dir, parameters, inputs, duration, outputs, name="model3"):
    """Co-simulates `duration` s in steps of STEP with `inputs(t) -> {name: value}` set before
    each step; returns {output: array} with the initial values first."""
    slave = support.Slave(vehicle, vehicle_dir, name)
    try:
        slave.initialise(parameters)
        references = slave.real_references(outputs)
        rows = [slave.fmu.getReal(references)]
        steps = int(round(duration / STEP))
        for k in range(steps):
            t = k * STEP
            slave.set(inputs(t))
            slave.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            rows.append(slave.fmu.getReal(references))
    finally:
        slave.free()
    table = np.array(rows)
    return {name: table[:, i] for i, name in enumerate(outputs)}


def step_steer(angle, at=1.0):
    return lambda t: {"steering_angle": angle if t >= at else 0.0}


def quiet(vehicle, **extra):
    """Model 3 without process or sensor noise."""
    return {"model": model(vehicle, "full_vehicle"), "noise": False, **extra}


def read_ssv(path, vehicle):
    """An .ssv file as fmpy start values (enumeration items by name -> their values)."""
    values = {}
    for parameter in ElementTree.parse(path).getroot().iter(f"{SSV}Parameter"):
        name = parameter.get("name")
        (typed,) = list(parameter)
        kind, text = typed.tag.removeprefix(SSV), typed.get("value")
        if kind == "Real":
            values[name] = float(text)
        elif kind == "Boolean":
            values[name] = text == "true"
        elif kind == "Enumeration":
            values[name] = vehicle.enumeration_value(name, text)
        else:
            values[name] = int(text)
    return values


def test_model_3_runs_a_step_steer_with_roll_and_load_transfer(vehicle, vehicle_dir):
    outputs = ["vx", "yaw_rate", "ay", "roll_angle"] + [f"wheel_load_{w}" for w in WHEELS] \
        + [f"omega_{w}" for w in WHEELS] + support.TRUTH_OUTPUTS
    result = run(vehicle, vehicle_dir, quiet(vehicle, vx0=20.0), step_steer(0.03), 4.0, outputs)
    for name in outputs:
        assert np.all(np.isfinite(result[name])), name
    # a left turn (ISO 8855): yaw rate and ay positive, the body rolls right side down, the right
    # (outer) wheels carry more
    assert result["yaw_rate"][-1] > 0.1 and result["ay"][-1] > 3.0
    assert result["roll_angle"][-1] > 0.005
    assert result["wheel_load_front_right"][-1] > result["wheel_load_front_left"][-1] + 500
    assert result["wheel_load_rear_right"][-1] > result["wheel_load_rear_left"][-1] + 300
    # the loads carry the car's weight (seed car: the mass parameter's start value)
    total = sum(result[f"wheel_load_{w}"][-1] for w in WHEELS)
    assert total == pytest.approx(vehicle.start("mass") * GRAVITY, rel=1e-6)
    # in the turn the outer wheels roll faster; the axle outputs are the means
    assert result["omega_front_right"][-1] > result["omega_front_left"][-1]
    assert result["omega_front"][-1] == pytest.approx(
        0.5 * (result["omega_front_left"][-1] + result["omega_front_right"][-1]), rel=1e-12)
    # before the steer the car rolls straight
    assert abs(result["ay"][50]) < 1e-6 and abs(result["roll_angle"][50]) < 1e-9


def test_models_1_and_2_report_static_loads_and_no_roll(vehicle, vehicle_dir):
    outputs = ["roll_angle", "omega_front", "omega_front_left", "wheel_load_rear_left"]
    for item in ("single_track_hsri", "two_track_magic_formula"):
        parameters = {"model": model(vehicle, item), "noise": False}
        result = run(vehicle, vehicle_dir, parameters, step_steer(0.03), 2.0, outputs, item)
        assert np.all(result["roll_angle"] == 0.0)
        assert np.all(result["wheel_load_rear_left"] == vehicle.start("wheel_load_rear"))
        assert np.all(np.isfinite(result["omega_front_left"]))


def test_road_friction_input_lowers_the_peak_lateral_acceleration(vehicle, vehicle_dir):
    def peak_ay(friction):
        inputs = lambda t: {"steering_angle": 0.08 if t >= 0.5 else 0.0, "road_friction": friction}
        result = run(vehicle, vehicle_dir, quiet(vehicle, vx0=25.0), inputs, 3.0, ["ay"])
        return np.max(np.abs(result["ay"]))

    dry, ice = peak_ay(1.0), peak_ay(0.3)
    assert dry > 7.0
    # on a road of friction 0.3 the tyres cannot give much more than 0.3 g (the seed tyre's peak
    # friction is about 1.1-1.2 at these loads)
    assert ice < 0.3 * 1.3 * GRAVITY
    assert ice < 0.5 * dry


def test_model_3_brakes_to_a_stop_holds_and_pulls_away(vehicle, vehicle_dir):
    def inputs(t):
        if t < 6.0:
            return {"brake_torque": 2500.0, "drive_torque": 0.0}
        return {"brake_torque": 0.0, "drive_torque": 600.0}

    outputs = ["vx"] + [f"omega_{w}" for w in WHEELS]
    result = run(vehicle, vehicle_dir, quiet(vehicle, vx0=8.0), inputs, 9.0, outputs)
    time = np.arange(len(result["vx"])) * STEP
    holding = (time > 4.0) & (time < 6.0)
    # stopped and held, wheels still; it may only rock back on its tyres' elasticity (a few
    # millimetres), never drive backwards (model A stalls at vx = -1 m/s)
    assert np.max(np.abs(result["vx"][holding])) < 0.02
    braking = time < 6.0
    position = np.cumsum(result["vx"][braking]) * STEP
    assert np.max(position) - position[-1] < 0.01
    for w in WHEELS:
        assert np.max(np.abs(result[f"omega_{w}"][holding])) < 0.1, w
    # pulls away when the brake is released and the drive torque applied
    assert result["vx"][-1] > 1.0


def sensed(vehicle, vehicle_dir, extra, inputs, duration=2.0, item="single_track_hsri", vx0=18.0):
    """Truth and measured signals of a quiet run of model `item` with the sensor parameters `extra`."""
    outputs = ["yaw_rate", "ay", "ax", "omega_front", "vx", "roll_angle",
               "yaw_rate_meas", "ay_meas", "ax_meas", "omega_front_meas", "vx_meas"]
    parameters = {"model": model(vehicle, item), "noise": False, "vx0": vx0, **extra}
    return run(vehicle, vehicle_dir, parameters, inputs, duration, outputs, "sensors")


def test_sensor_bias_is_off_by_default_and_offsets_when_set(vehicle, vehicle_dir):
    for name in ("bias_yaw_rate_meas", "bias_ay_meas", "bias_ax_meas", "drift_yaw_rate_meas",
                 "drift_ay_meas", "drift_ax_meas"):
        assert vehicle.start(name) == 0.0, name
    off = sensed(vehicle, vehicle_dir, {}, step_steer(0.02))
    assert np.array_equal(off["yaw_rate_meas"], off["yaw_rate"])
    on = sensed(vehicle, vehicle_dir, {"bias_yaw_rate_meas": 0.01, "bias_ay_meas": -0.2,
                                       "bias_ax_meas": 0.1}, step_steer(0.02))
    assert np.allclose(on["yaw_rate_meas"] - on["yaw_rate"], 0.01, atol=1e-12)
    assert np.allclose(on["ay_meas"] - on["ay"], -0.2, atol=1e-12)
    assert np.allclose(on["ax_meas"] - on["ax"], 0.1, atol=1e-12)


def test_sensor_drift_is_a_random_walk_of_the_given_intensity(vehicle, vehicle_dir):
    intensity = 1e-3
    offsets = []
    for seed in range(1, 9):
        result = sensed(vehicle, vehicle_dir, {"drift_yaw_rate_meas": intensity, "seed": seed},
                        lambda t: {}, duration=4.0)
        offset = result["yaw_rate_meas"] - result["yaw_rate"]
        assert offset[0] == 0.0 and np.all(np.isfinite(offset))
        offsets.append(offset[-1])
    # after 4 s the drifted bias has standard deviation intensity * sqrt(4): 8 seeds give a spread
    # of that order, not zero, not ten times more
    spread = float(np.std(offsets))
    assert 0.3 * intensity * 2 < spread < 3 * intensity * 2


def test_gravity_enters_the_accelerometers_through_bank_grade_and_roll(vehicle, vehicle_dir):
    road = lambda t: {"road_bank_angle": 0.05, "road_grade_angle": -0.1}
    off = sensed(vehicle, vehicle_dir, {}, road)
    assert np.array_equal(off["ay_meas"], off["ay"]) and np.array_equal(off["ax_meas"], off["ax"])
    on = sensed(vehicle, vehicle_dir, {"gravity_in_accelerometers": True}, road)
    end = -1
    # model 1 does not feel the slope in its motion, its accelerometers do
    assert on["ay_meas"][end] == pytest.approx(on["ay"][end] + GRAVITY * math.sin(0.05))
    assert on["ax_meas"][end] == pytest.approx(on["ax"][end] + GRAVITY * math.sin(-0.1))
    # model 3 feels the grade: braked to a stop and held on a 10 % uphill grade it stands still,
    # and the longitudinal accelerometer reads the slope, g sin(grade)
    grade = math.atan(0.1)
    held = sensed(vehicle, vehicle_dir, {"gravity_in_accelerometers": True},
                  lambda t: {"road_grade_angle": grade, "brake_torque": 3000.0},
                  duration=4.0, item="full_vehicle", vx0=2.0)
    assert abs(held["vx"][end]) < 1e-3 and abs(held["ax"][end]) < 1e-2
    assert held["ax_meas"][end] == pytest.approx(held["ax"][end] + GRAVITY * math.sin(grade))
    # model 3 in a left turn: the roll adds g sin(roll) to the lateral reading
    turn = sensed(vehicle, vehicle_dir, {"gravity_in_accelerometers": True}, step_steer(0.03),
                  duration=3.0, item="full_vehicle", vx0=20.0)
    roll = turn["roll_angle"][end]
    assert roll > 0.005
    assert turn["ay_meas"][end] == pytest.approx(
        turn["ay"][end] * math.cos(roll) + GRAVITY * math.sin(roll), rel=1e-9)


def test_wheel_speed_from_counted_teeth_is_quantised(vehicle, vehicle_dir):
    teeth, period = 48, 0.01
    result = sensed(vehicle, vehicle_dir, {"wheel_speed_teeth": teeth, "sensor_sample_period": period},
                    lambda t: {"brake_torque": 600.0})
    quantum = 2 * math.pi / (teeth * period)
    measured = result["omega_front_meas"][5:]
    assert np.allclose(measured / quantum, np.round(measured / quantum), atol=1e-6)
    # the counted speed follows the true one within a quantum (and its lag of about a window)
    assert np.max(np.abs(measured - result["omega_front"][5:])) < 1.5 * quantum
    assert len(np.unique(measured)) > 1
    # counting loses no angle: on average the counted speed is the true one (within a tooth over
    # the whole run)
    assert abs(np.mean(measured) - np.mean(result["omega_front"][5:])) < 0.2
    ideal = sensed(vehicle, vehicle_dir, {}, lambda t: {"brake_torque": 600.0})
    assert np.array_equal(ideal["omega_front_meas"], ideal["omega_front"])


@pytest.mark.parametrize("hold_last", [False, True])
def test_a_dropout_blanks_the_chosen_channels_for_its_time(vehicle, vehicle_dir, hold_last):
    extra = {"dropout_channels": 1 + 4, "dropout_start": 0.505, "dropout_duration": 0.3,
             "dropout_hold_last": hold_last}
    result = sensed(vehicle, vehicle_dir, extra, step_steer(0.03, at=0.2), duration=1.2)
    time = np.arange(len(result["vx"])) * STEP
    out = (time >= 0.505) & (time < 0.805)
    for name in ("yaw_rate", "omega_front"):
        meas = result[f"{name}_meas"]
        if hold_last:
            # stale: the last value before the dropout, while the truth moves on
            assert np.all(meas[out] == meas[np.argmax(out) - 1]), name
            assert np.ptp(result[name][out]) > 0, name
        else:
            assert np.all(np.isnan(meas[out])), name
        assert np.array_equal(meas[~out], result[name][~out]), name
    # the other channels are untouched
    assert np.array_equal(result["ay_meas"], result["ay"])


@pytest.mark.parametrize("car", CARS, ids=[path.stem for path in CARS])
def test_each_car_parameter_value_file_loads_and_runs(vehicle_fmu, vehicle, car):
    start_values = read_ssv(car, vehicle)
    assert start_values["model"] == model(vehicle, "full_vehicle")
    assert len(start_values) > 80
    start_values.update(noise=False, vx0=20.0)
    times = np.arange(0.0, 3.0 + STEP / 2, STEP)
    steering = np.where(times >= 1.0, 0.03, 0.0)
    drive = np.where(times >= 2.0, 800.0, 0.0)
    inputs = support.input_table(times, steering_angle=steering, drive_torque=drive,
                                 brake_torque=np.zeros_like(times))
    outputs = ["vx", "yaw_rate", "ay", "roll_angle"] + [f"omega_{w}" for w in WHEELS] \
        + [f"wheel_load_{w}" for w in WHEELS]
    result = simulate_fmu(str(vehicle_fmu), start_time=0.0, stop_time=3.0, output_interval=STEP,
                          start_values=start_values, input=inputs, output=outputs)
    for name in outputs:
        assert np.all(np.isfinite(result[name])), f"{car.stem}: {name}"
    # the car's own weight on its wheels
    total = sum(result[f"wheel_load_{w}"][-1] for w in WHEELS)
    assert total == pytest.approx(start_values["mass"] * GRAVITY, rel=1e-6), car.stem
    assert result["yaw_rate"][-1] > 0.05 and result["roll_angle"][-1] > 0.0, car.stem
    # the driven axle turns faster under drive torque (front-, rear- or all-wheel drive)
    front = result["omega_front_left"][-1] + result["omega_front_right"][-1]
    rear = result["omega_rear_left"][-1] + result["omega_rear_right"][-1]
    split = start_values["drive_distribution_front"]
    if split == 1.0:
        assert front > rear, car.stem
    elif split == 0.0:
        assert rear > front, car.stem
