"""The shipped VehicleWithEstimator.ssp in libcosim (Open Simulation Platform) through libcosimpy:
it loads (every connection has a startElement, every connector a type), runs
its DefaultExperiment with the step size of the `com.opensimulationplatform` annotation, and
applies the driver inputs' ParameterBinding to both FMUs. libcosim does not stop at the SSD's
stopTime by itself (its ssp_configuration keeps start time and algorithm only), so the test runs
to it. The car files cannot be bound in libcosim: its SSV parser (ssp_parser.cpp,
parse_parameter_set) aborts the process on the `ssv:Enumeration` that selects model 3."""

import zipfile

import pytest
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver
from lxml import etree

import fmu_support as support
from test_fmpy_ssp import default_experiment

NANOSECONDS = 1_000_000_000


def driver_values(ssp_path):
    with zipfile.ZipFile(ssp_path) as archive:
        root = etree.fromstring(archive.read("resources/driver_inputs.ssv"))
    return {p.get("name"): float(p.find("{*}Real").get("value")) for p in root.iter("{*}Parameter")}


@pytest.fixture(scope="module")
def default_run(ssp_file, vehicle, estimator):
    """The default experiment in libcosim: (execution, observer, slave indices, step in ns)."""
    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_ssp_file(str(ssp_file))
    index = {info.name.decode(): info.index for info in execution.slave_infos()}
    observer = CosimObserver.create_last_value()
    assert execution.add_observer(observer)
    assert execution.step()
    first_step = execution.status().current_time
    start, stop, _ = default_experiment(ssp_file)
    assert start == 0.0
    assert execution.simulate_until(round(stop * NANOSECONDS))
    return execution, observer, index, first_step


def test_libcosim_loads_both_components(default_run):
    execution, _, index, _ = default_run
    assert execution.num_slaves() == 2
    assert set(index) == {support.VEHICLE, support.ESTIMATOR}


def test_libcosim_steps_with_the_default_experiment(default_run, ssp_file, vehicle):
    execution, _, _, first_step = default_run
    _, stop, step = default_experiment(ssp_file)
    assert step == float(vehicle.description.defaultExperiment.stepSize)
    assert first_step == round(step * NANOSECONDS)
    assert execution.status().current_time == round(stop * NANOSECONDS)


def test_libcosim_applies_the_driver_binding_and_the_estimator_tracks(default_run, ssp_file,
                                                                      vehicle, estimator):
    _, observer, index, _ = default_run
    driver = driver_values(ssp_file)
    for interface in (vehicle, estimator):
        name = interface.description.modelName
        names = list(driver)
        values = observer.last_real_values(index[name], [interface.vr(n) for n in names])
        assert dict(zip(names, values)) == driver, name
    truth = dict(zip(["vy", "yaw_rate"], observer.last_real_values(
        index[support.VEHICLE], [vehicle.vr("vy"), vehicle.vr("yaw_rate")])))
    estimate = dict(zip(["vy", "yaw_rate"], observer.last_real_values(
        index[support.ESTIMATOR], [estimator.vr("vy_est"), estimator.vr("yaw_rate_est")])))
    # After 20 s of the bound steering angle the car turns left; the estimate is on it.
    assert truth["yaw_rate"] > 0.1
    assert estimate["yaw_rate"] == pytest.approx(truth["yaw_rate"], abs=0.01)
    assert estimate["vy"] == pytest.approx(truth["vy"], abs=0.02)
