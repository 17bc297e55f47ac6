"""Fixtures of the campaign tests: the harness binary (tests/conftest.py's build), the packaged
FMUs, and one Dask cluster of 2 worker processes on loopback started with the `dask scheduler`
and `dask worker` commands (as harness/campaign/README.md tells a cluster user), shared by the
tests that pass `--scheduler`."""

import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

from vse_campaign.__main__ import default_fmu_dir

ROOT = pathlib.Path(__file__).resolve().parents[2]
DASK = pathlib.Path(sys.executable).with_name("dask")


@pytest.fixture(scope="session")
def harness_binary(workspace_executables):
    return workspace_executables[("bin", "harness")]


@pytest.fixture(scope="session")
def fmu_dir():
    """<target>/fmu, where tests/run.sh packages the FMUs before pytest."""
    directory = default_fmu_dir()
    missing = [n for n in ("ReferenceVehicle.fmu", "VehicleStateEstimator.fmu") if not (directory / n).is_file()]
    assert not missing, f"{missing} not in {directory}: run `cargo run --release -p packaging` first"
    return directory


def _wait_for_workers(scheduler_file: pathlib.Path, count: int, deadline: float) -> str:
    from distributed import Client
    while not scheduler_file.exists():
        if time.monotonic() > deadline:
            raise AssertionError("dask scheduler wrote no scheduler file in time")
        time.sleep(0.1)
    address = json.loads(scheduler_file.read_text())["address"]
    with Client(address, timeout=30) as client:
        client.wait_for_workers(count, timeout=max(1.0, deadline - time.monotonic()))
    return address


@pytest.fixture(scope="session")
def dask_scheduler(tmp_path_factory):
    """Address of a scheduler on 127.0.0.1 with 2 single-threaded worker processes."""
    folder = tmp_path_factory.mktemp("dask")
    scheduler_file = folder / "scheduler.json"
    processes = [subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                   "--dashboard-address", "127.0.0.1:0",
                                   "--scheduler-file", str(scheduler_file)],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  start_new_session=True)]
    processes.append(subprocess.Popen([str(DASK), "worker", "--scheduler-file", str(scheduler_file),
                                       "--nworkers", "2", "--nthreads", "1", "--host", "127.0.0.1",
                                       "--no-dashboard"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      start_new_session=True))
    try:
        yield _wait_for_workers(scheduler_file, 2, time.monotonic() + 60)
    finally:
        # Each command runs in a session of its own: its process group holds it and the worker
        # processes it started, and nothing else.
        for process in reversed(processes):
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
