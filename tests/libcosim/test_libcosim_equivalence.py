"""A second, independent co-simulation master: libcosim, the Open Simulation
Platform's C++ engine, through its PyPI wrapper libcosimpy, runs ReferenceVehicle and
VehicleStateEstimator coupled, and a plain fmpy FMU2Slave loop that makes the same FMI calls in
the same order with the same time values gives bit-identical outputs at every communication point.

libcosim's fixed-step algorithm (src/cosim/algorithm/fixed_step_algorithm.cpp and
slave_simulator.cpp) is a Jacobi scheme on an integer nanosecond clock:
- initialisation: fmi2SetupExperiment(start 0, no stop time) and fmi2EnterInitializationMode on
  each instance, its outputs read; then, once per instance, the connected inputs set from the
  outputs read last and the outputs read again; then fmi2ExitInitializationMode, outputs read and
  transferred to the connected inputs;
- each step: every instance gets its pending input values (transferred outputs, overrides) and
  steps from t_n = n * h, with t_n and h converted from nanoseconds as (n * h_ns) / 1e9 and
  h_ns / 1e9; then every output is read and transferred.
The estimator therefore sees the reference's sensor outputs of t_n during the step from t_n, like
the harness master's order (tests/harness/test_master_equivalence.py).

libcosim does not import Enumeration variables (fmi/v2/fmu.cpp logs "FMI 2.0 Enumeration variable
type not supported ... will be ignored"), so both masters run the estimator's default, which
packaging/doc/VehicleStateEstimator.html documents for libcosim users."""

import numpy as np
import pytest
from libcosimpy import CosimConstants
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave

import fmu_support as support

STEPS = 2500


def libcosim_run(vehicle, estimator, vehicle_fmu, estimator_fmu, steps=STEPS, sensors=None):
    """Rows of every Real and Integer output of both FMUs after each of `steps` steps, from
    libcosim, with the reference's outputs `sensors` (default: all of `sensor_connections`)
    connected to the estimator's inputs of the same name."""
    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(support.STEP_NS)
    index = {}
    for interface, path in ((vehicle, vehicle_fmu), (estimator, estimator_fmu)):
        name = interface.description.modelName
        index[name] = execution.add_local_slave(CosimLocalSlave(str(path), name))
        assert index[name] >= 0, f"libcosim could not load {path}"
    v, e = index[support.VEHICLE], index[support.ESTIMATOR]
    for name in support.sensor_connections(vehicle, estimator) if sensors is None else sensors:
        status = execution.connect_real_variables(v, vehicle.vr(name), e, estimator.vr(name))
        assert status == CosimConstants.success, f"libcosim could not connect {name}"
    observer = CosimObserver.create_last_value()
    assert execution.add_observer(observer)
    driver = CosimManipulator.create_override()
    assert execution.add_manipulator(driver)
    rows = []
    for n in range(steps):
        angle = support.equivalence_steering(support.seconds(n * support.STEP_NS))
        for slave, interface in ((v, vehicle), (e, estimator)):
            assert driver.slave_real_values(slave, [interface.vr("steering_angle")], [angle])
        assert execution.step(), execution.status()
        assert execution.status().current_time == (n + 1) * support.STEP_NS
        row = []
        for slave, interface in ((v, vehicle), (e, estimator)):
            outputs = support.compared_outputs(interface)
            reals = [x.valueReference for x in outputs if x.type == "Real"]
            integers = [x.valueReference for x in outputs if x.type == "Integer"]
            row += observer.last_real_values(slave, reals)
            row += [float(i) for i in observer.last_integer_values(slave, integers)]
        rows.append(row)
    return np.array(rows)


def test_libcosim_leaves_out_the_enumerations_so_the_documented_default_runs(estimator,
                                                                           estimator_fmu):
    """packaging/doc/VehicleStateEstimator.html tells libcosim users that they get the EKF on
    the grip model (model 3): libcosim lists no Enumeration variable, and those are the XML's
    start values."""
    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(support.STEP_NS)
    slave = execution.add_local_slave(CosimLocalSlave(str(estimator_fmu), support.ESTIMATOR))
    listed = {v.name.decode() for v in execution.slave_variables(slave)}
    enumerations = {v.name for v in estimator.description.modelVariables if v.type == "Enumeration"}
    assert enumerations >= {"estimator", "model"} and not enumerations & listed
    assert listed >= set(estimator.names("input")) | set(estimator.names("output"))
    assert estimator.start("estimator") == estimator.enumeration_value("estimator", "ekf")
    assert estimator.start("model") == estimator.enumeration_value("model", "single_track_grip")


def test_libcosim_and_an_fmpy_loop_give_bit_identical_outputs(
        vehicle, estimator, vehicle_fmu, estimator_fmu, vehicle_dir, estimator_dir):
    cosim = libcosim_run(vehicle, estimator, vehicle_fmu, estimator_fmu)
    plain, _ = support.libcosim_order_loop(vehicle, estimator, vehicle_dir, estimator_dir, STEPS)
    names = support.compared_output_names(vehicle, estimator)
    assert len(cosim) == STEPS
    support.assert_bit_identical(cosim, plain, names, "libcosim")
