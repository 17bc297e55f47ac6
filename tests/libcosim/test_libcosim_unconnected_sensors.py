"""A second importer leaving sensor inputs unconnected: libcosim runs ReferenceVehicle and
VehicleStateEstimator with the wheel speeds, or the longitudinal accelerometer, not connected
(the cases of tests/fmpy/test_fmpy_unconnected_sensors.py), so it never sets those inputs. Its
outputs must equal, bit for bit, those of the plain fmpy loop in libcosim's call order that sets
them to NaN at every step, the value the estimator reads as "no sample", and its estimates must
follow the reference's truth: an unconnected sensor is missing in libcosim as in fmpy, never a
measurement of its start value."""

import pytest

import fmu_support as support
from test_fmpy_unconnected_sensors import (STEPS, UNCONNECTED, assert_estimates_follow_the_truth,
                                           connected_sensors)
from test_libcosim_equivalence import libcosim_run


@pytest.mark.parametrize("case", list(UNCONNECTED))
def test_libcosim_reads_an_unconnected_sensor_as_missing(
        case, vehicle, estimator, vehicle_fmu, estimator_fmu, vehicle_dir, estimator_dir):
    unconnected = UNCONNECTED[case]
    sensors = connected_sensors(vehicle, estimator, unconnected)
    cosim = libcosim_run(vehicle, estimator, vehicle_fmu, estimator_fmu, STEPS, sensors)
    plain, _ = support.libcosim_order_loop(vehicle, estimator, vehicle_dir, estimator_dir, STEPS,
                                           sensors, missing=unconnected)
    names = support.compared_output_names(vehicle, estimator)
    support.assert_bit_identical(cosim, plain, names, f"libcosim, {' and '.join(unconnected)} "
                                                      f"not connected")
    assert_estimates_follow_the_truth(cosim, names)
