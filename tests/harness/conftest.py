"""Fixtures of the harness tests: the packaged FMUs (a missing archive fails with the command that
builds it) and the harness binary of the workspace's release build."""

import os
import pathlib
import subprocess
import tomllib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# The seed-000 manoeuvre numbers, generated from the Rust crate harness/manoeuvres (src/seed000.rs).
with open(ROOT / "harness" / "manoeuvres" / "seed000_manoeuvres.toml", "rb") as _table_file:
    SEED000_MANOEUVRES = tomllib.load(_table_file)


def target_directory() -> pathlib.Path:
    target = os.environ.get("CARGO_TARGET_DIR")
    return ((ROOT / target) if target else (ROOT / "target")).resolve()


def fmu_directory() -> pathlib.Path:
    if os.environ.get("FMU_DIR"):
        return pathlib.Path(os.environ["FMU_DIR"]).resolve()
    return target_directory() / "fmu"


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


def run_harness(binary, *arguments, timeout=900):
    completed = subprocess.run([str(binary), *map(str, arguments)], cwd=ROOT, capture_output=True,
                               text=True, timeout=timeout)
    if completed.returncode != 0:
        raise AssertionError(f"harness {' '.join(map(str, arguments))} failed:\n"
                             f"{completed.stdout}\n{completed.stderr}")
    return completed
