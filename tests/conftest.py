"""Shared by every Python test: the release build of the workspace's binaries.

tests/run.sh compiles every workspace target once, as `cargo build --release --workspace
--all-targets`, with clippy-driver as the workspace's compiler (RUSTC_WORKSPACE_WRAPPER, which the
tests inherit). Asking cargo for exactly that selection again, in the same environment, compiles
nothing, while any other (`-p harness`, `cargo run --example` in the dev profile) would make cargo
unify the dependency features differently and compile them a second time. The binaries are found
through cargo's own artefact messages, so CARGO_TARGET_DIR and cargo configs are honoured."""

import json
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
WORKSPACE_BUILD = ["cargo", "build", "--release", "--workspace", "--all-targets",
                   "--message-format=json-render-diagnostics"]


def build_workspace():
    """Builds (or finds up to date) every workspace target; returns {(kind, name): executable}."""
    completed = subprocess.run(WORKSPACE_BUILD, cwd=ROOT, stdout=subprocess.PIPE, text=True,
                               timeout=3600)
    if completed.returncode != 0:
        raise AssertionError(f"`{' '.join(WORKSPACE_BUILD)}` failed (compiler output above)")
    executables = {}
    for line in completed.stdout.splitlines():
        message = json.loads(line)
        if message.get("reason") == "compiler-artifact" and message.get("executable"):
            target = message["target"]
            kinds = [kind for kind in target["kind"] if kind in ("bin", "example")]
            if kinds and not message["profile"]["test"]:
                executables[(kinds[0], target["name"])] = pathlib.Path(message["executable"])
    return executables


@pytest.fixture(scope="session")
def workspace_executables():
    # Under pytest-xdist each worker asks once; cargo's lock on the target directory makes the
    # second wait for the first, and then it finds everything built.
    return build_workspace()


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "starts_first: the tests of the suite's longest fixture (the `harness demo` run "
        "of tests/harness/test_demo.py); collected, and so handed to an xdist worker, first")


def pytest_collection_modifyitems(items):
    """The `starts_first` tests first (a stable sort keeps every other order): with `pytest -n 2
    --dist loadscope --no-loadscope-reorder` (tests/run.sh) xdist hands out the modules in this
    order, so one worker starts the demo at once and the other runs the remaining modules
    meanwhile; the suite then lasts about as long as the demo."""
    items.sort(key=lambda item: item.get_closest_marker("starts_first") is None)
