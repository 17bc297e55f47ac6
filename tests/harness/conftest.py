"""Fixtures of the harness tests: the packaged FMUs (a missing archive fails with the command that
builds it) and the harness binary of the workspace's release build. Plain helpers live in
harness_support.py."""

import pytest

from harness_support import fmu_directory


@pytest.fixture(scope="session")
def fmu_dir():
    directory = fmu_directory()
    for name in ("ReferenceVehicle.fmu", "VehicleStateEstimator.fmu"):
        if not (directory / name).is_file():
            pytest.fail(f"{directory / name} does not exist: build the archives first with "
                        f"`cargo run --release -p packaging` (tests/run.sh does this before pytest)",
                        pytrace=False)
    return directory


@pytest.fixture(scope="session")
def harness_binary(workspace_executables):
    """The harness binary of the workspace's release build (tests/conftest.py)."""
    binary = workspace_executables[("bin", "harness")]
    assert binary.is_file(), binary
    return binary
