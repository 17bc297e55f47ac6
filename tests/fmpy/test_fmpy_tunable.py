"""Through fmpy and the C ABI: noise levels, gates and tyre scales are `tunable`;
a value set during the run takes effect at the next filter sample, a `fixed` parameter set during
the run is refused with fmi2Error."""

import math

import pytest
from fmpy.fmi1 import FMICallException

import fmu_support as support

SAMPLE_TIME = 0.01
STEP = 0.005  # every other doStep processes a filter sample


def sensors(t):
    wheel = 20.0 / 0.3
    return {"yaw_rate_meas": 0.05 * math.sin(t), "ay_meas": 0.8 * math.sin(3.0 * t),
            "omega_front_meas": wheel, "omega_rear_meas": wheel, "ax_meas": 0.0, "vx_meas": 20.0}


def run(estimator, estimator_dir, name, change=None):
    """Steps 0..203; before doStep 202 (the one that processes the sample at 1.01 s) applies
    `change`. Returns the NIS after each doStep."""
    slave = support.Slave(estimator, estimator_dir, name)
    nis = []
    try:
        slave.initialise({"sample_time": SAMPLE_TIME})
        for k in range(204):
            if k == 202 and change:
                slave.set(change)
            slave.set(sensors(k * STEP))
            slave.fmu.doStep(currentCommunicationPoint=k * STEP, communicationStepSize=STEP)
            nis.append(slave.fmu.getReal([estimator.vr("nis")])[0])
    finally:
        slave.free()
    return nis


def test_a_noise_level_set_mid_run_acts_at_the_next_sample(estimator, estimator_dir):
    assert estimator["measurement_noise_std_ay"].variability == "tunable"
    plain = run(estimator, estimator_dir, "plain")
    tuned = run(estimator, estimator_dir, "tuned", {"measurement_noise_std_ay": 5.0})
    assert plain[:202] == tuned[:202]
    # the sample of doStep 202 already weighs the ay row with R = 25: a smaller NIS
    assert tuned[202] < plain[202]


def test_a_fixed_parameter_set_mid_run_is_refused(estimator, estimator_dir):
    assert estimator["mass"].variability == "fixed"
    slave = support.Slave(estimator, estimator_dir, "fixed")
    try:
        slave.initialise({})
        slave.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=STEP)
        with pytest.raises(FMICallException):
            slave.set({"mass": 1600.0})
    finally:
        slave.fmu.freeInstance()
