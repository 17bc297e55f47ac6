"""The Dask task: one chunk of cases run by the Rust harness (`harness cases`).

Standard library only, and shipped to the workers by value (runner.py registers it with
cloudpickle), so a `dask worker` needs no copy of this package: only the harness binary and the
FMUs at the paths given."""

from __future__ import annotations

import csv
import io
import json
import os
import socket
import subprocess
import tempfile
import time


class ChunkError(RuntimeError):
    """The harness could not run the chunk at all (not one case's failure)."""


def toml_value(value) -> str:
    """A TOML value: JSON's string escapes are TOML's, Python's float repr reads back exactly."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML form for {value!r} ({type(value).__name__})")


def chunk_toml(scenario: str, instances, cases) -> str:
    """The chunk file of `harness cases` (format in harness/studies/src/cases.rs)."""
    lines = [f"scenario = {toml_value(scenario)}", f"instances = {toml_value(list(instances))}"]
    for case in cases:
        lines.append("[[case]]")
        lines.extend(f"{key} = {toml_value(value)}" for key, value in case.items())
    return "\n".join(lines) + "\n"


def parse_rows(text: str) -> dict[int, dict]:
    """`case,field,value` rows -> {case: {field: value}}; scores and wall time as floats."""
    results: dict[int, dict] = {}
    for record in csv.reader(io.StringIO(text)):
        if len(record) != 3:  # a last line cut off by a killed process
            continue
        case, field, value = record
        row = results.setdefault(int(case), {})
        row[field] = value if field in ("status", "error") else float(value)
    return results


def run_chunk(harness: str, fmu_dir: str, scenario: str, instances, cases, timeout: float) -> list[dict]:
    """Run `cases` (chunk file entries) and return one result dict per case, in their order.
    A case the harness did not finish (the process died or timed out) is an error row."""
    with tempfile.TemporaryDirectory(prefix="vse-chunk-") as folder:
        path = os.path.join(folder, "chunk.toml")
        with open(path, "w", encoding="utf-8") as file:
            file.write(chunk_toml(scenario, instances, cases))
        command = [harness, "cases", path, "--fmu-dir", fmu_dir, "--threads", "1"]
        started = time.perf_counter()
        try:
            completed = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
            stdout, stderr, code = completed.stdout, completed.stderr, completed.returncode
        except subprocess.TimeoutExpired as expired:
            stdout = expired.stdout.decode() if isinstance(expired.stdout, bytes) else (expired.stdout or "")
            stderr, code = f"timed out after {timeout} s", None
    finished = parse_rows(stdout)
    if code not in (0, None) and not finished:
        raise ChunkError(f"`{' '.join(command)}` failed ({code}): {stderr.strip()}")
    elapsed = time.perf_counter() - started
    worker = f"{socket.gethostname()}:{os.getpid()}"
    rows = []
    for case in cases:
        row = finished.get(case["id"]) or {
            "status": "error", "wall_time": float("nan"),
            "error": f"the harness ended before this case finished (exit {code}): {stderr.strip()[-500:]}"}
        rows.append({"case": case["id"], "worker": worker, "chunk_wall_time": elapsed, **row})
    return rows
