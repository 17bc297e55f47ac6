"""What the harness tests share beyond fixtures: the repository root, the seed-000 manoeuvre
numbers and running the harness binary. A module of its own name, not conftest: with several test
folders each holding a conftest.py, `from conftest import ...` picks whichever conftest was
imported first (pytest tests/harness tests/campaign failed so)."""

import os
import pathlib
import subprocess
import tomllib

ROOT = pathlib.Path(__file__).resolve().parents[2]

# The seed-000 manoeuvre numbers, generated from the Rust crate fmu-src/manoeuvres (src/seed000.rs).
with open(ROOT / "fmu-src" / "manoeuvres" / "seed000_manoeuvres.toml", "rb") as _table_file:
    SEED000_MANOEUVRES = tomllib.load(_table_file)


def target_directory() -> pathlib.Path:
    target = os.environ.get("CARGO_TARGET_DIR")
    return ((ROOT / target) if target else (ROOT / "target")).resolve()


def fmu_directory() -> pathlib.Path:
    if os.environ.get("FMU_DIR"):
        return pathlib.Path(os.environ["FMU_DIR"]).resolve()
    return target_directory() / "fmu"


def run_harness(binary, *arguments, timeout=900):
    completed = subprocess.run([str(binary), *map(str, arguments)], cwd=ROOT, capture_output=True,
                               text=True, timeout=timeout)
    if completed.returncode != 0:
        raise AssertionError(f"harness {' '.join(map(str, arguments))} failed:\n"
                             f"{completed.stdout}\n{completed.stderr}")
    return completed
