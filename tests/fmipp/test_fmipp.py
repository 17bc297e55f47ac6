"""A third, independent FMI importer: FMI++ (fmipp, its C++ FMI 2.0 import with its own
model-description parser, built by packaging/fmipp.sh), beside fmpy and libcosim.

- FMI++'s `terminate()` frees the instance and its destructor frees it again
  (fmipp_terminate_runner.py): the process must survive it. Before fmi-export listed its live
  components (fmu-src/fmi-export/src/live.rs) it aborted in the second fmi2Terminate.
- ReferenceVehicle and VehicleStateEstimator coupled by a loop of FMI++ calls give, at every
  communication point, the outputs of the same loop made of plain fmpy FMU2Slave calls, bit for
  bit. FMI++'s calls: fmi2Instantiate then fmi2SetDebugLogging(loggingOn, 0 categories);
  `initialize` is fmi2SetupExperiment(toleranceDefined, tolerance = its time resolution 1e-9,
  start 0, no stop time), fmi2EnterInitializationMode, fmi2ExitInitializationMode; `doStep`
  passes its own time, the sum of the step sizes so far, and newStep = true. FMI++ reads no
  Enumeration variable (only Real, Integer, Boolean and String), so both loops run the
  estimator's default (the EKF on the grip model, model 3)."""

import pathlib
import subprocess
import sys

import numpy as np

import fmipp
import fmu_support as support

STEP = 0.001
STEPS = 2500
TIME_RESOLUTION = 1e-9


def test_fmipp_terminate_and_its_destructor_free_twice_and_the_process_survives(
        vehicle_fmu, estimator_fmu, tmp_path):
    runner = pathlib.Path(__file__).with_name("fmipp_terminate_runner.py")
    result = subprocess.run(
        [sys.executable, str(runner), str(tmp_path),
         str(vehicle_fmu), support.VEHICLE, str(estimator_fmu), support.ESTIMATOR],
        capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and "completed" in result.stdout, \
        f"return code {result.returncode}\n{result.stdout}\n{result.stderr}"


class FmippSlave:
    """One instance through FMI++, its variables read and written by name."""

    def __init__(self, interface, fmu_path, directory, instance_name):
        self.interface = interface
        uri = fmipp.extractFMU(str(fmu_path), str(directory))
        self.fmu = fmipp.FMUCoSimulationV2(uri, interface.description.coSimulation.modelIdentifier,
                                           False, TIME_RESOLUTION)
        assert self.fmu.instantiate(instance_name, 0.0, False, False) == fmipp.statusOK
        assert self.fmu.initialize(0.0, False, 0.0) == fmipp.statusOK

    def set(self, name, value):
        assert self.fmu.setRealValue(name, value) == fmipp.statusOK, name

    def step(self, t):
        assert self.fmu.doStep(t, STEP, True) == fmipp.statusOK, self.fmu.getLastStatus()

    def outputs(self):
        row = []
        for variable in support.compared_outputs(self.interface):
            if variable.type == "Real":
                row.append(self.fmu.getRealValue(variable.name))
            else:
                row.append(float(self.fmu.getIntegerValue(variable.name)))
            assert self.fmu.getLastStatus() == fmipp.statusOK, variable.name
        return row


def fmipp_run(vehicle, estimator, vehicle_fmu, estimator_fmu, directory):
    car = FmippSlave(vehicle, vehicle_fmu, directory, "car")
    filt = FmippSlave(estimator, estimator_fmu, directory, "filter")
    sensors = support.sensor_connections(vehicle, estimator)
    rows, t = [], 0.0
    for _ in range(STEPS):
        angle = support.equivalence_steering(t)
        car.set("steering_angle", angle)
        car.step(t)
        filt.set("steering_angle", angle)
        for name in sensors:
            filt.set(name, car.fmu.getRealValue(name))
        filt.step(t)
        rows.append(car.outputs() + filt.outputs())
        t += STEP  # FMI++'s own clock (FMUCoSimulation::doStep: time_ += communicationStepSize)
    return np.array(rows)


def fmpy_loop(vehicle, estimator, vehicle_dir, estimator_dir):
    """The same calls in the same order as FMI++ makes them (module docstring)."""
    car = support.Slave(vehicle, vehicle_dir, support.VEHICLE)
    filt = support.Slave(estimator, estimator_dir, support.ESTIMATOR)
    for slave in (car, filt):
        slave.fmu.setDebugLogging(False, [])
        slave.fmu.setupExperiment(tolerance=TIME_RESOLUTION, startTime=0.0)
        slave.fmu.enterInitializationMode()
        slave.fmu.exitInitializationMode()
        slave.initialised = True
    sensors = support.sensor_connections(vehicle, estimator)
    rows, t = [], 0.0
    for _ in range(STEPS):
        angle = support.equivalence_steering(t)
        car.set({"steering_angle": angle})
        car.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
        filt.set({"steering_angle": angle})
        filt.set(dict(zip(sensors, car.fmu.getReal(car.real_references(sensors)))))
        filt.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
        rows.append(support.read_outputs(car) + support.read_outputs(filt))
        t += STEP
    for slave in (car, filt):
        slave.free()
    return np.array(rows)


def test_fmipp_and_an_fmpy_loop_give_bit_identical_outputs(
        vehicle, estimator, vehicle_fmu, estimator_fmu, vehicle_dir, estimator_dir, tmp_path):
    cosim = fmipp_run(vehicle, estimator, vehicle_fmu, estimator_fmu, tmp_path)
    plain = fmpy_loop(vehicle, estimator, vehicle_dir, estimator_dir)
    names = support.compared_output_names(vehicle, estimator)
    assert len(cosim) == STEPS
    support.assert_bit_identical(cosim, plain, names, "FMI++")
