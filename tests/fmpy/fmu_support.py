"""Shared helpers of the fmpy tests: where the packaged archives are, what their model descriptions
say, the seed-000 driver manoeuvres, and a thin wrapper around fmpy's FMU2Slave for plain
co-simulation loops.

Value references, types and start values are always read from the packaged modelDescription.xml,
never hard-coded, so the tests follow the XML (the single source of truth of the interface).
"""

import math
import os
import pathlib
import tomllib
from ctypes import CFUNCTYPE, c_char_p, c_int, c_void_p, cast, string_at

import numpy as np
from fmpy import calloc, free, read_model_description
from filterpy.kalman import KalmanFilter
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2True)

ROOT = pathlib.Path(__file__).resolve().parents[2]

VEHICLE = "ReferenceVehicle"
ESTIMATOR = "VehicleStateEstimator"
SSP_NAME = "VehicleWithEstimator"

# The interface names both FMUs share.
DRIVER_INPUTS = ["steering_angle", "drive_torque", "brake_torque"]
SENSOR_SIGNALS = ["yaw_rate_meas", "ay_meas", "omega_front_meas", "omega_rear_meas", "ax_meas", "vx_meas"]
TRUTH_OUTPUTS = ["vx", "vy", "yaw_rate", "omega_front", "omega_rear", "sideslip", "ay", "ax",
                 "slip_angle_front", "slip_angle_rear", "slip_front", "slip_rear"]
ESTIMATE_OUTPUTS = ["vx_est", "vy_est", "yaw_rate_est", "omega_front_est", "omega_rear_est",
                    "sideslip_est", "ay_est", "slip_angle_front_est", "slip_angle_rear_est",
                    "slip_front_est", "slip_rear_est", "vx_std", "vy_std", "yaw_rate_std",
                    "omega_front_std", "omega_rear_std", "sideslip_std", "nis", "status"]
# The estimators (item name -> value of the `estimator` parameter) as the source modelDescription
# declares them, read with fmpy: the XML's enumeration is the one list (the estimation crate's
# registry is checked against it), so a new estimator needs no line here.
ESTIMATOR_KINDS = {
    item.name: int(item.value)
    for item in next(
        simple_type for simple_type in read_model_description(
            str(ROOT / "modelDescription" / f"{ESTIMATOR}.xml"), validate=False).typeDefinitions
        if simple_type.name == "EstimatorKind").items
}

# Seed-000 manoeuvres (SPEC section 7), defined once for the project in the Rust crate
# fmu-src/manoeuvres (src/seed000.rs) and read here from the table it generates (a Rust test keeps
# the table current): 12 s, steering starts at 4 s with 0.07 rad/s.
with open(ROOT / "fmu-src" / "manoeuvres" / "seed000_manoeuvres.toml", "rb") as _table_file:
    SEED000_MANOEUVRES = tomllib.load(_table_file)
MANOEUVRE_DURATION = SEED000_MANOEUVRES["manoeuvre_duration"]
STEER_START_TIME = SEED000_MANOEUVRES["steer_start_time"]
STEER_RAMP_RATE = SEED000_MANOEUVRES["steer_ramp_rate"]
MODERATE_RAMP_ANGLE = SEED000_MANOEUVRES["moderate_ramp_angle"]
HIGH_RAMP_ANGLE = SEED000_MANOEUVRES["high_ramp_angle"]


def fmu_directory() -> pathlib.Path:
    """Where `cargo run --release -p packaging` writes: <cargo target dir>/fmu.

    FMU_DIR overrides; otherwise CARGO_TARGET_DIR (relative to the repository root, as cargo
    resolves it when run from there) or the default <root>/target.
    """
    if os.environ.get("FMU_DIR"):
        return pathlib.Path(os.environ["FMU_DIR"]).resolve()
    target = os.environ.get("CARGO_TARGET_DIR")
    target_directory = (ROOT / target) if target else (ROOT / "target")
    return target_directory.resolve() / "fmu"


def archive_path(file_name: str) -> pathlib.Path:
    return fmu_directory() / file_name


def interface_and_directory(request, which):
    """The Interface and the extracted directory of one FMU, from the conftest fixtures; only that
    FMU's archive is required."""
    prefix = {VEHICLE: "vehicle", ESTIMATOR: "estimator"}[which]
    return request.getfixturevalue(prefix), request.getfixturevalue(f"{prefix}_dir")


def steering_ramp(time, limit):
    """Road-wheel steering angle of a seed-000 ramp: 0 until 4 s, then 0.07 rad/s up to `limit`."""
    return np.minimum(np.maximum(np.asarray(time, dtype=float) - STEER_START_TIME, 0.0) * STEER_RAMP_RATE, limit)


def input_table(times, **signals):
    """Structured array in the form fmpy.simulate_fmu takes as `input`."""
    dtype = [("time", np.float64)] + [(name, np.float64) for name in signals]
    table = np.zeros(len(times), dtype=dtype)
    table["time"] = times
    for name, values in signals.items():
        table[name] = values
    return table


def rmse(a, b):
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return float(np.sqrt(np.mean((a - b) ** 2)))


def gauss_markov_offset_filter(std, time_constant, step, measurement_variance):
    """filterpy's Kalman filter of a sensor offset b, a first-order Gauss-Markov process
    (F = a = exp(-T / tau), Q = std^2 (1 - a^2)) measured directly (H = 1, R =
    `measurement_variance`), from b = 0 with variance std^2: the oracle of the FMU's offset
    learners (fmu-src/vehicle-state-estimator/src/gauss_markov.rs)."""
    decay = np.exp(-step / time_constant)
    kf = KalmanFilter(dim_x=1, dim_z=1)
    kf.F = np.array([[decay]])
    kf.H = np.array([[1.0]])
    kf.Q = np.array([[std**2 * (1.0 - decay**2)]])
    kf.R = np.array([[measurement_variance]])
    kf.x = np.array([[0.0]])
    kf.P = np.array([[std**2]])
    return kf


class Interface:
    """The variables of one FMU, from its model description."""

    def __init__(self, fmu_path):
        self.path = str(fmu_path)
        self.description = read_model_description(self.path)
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.types = {t.name: t for t in self.description.typeDefinitions}

    def __getitem__(self, name):
        try:
            return self.variables[name]
        except KeyError:
            raise KeyError(f"{self.description.modelName} has no variable {name!r}") from None

    def vr(self, name):
        return self[name].valueReference

    def start(self, name):
        """The start value of a variable as a Python number (Real -> float, Boolean -> bool)."""
        variable = self[name]
        if variable.start is None:
            raise ValueError(f"{name} has no start value")
        if variable.type == "Real":
            return float(variable.start)
        if variable.type == "Boolean":
            return variable.start in ("true", "1", True)
        if variable.type in ("Integer", "Enumeration"):
            return int(variable.start)
        return variable.start

    def enumeration_value(self, variable_name, item_name):
        declared = self[variable_name].declaredType
        for item in declared.items:
            if item.name == item_name:
                return int(item.value)
        raise KeyError(f"enumeration {declared.name} of {variable_name} has no item {item_name!r}: "
                       f"{[item.name for item in declared.items]}")

    def names(self, causality):
        return [v.name for v in self.description.modelVariables if v.causality == causality]


# The logger as the FMUs call it, logger(environment, instance, status, category, "%s", text)
# (fmi-export's log_message), declared with the variadic text as a sixth argument, which the
# x86-64 calling convention passes as it passes a fixed one. fmpy's own way, its native proxy
# addLoggerProxy, keeps one logger for the whole process and would redirect every other
# instance's messages too.
_TEXT_LOGGER = CFUNCTYPE(None, c_void_p, c_char_p, c_int, c_char_p, c_char_p, c_void_p)


class LogRecorder:
    """FMI 2.0 callbacks for `Slave` whose logger keeps every message as (status, category,
    text) in `lines`, for tests of what an FMU tells its importer."""

    def __init__(self):
        self.lines = []
        self._logger = _TEXT_LOGGER(self._record)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = cast(self._logger, fmi2CallbackLoggerTYPE)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)

    def _record(self, _environment, _instance, status, category, message_format, text):
        # Only with the format "%s" is the sixth argument the text; otherwise the format is it.
        message = string_at(text) if message_format == b"%s" and text else message_format
        self.lines.append((status, category.decode(), message.decode()))


class Slave:
    """One FMI 2.0 co-simulation instance driven directly through fmpy's FMU2Slave; `callbacks`
    replaces fmpy's default ones (which print the log), e.g. a `LogRecorder`'s."""

    def __init__(self, interface, unzip_directory, instance_name, callbacks=None):
        self.interface = interface
        self.fmu = FMU2Slave(guid=interface.description.guid,
                             unzipDirectory=str(unzip_directory),
                             modelIdentifier=interface.description.coSimulation.modelIdentifier,
                             instanceName=instance_name)
        self.fmu.instantiate(callbacks=callbacks)
        self.initialised = False

    def set(self, values):
        """Sets variables by name, each with the C API call its type needs."""
        groups = {"Real": ([], []), "Integer": ([], []), "Boolean": ([], [])}
        for name, value in values.items():
            variable = self.interface[name]
            kind = "Integer" if variable.type == "Enumeration" else variable.type
            groups[kind][0].append(variable.valueReference)
            groups[kind][1].append(value)
        if groups["Real"][0]:
            self.fmu.setReal(groups["Real"][0], [float(v) for v in groups["Real"][1]])
        if groups["Integer"][0]:
            self.fmu.setInteger(groups["Integer"][0], [int(v) for v in groups["Integer"][1]])
        if groups["Boolean"][0]:
            self.fmu.setBoolean(groups["Boolean"][0], [bool(v) for v in groups["Boolean"][1]])

    def initialise(self, parameters, start_time=0.0):
        self.fmu.setupExperiment(startTime=start_time)
        self.set(parameters)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.initialised = True

    def real_references(self, names):
        return [self.interface.vr(name) for name in names]

    def free(self):
        if self.initialised:
            self.fmu.terminate()
        self.fmu.freeInstance()


def seed000_vehicle_parameters(vehicle: Interface):
    """Seed-000 chapter-7 reference: model A, process and sensor noise on (the defaults of SPEC
    section 7), and none of the seed-001 sensor corruption (no quantisation, sampling or latency)."""
    parameters = {
        "model": vehicle.enumeration_value("model", "single_track_hsri"),
        "noise": True,
        "vx0": SEED000_MANOEUVRES["initial_speed"],
    }
    for name in vehicle.names("parameter"):
        if name.startswith("quantum_") or name in ("sensor_sample_period", "sensor_latency"):
            parameters[name] = 0.0
    return parameters


def seed000_estimator_parameters(estimator: Interface, vehicle: Interface, kind: str):
    """The seed-000 filter set-up: model A at 1 ms, Q = diag(w^2) and R = diag(v^2) with the noise
    levels the reference vehicle actually uses, start at the reference's initial state."""
    vx0 = SEED000_MANOEUVRES["initial_speed"]
    wheel_speed = vx0 / vehicle.start("wheel_radius")
    parameters = {
        "estimator": estimator.enumeration_value("estimator", kind),
        "model": estimator.enumeration_value("model", "single_track_5_state"),
        "sample_time": 1e-3,
        "vx_initial": vx0,
        "vy_initial": 0.0,
        "yaw_rate_initial": 0.0,
        "omega_front_initial": wheel_speed,
        "omega_rear_initial": wheel_speed,
        # The seed's filter: no speed rows, start from the parameters, no gate (the
        # robustness defaults are off; tests/fmpy/test_fmpy_robustness.py tests it).
        "use_speed_measurements": False,
        "start_from_measurements": False,
        "gate_measurements": False,
        # The seed's gyro and accelerometer have no offset and its wheels roll on their nominal
        # radii, and the seed's filter takes them as they come.
        "yaw_rate_offset_std": 0.0,
        "ay_offset_std": 0.0,
        "wheel_radius_std": 0.0,
        # Seed 000's LKF is linearised once (no gain scheduling), and the observer's gain
        # placed once, as seed 002's.
        "schedule_threshold": 0.0,
        "observer_schedule_threshold": 0.0,
    }
    for state in ("vx", "vy", "yaw_rate", "omega_front", "omega_rear"):
        parameters[f"process_noise_std_{state}"] = vehicle.start(f"process_noise_std_{state}")
    for signal in ("yaw_rate", "ay", "omega_front", "omega_rear"):
        parameters[f"measurement_noise_std_{signal}"] = vehicle.start(f"noise_std_{signal}_meas")
    return parameters


# The coupled run the importer tests (tests/libcosim, tests/fmipp) compare with a plain fmpy loop.

# libcosim's clock: whole nanoseconds, a time point in seconds being the double division of its
# count (to_double_time_point); the communication step of the runs compared with libcosim.
STEP_NS = 1_000_000


def seconds(nanoseconds):
    return nanoseconds / 1e9

def equivalence_steering(t):
    """The seed-000 steering ramp started at 0 and held at the high-ay angle: the car turns harder
    for 1.7 s, so the comparison covers a transient, not a steady state."""
    return min(STEER_RAMP_RATE * t, HIGH_RAMP_ANGLE)


def compared_outputs(interface):
    """Every Real and Integer output, in model-description order."""
    return [v for v in interface.description.modelVariables
            if v.causality == "output" and v.type in ("Real", "Integer")]


def compared_output_names(vehicle, estimator):
    """The columns of a comparison row: both FMUs' compared outputs, qualified."""
    return [f"{VEHICLE}.{x.name}" for x in compared_outputs(vehicle)] + \
        [f"{ESTIMATOR}.{x.name}" for x in compared_outputs(estimator)]


def sensor_connections(vehicle, estimator):
    """The reference's outputs that are estimator inputs of the same name."""
    return [name for name in vehicle.names("output") if name in estimator.names("input")]


def read_outputs(slave):
    """The compared outputs of a `Slave` in model-description order, Integers as floats."""
    outputs = compared_outputs(slave.interface)
    reals = [x.valueReference for x in outputs if x.type == "Real"]
    integers = [x.valueReference for x in outputs if x.type == "Integer"]
    values = {"Real": iter(slave.fmu.getReal(reals) if reals else []),
              "Integer": iter(slave.fmu.getInteger(integers) if integers else [])}
    return [float(next(values[x.type])) for x in outputs]


def assert_bit_identical(rows, plain, names, importer):
    """Every column of `rows` (from `importer`) equals the plain fmpy loop's bit for bit; the
    run turned the car and the estimator followed its yaw rate."""
    assert rows.shape == plain.shape == (len(rows), len(names))
    for column, name in enumerate(names):
        differing = np.flatnonzero(rows[:, column].view(np.int64) != plain[:, column].view(np.int64))
        assert differing.size == 0, \
            f"{name} differs first at step {differing[0]}: {rows[differing[0], column]!r} " \
            f"({importer}) vs {plain[differing[0], column]!r} (fmpy)"
    column = names.index
    yaw_rate = rows[:, column(f"{VEHICLE}.yaw_rate")]
    assert yaw_rate[-1] > 0.3
    assert rmse(rows[-500:, column(f"{ESTIMATOR}.yaw_rate_est")], yaw_rate[-500:]) < 0.01


def libcosim_order_loop(vehicle, estimator, vehicle_dir, estimator_dir, steps, sensors=None,
                        missing=(), estimator_callbacks=None):
    """Both FMUs at their defaults as plain fmpy calls in the order and with the time values of
    libcosim's fixed-step algorithm (tests/libcosim/test_libcosim_equivalence.py describes it),
    steered by `equivalence_steering`, for `steps` steps of STEP_NS.

    `sensors` are the reference's outputs transferred to the estimator's inputs of the same name
    (default: all of `sensor_connections`); every input named in `missing` is set to NaN at each
    transfer, as a master does for a sensor it has no signal of. Returns the rows of
    `compared_output_names` after each step and each step's doStep statuses [reference,
    estimator]."""
    car = Slave(vehicle, vehicle_dir, VEHICLE)
    filt = Slave(estimator, estimator_dir, ESTIMATOR, estimator_callbacks)
    sensors = sensor_connections(vehicle, estimator) if sensors is None else sensors
    unset = dict.fromkeys(missing, math.nan)

    def transfer():
        filt.set(dict(zip(sensors, car.fmu.getReal(car.real_references(sensors)))) | unset)

    rows, statuses = [], []
    try:
        for slave in (car, filt):
            slave.fmu.setupExperiment(startTime=0.0)
            slave.fmu.enterInitializationMode()
        for _ in range(2):  # libcosim iterates once per simulator to propagate initial values
            transfer()
        for slave in (car, filt):
            slave.fmu.exitInitializationMode()
            slave.initialised = True
        transfer()
        for n in range(steps):
            angle = equivalence_steering(seconds(n * STEP_NS))
            statuses.append([])
            for slave in (car, filt):
                slave.set({"steering_angle": angle})
                statuses[-1].append(slave.fmu.fmi2DoStep(slave.fmu.component, seconds(n * STEP_NS),
                                                         seconds(STEP_NS), fmi2True))
            rows.append(read_outputs(car) + read_outputs(filt))
            transfer()
    finally:
        for slave in (car, filt):
            slave.free()
    return np.array(rows), np.array(statuses)
