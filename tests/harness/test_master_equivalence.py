"""The Rust master and a plain fmpy FMU2Slave loop run the same scenario with the same seed and
give the same outputs (to 1e-12): same communication points t0 + n h, same order (the reference's
inputs, its outputs to the estimators within the step, then fmi2DoStep on every instance)."""

import csv
import pathlib
import tomllib

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from harness_support import SEED000_MANOEUVRES, run_harness

HERE = pathlib.Path(__file__).resolve().parent
SCENARIO = HERE / "equivalence.toml"


def ramp(t, start=SEED000_MANOEUVRES["steer_start_time"], rate=SEED000_MANOEUVRES["steer_ramp_rate"],
         final=SEED000_MANOEUVRES["high_ramp_angle"]):
    # Same floating-point operations as the manoeuvres crate's SteerRamp.
    return 0.0 if t <= start else min(rate * (t - start), final)


class Instance:
    def __init__(self, name, fmu_path, unzip_root):
        self.name = name
        self.description = read_model_description(str(fmu_path))
        self.variables = {v.name: v for v in self.description.modelVariables}
        directory = extract(str(fmu_path), str(unzip_root / name))
        self.fmu = FMU2Slave(guid=self.description.guid, unzipDirectory=directory,
                             modelIdentifier=self.description.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate()

    def set(self, values):
        for name, value in values.items():
            v = self.variables[name]
            if v.type == "Real":
                self.fmu.setReal([v.valueReference], [float(value)])
            elif v.type in ("Integer", "Enumeration"):
                self.fmu.setInteger([v.valueReference], [int(value)])
            elif v.type == "Boolean":
                self.fmu.setBoolean([v.valueReference], [bool(value)])
            else:
                raise AssertionError(f"unexpected type of {name}")

    def outputs(self):
        return [v.name for v in self.description.modelVariables
                if v.causality == "output" and v.type != "String"]

    def get(self, names):
        values = []
        for name in names:
            v = self.variables[name]
            if v.type == "Real":
                values.append(self.fmu.getReal([v.valueReference])[0])
            elif v.type in ("Integer", "Enumeration"):
                values.append(float(self.fmu.getInteger([v.valueReference])[0]))
            else:
                values.append(float(bool(self.fmu.getBoolean([v.valueReference])[0])))
        return values


def fmpy_master(scenario, fmu_dir, unzip_root):
    """The master's algorithm written out with fmpy."""
    instances = []
    for section in scenario["fmu"]:
        path = pathlib.Path(section["path"].replace("{fmu_dir}", str(fmu_dir)))
        instance = Instance(section["name"], path, unzip_root)
        instances.append((instance, section.get("parameters", {})))
    vehicle = instances[0][0]
    stop, h = scenario["stop_time"], scenario["step"]
    steps = round(stop / h)
    vehicle_inputs = {"steering_angle", "drive_torque", "brake_torque"}
    for instance, parameters in instances:
        values = dict(parameters)
        if instance is vehicle:
            values["vx0"] = SEED000_MANOEUVRES["initial_speed"]  # the manoeuvre's initial_speed
        instance.set(values)
        instance.fmu.setupExperiment(startTime=0.0, stopTime=stop)
        instance.fmu.enterInitializationMode()
    connected = {}
    for instance, _ in instances[1:]:
        inputs = {v.name for v in instance.description.modelVariables if v.causality == "input"}
        connected[instance.name] = [n for n in vehicle.outputs() if n in inputs]

    def exchange(t):
        driver = {"steering_angle": ramp(t), "drive_torque": 0.0, "brake_torque": 0.0}
        vehicle.set(driver)
        names = vehicle.outputs()
        reference = dict(zip(names, vehicle.get(names)))
        row = {f"vehicle.{n}": reference[n] for n in names}
        for instance, _ in instances[1:]:
            values = {n: driver[n] for n in vehicle_inputs}
            values.update({n: reference[n] for n in connected[instance.name]})
            instance.set(values)
            outs = instance.outputs()
            row.update({f"{instance.name}.{n}": x for n, x in zip(outs, instance.get(outs))})
        return row

    exchange(0.0)
    for instance, _ in instances:
        instance.fmu.exitInitializationMode()
    rows = []
    for n in range(steps + 1):
        t = n * h
        rows.append(exchange(t))
        if n == steps:
            break
        step = (n + 1) * h - t
        for instance, _ in instances:
            instance.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=step)
    for instance, _ in instances:
        instance.fmu.terminate()
        instance.fmu.freeInstance()
    return rows


def read_csv(path):
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        data = np.array([[float(x) for x in row] for row in reader])
    return header, data


def test_rust_master_and_fmpy_loop_agree(fmu_dir, harness_binary, tmp_path):
    scenario = tomllib.loads(SCENARIO.read_text())
    out = tmp_path / "rust"
    run_harness(harness_binary, "run", SCENARIO, "--out", out, "--fmu-dir", fmu_dir, "--no-plots")
    header, rust = read_csv(out / scenario["name"] / f"{scenario['name']}.csv")
    rows = fmpy_master(scenario, fmu_dir, tmp_path / "fmpy")
    assert len(rows) == rust.shape[0] == round(scenario["stop_time"] / scenario["step"]) + 1
    times = rust[:, 0]
    np.testing.assert_array_equal(times, np.arange(len(rows)) * scenario["step"])
    compared = 0
    for column, name in enumerate(header):
        if name == "time" or name.startswith("manoeuvre."):
            continue
        python = np.array([row[name] for row in rows])
        np.testing.assert_allclose(rust[:, column], python, rtol=1e-12, atol=1e-12, err_msg=name)
        compared += 1
    # Every output of the three instances was compared, and the run is not trivial.
    assert compared == len(rows[0]) and compared > 40
    vy = rust[:, header.index("vehicle.vy")]
    assert np.max(np.abs(vy)) > 0.1
    steering = rust[:, header.index("manoeuvre.steering_angle")]
    np.testing.assert_array_equal(steering, [ramp(t) for t in times])
