"""Fixtures of the fmpy tests: the packaged archives (a missing archive fails the tests with the
command that builds it; nothing is skipped) and their extracted contents."""

import pytest
from fmpy import extract

import fmu_support as support


def _require(file_name):
    path = support.archive_path(file_name)
    if not path.is_file():
        pytest.fail(f"{path} does not exist: build the archives first with "
                    f"`cargo run --release -p packaging` (tests/run.sh does this before pytest)",
                    pytrace=False)
    return path


@pytest.fixture(scope="session")
def vehicle_fmu():
    return _require(f"{support.VEHICLE}.fmu")


@pytest.fixture(scope="session")
def estimator_fmu():
    return _require(f"{support.ESTIMATOR}.fmu")


@pytest.fixture(scope="session")
def ssp_file():
    return _require(f"{support.SSP_NAME}.ssp")


@pytest.fixture(scope="session")
def vehicle(vehicle_fmu):
    return support.Interface(vehicle_fmu)


@pytest.fixture(scope="session")
def estimator(estimator_fmu):
    return support.Interface(estimator_fmu)


@pytest.fixture(scope="session")
def vehicle_dir(vehicle_fmu, tmp_path_factory):
    return extract(str(vehicle_fmu), str(tmp_path_factory.mktemp("vehicle")))


@pytest.fixture(scope="session")
def estimator_dir(estimator_fmu, tmp_path_factory):
    return extract(str(estimator_fmu), str(tmp_path_factory.mktemp("estimator")))
