"""Runs a campaign's missing cases on Dask: a LocalCluster on this machine, or the scheduler at
`--scheduler`. Each chunk is one task (vse_campaign.task.run_chunk: the harness binary on those
cases); a finished chunk is written to Parquet at once. A worker that dies takes only its running
chunk with it, which the scheduler gives to another worker (Dask reschedules the tasks of a lost
worker, up to `distributed.scheduler.allowed-failures` times)."""

from __future__ import annotations

import dataclasses
import json
import os
import pathlib
import subprocess
import sys
import time

import cloudpickle
from distributed import Client, LocalCluster, as_completed
from tqdm import tqdm

from . import task
from .campaign import ROOT, Campaign
from .results import ResultStore


@dataclasses.dataclass
class Options:
    out: pathlib.Path
    harness: pathlib.Path
    fmu_dir: pathlib.Path
    scheduler: str | None = None
    chunk: int = 25
    workers: int | None = None
    dashboard_address: str = "127.0.0.1:8787"
    # Per chunk; a case of the seed-000 ramp takes well under a second.
    chunk_timeout: float = 3600.0
    progress: bool = True


@dataclasses.dataclass
class Outcome:
    cases: int
    already_done: int
    ran: int
    failed_cases: int
    lost_chunks: list[str]
    wall_time: float
    dashboard: str | None


def find_harness() -> pathlib.Path:
    """The harness binary of the workspace's release build, found as tests/conftest.py does it:
    cargo's artefact messages (CARGO_TARGET_DIR and cargo configs honoured)."""
    command = ["cargo", "build", "--release", "-p", "harness", "--bin", "harness",
               "--message-format=json-render-diagnostics"]
    completed = subprocess.run(command, cwd=ROOT, stdout=subprocess.PIPE, text=True)
    if completed.returncode != 0:
        raise RuntimeError(f"`{' '.join(command)}` failed in {ROOT} (compiler output above); "
                           f"or give --harness PATH")
    for line in completed.stdout.splitlines():
        message = json.loads(line)
        if message.get("reason") == "compiler-artifact" and message.get("executable") \
                and message["target"]["name"] == "harness":
            return pathlib.Path(message["executable"])
    raise RuntimeError("cargo built no harness executable; give --harness PATH")


def check_scenario(campaign: Campaign, options: Options) -> None:
    """Let the harness read the scenario (and the instance list) before any worker starts, so a
    broken scenario is one error, not one per case."""
    result = task.run_chunk(str(options.harness), str(options.fmu_dir), str(campaign.scenario),
                            campaign.instances, [], timeout=120)
    assert result == []


def chunks_of(cases: list[dict], size: int) -> list[list[dict]]:
    return [cases[i:i + size] for i in range(0, len(cases), size)]


def start_client(options: Options) -> tuple[Client, LocalCluster | None]:
    if options.scheduler:
        return Client(options.scheduler), None
    cluster = LocalCluster(n_workers=options.workers or os.cpu_count(), threads_per_worker=1,
                           processes=True, host="127.0.0.1",
                           dashboard_address=options.dashboard_address)
    return Client(cluster), cluster


def dashboard_of(client: Client) -> str | None:
    """The dashboard's address, when the scheduler serves one (it needs bokeh)."""
    try:
        import bokeh  # noqa: F401  (the dashboard exists only with it)
    except ImportError:
        return None
    return client.dashboard_link


def run(campaign: Campaign, options: Options) -> Outcome:
    started = time.perf_counter()
    store = ResultStore(options.out, campaign)
    done = store.open()
    cases = campaign.cases()
    missing = [campaign.harness_case(case) for case in cases if case["case"] not in done]
    print(f"campaign {campaign.name}: {len(cases)} cases, {len(done)} already in {options.out}, "
          f"{len(missing)} to run", file=sys.stderr)
    failed, lost, dashboard = 0, [], None
    if missing:
        check_scenario(campaign, options)
        failed, lost, dashboard = _run_missing(campaign, options, store, missing, len(done), len(cases))
    return Outcome(cases=len(cases), already_done=len(done), ran=len(missing), failed_cases=failed,
                   lost_chunks=lost, wall_time=time.perf_counter() - started, dashboard=dashboard)


def _run_missing(campaign, options, store, missing, done, total):
    # Workers get the task module by value: a `dask worker` elsewhere needs only the harness
    # binary and the FMUs, not this package.
    cloudpickle.register_pickle_by_value(task)
    client, cluster = start_client(options)
    failed, lost = 0, []
    try:
        dashboard = dashboard_of(client)
        if dashboard:
            print(f"Dask dashboard: {dashboard}", file=sys.stderr)
        futures = {
            client.submit(task.run_chunk, str(options.harness), str(options.fmu_dir),
                          str(campaign.scenario), campaign.instances, chunk, options.chunk_timeout,
                          key=f"chunk-{chunk[0]['id']}-{chunk[-1]['id']}", pure=False): chunk
            for chunk in chunks_of(missing, options.chunk)}
        with tqdm(total=total, initial=done, unit="case", disable=not options.progress,
                  file=sys.stderr, dynamic_ncols=True, smoothing=0.1) as bar:
            for future in as_completed(futures):
                try:
                    rows = future.result()
                except Exception as error:  # noqa: BLE001  (a chunk lost for good; the rest goes on)
                    lost.append(f"{future.key}: {type(error).__name__}: {error}")
                    continue
                store.write_chunk(rows)
                failed += sum(row["status"] != "ok" for row in rows)
                bar.update(len(rows))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
        cloudpickle.unregister_pickle_by_value(task)
    return failed, lost, dashboard
