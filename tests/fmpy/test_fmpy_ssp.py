"""The SSP system VehicleWithEstimator simulated with fmpy.ssp.

fmpy's SSP master is minimal: it applies each connection after all components stepped, so every
connected input lags its source by one communication step, and it ignores ParameterBindings (the
SSP has none: both FMUs run on their defaults, i.e. reference noise on and the default estimator)."""

import numpy as np
import pytest
from fmpy.ssp.simulation import simulate_ssp

import fmu_support as support

STEP = 1e-3
STOP = 7.0


@pytest.fixture(scope="module")
def ssp_run(ssp_file):
    steering = lambda time: float(support.steering_ramp(time, support.MODERATE_RAMP_ANGLE))
    return simulate_ssp(str(ssp_file), start_time=0.0, stop_time=STOP, step_size=STEP,
                        input={"steering_angle": steering})


def column(result, element, name):
    return result[f"{element}.{name}"]


def test_ssp_runs_the_whole_horizon(ssp_run):
    assert len(ssp_run) == int(round(STOP / STEP))
    assert ssp_run["time"][-1] == pytest.approx(STOP - STEP)


def test_ssp_connections_carry_values_by_name(ssp_run, vehicle, estimator):
    # Rows are recorded after the connections were applied: a connected input equals its source.
    for name in support.DRIVER_INPUTS:
        assert np.array_equal(column(ssp_run, support.VEHICLE, name), ssp_run[name])
        assert np.array_equal(column(ssp_run, support.ESTIMATOR, name), ssp_run[name])
    for name in set(vehicle.names("output")) & set(estimator.names("input")):
        assert np.array_equal(column(ssp_run, support.ESTIMATOR, name), column(ssp_run, support.VEHICLE, name)), name
    assert np.max(ssp_run["steering_angle"]) == pytest.approx(support.MODERATE_RAMP_ANGLE)


def test_ssp_estimator_tracks_the_vehicle(ssp_run):
    vy = column(ssp_run, support.VEHICLE, "vy")
    vy_est = column(ssp_run, support.ESTIMATOR, "vy_est")
    assert np.all(np.isfinite(vy_est))
    turning = ssp_run["time"] > 5.0
    # The car really turns left (ISO 8855: positive yaw rate) and has a lateral velocity to track.
    assert np.all(column(ssp_run, support.VEHICLE, "yaw_rate")[turning] > 0.05)
    assert np.max(np.abs(vy)) > 0.01
    # The estimator sees every measurement one step late (fmpy's connection lag); with 1 ms steps
    # that costs far less than the 1 cm/s the tolerance allows.
    error = support.rmse(vy_est, vy)
    print(f"SSP default estimator: vy RMSE {error:.3g} m/s")
    assert error < 1e-2
    yaw_error = support.rmse(column(ssp_run, support.ESTIMATOR, "yaw_rate_est"),
                             column(ssp_run, support.VEHICLE, "yaw_rate"))
    assert yaw_error < 1e-2
