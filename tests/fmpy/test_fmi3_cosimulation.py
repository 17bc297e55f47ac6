"""The FMI 3.0 archives in fmpy: both FMUs coupled through FMU3Slave, beside the same loop through
FMU2Slave on the FMI 2.0 archives. One library serves both archives, so every output the two
interfaces share must be bit-identical at every step; the FMI 3-only arrays hold the filter's
state and covariance."""

import ctypes
import os
import zipfile

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

import fmu_support as support

STEP = 1e-3
DURATION = 2.0
# The seed-000 EKF on model A, and the FMU's defaults (the grip model, 11 states).
SETUPS = ["seed000_ekf", "defaults"]


def fmi3_path(model_identifier):
    path = support.archive_path(f"{model_identifier}-fmi3.fmu")
    if not path.is_file():
        pytest.fail(f"{path} does not exist: build the archives first with "
                    f"`cargo run --release -p packaging`", pytrace=False)
    return path


@pytest.fixture(scope="module")
def archives(tmp_path_factory, vehicle_fmu, estimator_fmu):
    """{(model, version): (model description, unzip directory)} for both FMUs and versions."""
    found = {}
    for model, fmi2_path in [(support.VEHICLE, vehicle_fmu), (support.ESTIMATOR, estimator_fmu)]:
        for version, path in [(2, fmi2_path), (3, fmi3_path(model))]:
            directory = extract(str(path), str(tmp_path_factory.mktemp(f"{model}{version}")))
            found[(model, version)] = (read_model_description(str(path)), directory)
    return found


class Instance:
    """One co-simulation instance of either FMI version, set and read by variable name."""

    def __init__(self, description, directory, name, version):
        self.version = version
        self.variables = {v.name: v for v in description.modelVariables}
        if version == 2:
            self.fmu = FMU2Slave(guid=description.guid, unzipDirectory=directory,
                                 modelIdentifier=description.coSimulation.modelIdentifier,
                                 instanceName=name)
        else:
            self.fmu = FMU3Slave(guid=description.instantiationToken, unzipDirectory=directory,
                                 modelIdentifier=description.coSimulation.modelIdentifier,
                                 instanceName=name)
        self.fmu.instantiate()
        self.time = 0.0

    def references(self, names):
        return [self.variables[name].valueReference for name in names]

    def set(self, values):
        for name, value in values.items():
            variable = self.variables[name]
            vr = [variable.valueReference]
            kind = variable.type
            if kind in ("Real", "Float64"):
                (self.fmu.setReal if self.version == 2 else self.fmu.setFloat64)(vr, [float(value)])
            elif kind in ("Integer", "Int32"):
                (self.fmu.setInteger if self.version == 2 else self.fmu.setInt32)(vr, [int(value)])
            elif kind == "Enumeration":
                (self.fmu.setInteger if self.version == 2 else self.fmu.setInt64)(vr, [int(value)])
            elif kind == "Boolean":
                self.fmu.setBoolean(vr, [bool(value)])
            else:
                raise TypeError(f"{name}: {kind}")

    def set_reals(self, references, values):
        (self.fmu.setReal if self.version == 2 else self.fmu.setFloat64)(references, values)

    def get_reals(self, references):
        return (self.fmu.getReal if self.version == 2 else self.fmu.getFloat64)(references)

    def get_integers(self, references):
        return (self.fmu.getInteger if self.version == 2 else self.fmu.getInt32)(references)

    def initialise(self, parameters):
        if self.version == 2:
            self.fmu.setupExperiment(startTime=0.0)
            self.set(parameters)
            self.fmu.enterInitializationMode()
        else:
            self.set(parameters)
            self.fmu.enterInitializationMode(startTime=0.0)
        self.fmu.exitInitializationMode()

    def step(self):
        self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=STEP)
        self.time += STEP

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def fmi2_interfaces(vehicle_fmu, estimator_fmu):
    return support.Interface(vehicle_fmu), support.Interface(estimator_fmu)


def run(archives, version, setup, vehicle_fmu, estimator_fmu, keep_instances=False):
    """The seed-000 high ramp with the vehicle's sensors connected by name; returns the recorded
    outputs {name: array} of both FMUs (and the live estimator instance when asked)."""
    vehicle_interface, estimator_interface = fmi2_interfaces(vehicle_fmu, estimator_fmu)
    vehicle = Instance(*archives[(support.VEHICLE, version)], f"vehicle{version}", version)
    estimator = Instance(*archives[(support.ESTIMATOR, version)], f"estimator{version}", version)
    vehicle.initialise(support.seed000_vehicle_parameters(vehicle_interface))
    estimator.initialise(support.seed000_estimator_parameters(estimator_interface,
                                                              vehicle_interface, "ekf")
                         if setup == "seed000_ekf" else {})
    connected = [name for name in vehicle_interface.names("output")
                 if name in estimator_interface.variables
                 and estimator_interface[name].causality == "input"]
    real_outputs = {
        "vehicle": [n for n in vehicle_interface.names("output") if vehicle_interface[n].type == "Real"],
        "estimator": [n for n in estimator_interface.names("output")
                      if estimator_interface[n].type == "Real"],
    }
    integer_outputs = [n for n in estimator_interface.names("output")
                       if estimator_interface[n].type == "Integer"]
    measured = vehicle.references(connected)
    estimator_inputs = estimator.references(support.DRIVER_INPUTS + connected)
    vehicle_driver = vehicle.references(support.DRIVER_INPUTS)
    steps = int(round(DURATION / STEP))
    record = {name: np.zeros(steps) for group in real_outputs.values() for name in group}
    record.update({name: np.zeros(steps, dtype=np.int64) for name in integer_outputs})
    references = {group: (vehicle if group == "vehicle" else estimator).references(names)
                  for group, names in real_outputs.items()}
    integer_references = estimator.references(integer_outputs)
    for k in range(steps):
        driver = [support.equivalence_steering(vehicle.time), 0.0, 0.0]
        vehicle.set_reals(vehicle_driver, driver)
        vehicle.step()
        estimator.set_reals(estimator_inputs, driver + list(vehicle.get_reals(measured)))
        estimator.step()
        for group, names in real_outputs.items():
            values = (vehicle if group == "vehicle" else estimator).get_reals(references[group])
            for name, value in zip(names, values):
                record[name][k] = value
        for name, value in zip(integer_outputs, estimator.get_integers(integer_references)):
            record[name][k] = value
    vehicle.free()
    if keep_instances:
        return record, estimator
    estimator.free()
    return record


@pytest.mark.parametrize("setup", SETUPS)
def test_the_outputs_both_versions_share_are_bit_identical(archives, setup, vehicle_fmu,
                                                           estimator_fmu):
    fmi2 = run(archives, 2, setup, vehicle_fmu, estimator_fmu)
    fmi3 = run(archives, 3, setup, vehicle_fmu, estimator_fmu)
    assert fmi2.keys() == fmi3.keys()
    assert np.max(np.abs(fmi2["ay"])) > 3.0, "the manoeuvre should turn the car"
    for name in fmi2:
        np.testing.assert_array_equal(fmi3[name].view(np.int64) if fmi3[name].dtype == float
                                      else fmi3[name],
                                      fmi2[name].view(np.int64) if fmi2[name].dtype == float
                                      else fmi2[name], err_msg=name)


@pytest.mark.parametrize("setup, states", [("seed000_ekf", 5), ("defaults", 11)])
def test_the_estimator_reports_its_state_and_covariance_as_arrays(archives, setup, states,
                                                                 vehicle_fmu, estimator_fmu):
    record, estimator = run(archives, 3, setup, vehicle_fmu, estimator_fmu, keep_instances=True)
    try:
        (dimension,) = estimator.fmu.getInt32(estimator.references(["state_dimension"]))
        x = np.array(estimator.fmu.getFloat64(estimator.references(["state_estimate"]), nValues=11))
        p = np.array(estimator.fmu.getFloat64(estimator.references(["state_covariance"]),
                                              nValues=121)).reshape(11, 11)
        both = estimator.fmu.getFloat64(estimator.references(["state_estimate", "vx_est",
                                                              "state_covariance"]), nValues=133)
        (time,) = estimator.fmu.getFloat64(estimator.references(["time"]))
    finally:
        estimator.free()
    assert dimension == states
    assert time == pytest.approx(DURATION, rel=1e-12)
    np.testing.assert_array_equal(both[:11], x)
    assert both[11] == record["vx_est"][-1]
    np.testing.assert_array_equal(np.array(both[12:]).reshape(11, 11), p)
    assert np.all(x[states:] == 0.0) and np.all(p[states:, :] == 0.0) and np.all(p[:, states:] == 0.0)
    block = p[:states, :states]
    np.testing.assert_allclose(block, block.T, rtol=0, atol=1e-12 * np.max(np.abs(block)))
    assert np.all(np.linalg.eigvalsh((block + block.T) / 2) > -1e-12 * np.max(np.diag(block)))
    # Model A's and the grip model's first five states are vx, vy, yaw rate and the wheel speeds
    # (the grip model reports a filtered speed and the vy that goes with it, hence the tolerance).
    estimates = [record[name][-1] for name in ("vx_est", "vy_est", "yaw_rate_est")]
    np.testing.assert_allclose(x[:3], estimates, rtol=1e-9 if states == 5 else 1e-4, atol=1e-12)
    # The reported standard deviation of vy is at least the filter's own: the consider terms
    # (the tyres' uncertain stiffness) add to it.
    assert record["vy_std"][-1] >= np.sqrt(p[1, 1]) * (1 - 1e-9)


def test_fmu_state_restores_and_deserialises_bit_identically(archives, vehicle_fmu, estimator_fmu):
    vehicle_interface, estimator_interface = fmi2_interfaces(vehicle_fmu, estimator_fmu)
    estimator = Instance(*archives[(support.ESTIMATOR, 3)], "state", 3)
    try:
        estimator.initialise({})
        inputs = estimator.references(support.DRIVER_INPUTS + support.SENSOR_SIGNALS)
        outputs = estimator.references(["state_estimate", "state_covariance", "vy_est", "vy_std"])

        def advance(steps):
            for k in range(steps):
                t = estimator.time
                estimator.set_reals(inputs, [0.02, 0, 0, 0.05 * t, 1.0 * t, 40, 40, 0.0, 12.0])
                estimator.step()
            return estimator.fmu.getFloat64(outputs, nValues=11 + 121 + 2)

        advance(100)
        state = estimator.fmu.getFMUState()
        serialized = estimator.fmu.serializeFMUState(state)
        time = estimator.time
        first = advance(200)
        estimator.fmu.setFMUState(state)
        estimator.time = time
        again = advance(200)
        restored = estimator.fmu.deserializeFMUState(serialized)
        estimator.fmu.setFMUState(restored)
        estimator.time = time
        third = advance(200)
        estimator.fmu.freeFMUState(state)
        estimator.fmu.freeFMUState(restored)
        assert np.array_equal(np.array(first).view(np.int64), np.array(again).view(np.int64))
        assert np.array_equal(np.array(first).view(np.int64), np.array(third).view(np.int64))
    finally:
        estimator.free()


@pytest.mark.parametrize("model", [support.VEHICLE, support.ESTIMATOR])
def test_variable_dependencies_match_the_model_structure(archives, model):
    # Called through fmpy's C bindings: its Python wrapper of
    # fmi3GetNumberOfVariableDependencies passes a type where an instance belongs.
    description, _ = archives[(model, 3)]
    instance = Instance(*archives[(model, 3)], "dependencies", 3)
    fmu = instance.fmu
    try:
        assert description.outputs
        for output in description.outputs:
            vr = output.variable.valueReference
            listed = sorted(v.valueReference for v in output.dependencies)
            count = ctypes.c_size_t(99)
            assert fmu.fmi3GetNumberOfVariableDependencies(fmu.component, vr,
                                                           ctypes.byref(count)) == 0
            assert count.value == len(listed), output.variable.name
            n = len(listed)
            element_of_dependent = (ctypes.c_size_t * max(n, 1))()
            independents = (ctypes.c_uint32 * max(n, 1))()
            element_of_independents = (ctypes.c_size_t * max(n, 1))()
            kinds = (ctypes.c_int * max(n, 1))()
            assert fmu.fmi3GetVariableDependencies(fmu.component, vr, element_of_dependent,
                                                   independents, element_of_independents, kinds,
                                                   n) == 0
            assert sorted(independents[:n]) == listed, output.variable.name
            assert list(kinds[:n]) == [5] * n  # fmi3Dependent
        # An input is no unknown of the model structure: an error, not a crash.
        an_input = next(v for v in description.modelVariables if v.causality == "input")
        with pytest.raises(FMICallException, match="status 3"):
            fmu.fmi3GetNumberOfVariableDependencies(fmu.component, an_input.valueReference,
                                                    ctypes.byref(ctypes.c_size_t()))
    finally:
        instance.fmu.freeInstance()


@pytest.mark.parametrize("model", [support.VEHICLE, support.ESTIMATOR])
def test_the_archives_validate(model):
    path = str(fmi3_path(model))
    assert validate_fmu(path) == []
    description = read_model_description(path, validate=True)
    assert description.fmiVersion == "3.0"
    names = zipfile.ZipFile(path).namelist()
    assert f"binaries/x86_64-linux/{model}.so" in names
    assert "documentation/index.html" in names
    assert "terminalsAndIcons/icon.png" in names
    from lxml import etree
    import fmpy
    schema = etree.XMLSchema(file=os.path.join(os.path.dirname(fmpy.__file__), "schema", "fmi3",
                                               "fmi3ModelDescription.xsd"))
    document = etree.fromstring(zipfile.ZipFile(path).read("modelDescription.xml"))
    assert schema.validate(document), schema.error_log


@pytest.mark.parametrize("model, fmi2_fixture", [(support.VEHICLE, "vehicle_fmu"),
                                                 (support.ESTIMATOR, "estimator_fmu")])
def test_the_fmi3_archive_carries_the_fmi2_archives_library_icon_and_documentation(
        model, fmi2_fixture, request):
    """One library serves both archives, so the FMI 3 archive is as portable as the FMI 2 one
    (tests/fmpy/test_portable_binaries.py checks that library's glibc symbol versions)."""
    fmi2 = zipfile.ZipFile(request.getfixturevalue(fmi2_fixture))
    fmi3 = zipfile.ZipFile(fmi3_path(model))
    assert (fmi3.read(f"binaries/x86_64-linux/{model}.so")
            == fmi2.read(f"binaries/linux64/{model}.so"))
    assert fmi3.read("terminalsAndIcons/icon.png") == fmi2.read("model.png")
    for name in fmi2.namelist():
        if name.startswith("documentation/"):
            assert fmi3.read(name) == fmi2.read(name), name
    two = read_model_description(str(request.getfixturevalue(fmi2_fixture)))
    three = read_model_description(str(fmi3_path(model)))
    for attribute in ("modelName", "description", "version", "author", "license", "copyright"):
        assert getattr(three, attribute) == getattr(two, attribute), attribute
    assert three.instantiationToken == two.guid
