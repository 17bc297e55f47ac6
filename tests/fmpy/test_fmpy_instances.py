"""Instances and libraries under fmpy: 1,000 load/instantiate/run/free/unload cycles per FMU in one
process, and independent instances in parallel threads giving bit-identical results."""

import pathlib
import subprocess
import sys
import threading

import numpy as np
import pytest

import fmu_support as support

CYCLES = 1000
RUNNER = pathlib.Path(__file__).with_name("fmpy_load_cycles_runner.py")


@pytest.mark.parametrize("which", [support.VEHICLE, support.ESTIMATOR])
def test_thousand_load_unload_cycles_in_one_process(which, request):
    interface, directory = support.interface_and_directory(request, which)
    process = subprocess.run([sys.executable, str(RUNNER), str(directory), interface.description.guid,
                              interface.description.coSimulation.modelIdentifier, str(CYCLES)],
                             capture_output=True, text=True, timeout=600)
    assert process.returncode == 0, (
        f"{which}: the process died with return code {process.returncode} (negative = signal) "
        f"during the load/unload cycles\nstderr: {process.stderr[-4000:]}")
    assert process.stdout.strip().endswith(f"completed {CYCLES}")


def run_vehicle(vehicle, directory, name, steps, results):
    slave = support.Slave(vehicle, directory, name)
    try:
        slave.initialise(support.seed000_vehicle_parameters(vehicle))
        outputs = slave.real_references(["vy", "yaw_rate_meas", "ay_meas", "omega_front_meas"])
        inputs = slave.real_references(support.DRIVER_INPUTS)
        record = np.zeros((steps, len(outputs)))
        time = 0.0
        for k in range(steps):
            # A steering sine, so the motion is not trivial.
            slave.fmu.setReal(inputs, [0.05 * np.sin(2.0 * time), 0.0, 0.0])
            slave.fmu.doStep(currentCommunicationPoint=time, communicationStepSize=0.001)
            record[k] = slave.fmu.getReal(outputs)
            time += 0.001
        results[name] = record
    finally:
        slave.free()


def test_parallel_instances_in_threads_are_independent_and_deterministic(vehicle, vehicle_dir):
    steps = 1500
    reference = {}
    run_vehicle(vehicle, vehicle_dir, "alone", steps, reference)
    results = {}
    threads = [threading.Thread(target=run_vehicle, args=(vehicle, vehicle_dir, f"thread{i}", steps, results))
               for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=300)
    assert sorted(results) == [f"thread{i}" for i in range(4)], "a thread failed"
    for name, record in results.items():
        assert np.array_equal(record, reference["alone"]), f"{name} differs from the single-threaded run"
    # Noise is on: the sensor columns are not the smooth truth, so equality is not trivial.
    assert np.std(np.diff(reference["alone"][:, 1])) > 0
