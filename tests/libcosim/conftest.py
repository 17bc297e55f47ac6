"""Fixtures of the libcosim tests: the packaged archives are found, and required, exactly as the fmpy
tests do it (tests/fmpy/conftest.py, re-exported here), so a missing archive fails with the
command that builds it."""

import importlib.util
import pathlib
import sys

FMPY_TESTS = pathlib.Path(__file__).resolve().parents[1] / "fmpy"
sys.path.insert(0, str(FMPY_TESTS))

_spec = importlib.util.spec_from_file_location("fmpy_test_fixtures", FMPY_TESTS / "conftest.py")
_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_fixtures)

vehicle_fmu = _fixtures.vehicle_fmu
estimator_fmu = _fixtures.estimator_fmu
ssp_file = _fixtures.ssp_file
vehicle = _fixtures.vehicle
estimator = _fixtures.estimator
vehicle_dir = _fixtures.vehicle_dir
estimator_dir = _fixtures.estimator_dir
