"""FMU states through fmpy: for every estimator (the particle filter included, whose state holds
its particles and its random generator's position), a state taken mid-run, serialized,
deserialized into a new instance and set there continues bit-identically."""

import numpy as np
import pytest

import fmu_support as support

ESTIMATORS = list(support.ESTIMATOR_KINDS)
OUTPUTS = ["vx_est", "vy_est", "yaw_rate_est", "sideslip_est", "vx_std", "nis"]
SENSORS = ["yaw_rate_meas", "ay_meas", "omega_front_meas", "omega_rear_meas"]


def drive(slave, start_step, steps):
    """Feeds a deterministic sensor pattern (a steering sine and consistent measurements) and
    returns the outputs after each step."""
    inputs = slave.real_references(support.DRIVER_INPUTS + SENSORS)
    outputs = slave.real_references(OUTPUTS)
    record = np.zeros((steps, len(OUTPUTS)))
    for k in range(steps):
        time = (start_step + k) * 1e-3
        steer = 0.03 * np.sin(2.0 * time)
        wheel = 18.0 / 0.3
        slave.fmu.setReal(inputs, [steer, 0.0, 0.0, 5.0 * steer, 90.0 * steer,
                                   wheel * (1.0 + 1e-3 * np.cos(7.0 * time)), wheel])
        slave.fmu.doStep(currentCommunicationPoint=time, communicationStepSize=1e-3)
        record[k] = slave.fmu.getReal(outputs)
    return record


@pytest.mark.parametrize("kind", ESTIMATORS)
def test_serialized_state_continues_bit_identically(kind, estimator, vehicle, estimator_dir):
    parameters = support.seed000_estimator_parameters(estimator, vehicle, kind)
    parameters["particle_count"] = 200
    original = support.Slave(estimator, estimator_dir, "original")
    copy = support.Slave(estimator, estimator_dir, "copy")
    try:
        original.initialise(parameters)
        copy.initialise(parameters)
        drive(original, 0, 300)
        state = original.fmu.getFMUstate()
        blob = original.fmu.serializeFMUstate(state)
        reference = drive(original, 300, 200)

        restored = copy.fmu.deSerializeFMUstate(blob)
        copy.fmu.setFMUstate(restored)
        continued = drive(copy, 300, 200)
        assert np.array_equal(continued, reference), f"{kind}: the deserialized state diverges"
        assert np.all(np.isfinite(continued))
        # Not a trivial equality: the estimate moves over the continued run.
        assert np.ptp(reference[:, 1]) > 0.0
        copy.fmu.freeFMUstate(restored)
        original.fmu.freeFMUstate(state)
    finally:
        original.free()
        copy.free()
