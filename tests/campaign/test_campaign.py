"""Campaigns on Dask. A small Monte Carlo on a LocalCluster of 2 workers gives the
scores of `harness montecarlo` bit for bit; an interrupted campaign resumes without running a
case twice or losing one; a case the FMU refuses is recorded with its error; a malformed campaign
file is named in the error."""

import csv
import math
import os
import pathlib
import subprocess
import sys
import time

import pyarrow.parquet as pq
import pytest

from vse_campaign import campaign as campaign_file

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "harness" / "scenarios" / "seed000_ramp_high_ay.toml"
# Scores that are measurements of this machine, not results of the co-simulation.
TIMING_SUFFIX = ".step_wall_time"


def write_campaign(folder: pathlib.Path, axes: str, name="campaign.toml") -> pathlib.Path:
    path = folder / name
    path.write_text(f'scenario = "{SCENARIO}"\ninstances = ["vehicle", "UKF"]\n{axes}')
    return path


def vse_campaign(*arguments, timeout=120):
    return subprocess.run([sys.executable, "-m", "vse_campaign", *map(str, arguments)], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout)


def results(out: pathlib.Path) -> list[dict]:
    return pq.read_table(out / "results.parquet").to_pylist()


def test_two_worker_local_cluster_gives_harness_montecarlo_scores_bit_for_bit(
        tmp_path, harness_binary, fmu_dir):
    runs = 4
    path = write_campaign(tmp_path, f'[[axis]]\nseeds = ["vehicle.seed"]\nfirst = 1\ncount = {runs}\n')
    campaign = vse_campaign(path, "--out", tmp_path / "out", "--workers", 2, "--chunk", 2,
                            "--harness", harness_binary, "--fmu-dir", fmu_dir,
                            "--dashboard-address", "127.0.0.1:0")
    assert campaign.returncode == 0, campaign.stderr
    assert "Dask dashboard: http://127.0.0.1:" in campaign.stderr
    assert "case/s" in campaign.stderr  # the progress bar's rate
    montecarlo = subprocess.run(
        [str(harness_binary), "montecarlo", str(SCENARIO), "--instances", "vehicle,UKF",
         "--runs", str(runs), "--first-seed", "1", "--threads", "2", "--out", str(tmp_path / "mc"),
         "--fmu-dir", str(fmu_dir)], capture_output=True, text=True, timeout=120)
    assert montecarlo.returncode == 0, montecarlo.stderr
    with open(tmp_path / "mc" / "seed000_ramp_high_ay" / "runs.csv", newline="") as file:
        reference = list(csv.DictReader(file))
    rows = results(tmp_path / "out")
    assert [row["case"] for row in rows] == list(range(runs))
    assert {row["status"] for row in rows} == {"ok"}
    compared = [name for name in reference[0] if name != "seed" and not name.endswith(TIMING_SUFFIX)]
    assert "UKF.sideslip.rmse" in compared and "UKF.vy.nees" in compared
    for row, expected in zip(rows, reference):
        assert row["seed"] == int(expected["seed"])
        for name in compared:
            assert row[name].hex() == float(expected[name]).hex(), (row["case"], name)
    assert row["wall_time"] > 0 and row["worker"]
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert "UKF.vx.rmse" in summary and (tmp_path / "out" / "summary.png").stat().st_size > 0


def chunk_files(out: pathlib.Path) -> list[pathlib.Path]:
    return sorted((out / "chunks").glob("cases-*.parquet"))


def held_back_harness(folder: pathlib.Path, harness_binary: pathlib.Path, immediate=2,
                      delay=5.0) -> pathlib.Path:
    """The harness behind a script that runs the scenario check and the first `immediate` chunks
    at once and lets every later chunk wait `delay` seconds first: the kill then lands after two
    chunks and before the rest however loaded the machine is (a campaign of the real binary
    could finish all its chunks between two polls under load). The waiting chunks still run, so
    the Dask workers are free again for the resumed campaign."""
    tickets = folder / "tickets"
    tickets.mkdir()
    script = folder / "held_back_harness"
    # `harness cases CHUNK.toml ...`: a chunk file with [[case]] tables is a real chunk.
    script.write_text(f"""#!/bin/sh
if grep -q '^\\[\\[case\\]\\]' "$2"; then
    for ticket in $(seq 1 {immediate}); do
        if mkdir "{tickets}/$ticket" 2>/dev/null; then exec "{harness_binary}" "$@"; fi
    done
    sleep {delay}
fi
exec "{harness_binary}" "$@"
""")
    script.chmod(0o755)
    return script


def test_a_killed_campaign_resumes_with_only_the_missing_cases(
        tmp_path, harness_binary, fmu_dir, dask_scheduler):
    total = 12
    path = write_campaign(tmp_path, f'[[axis]]\nseeds = ["vehicle.seed"]\ncount = {total}\n')
    out = tmp_path / "out"
    arguments = [sys.executable, "-m", "vse_campaign", str(path), "--out", str(out), "--chunk", "2",
                 "--scheduler", dask_scheduler,
                 "--harness", str(held_back_harness(tmp_path, harness_binary)),
                 "--fmu-dir", str(fmu_dir), "--no-progress"]
    process = subprocess.Popen(arguments, cwd=ROOT, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while len(chunk_files(out)) < 2 and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    process.kill()
    process.wait()
    before = {file.name: file.stat().st_mtime_ns for file in chunk_files(out)}
    done = sum(pq.read_metadata(out / "chunks" / name).num_rows for name in before)
    assert 0 < done < total, f"the kill came too late or too early ({done} of {total} done)"

    resumed = vse_campaign(path, "--out", out, "--chunk", 2, "--scheduler", dask_scheduler,
                           "--harness", harness_binary, "--fmu-dir", fmu_dir, "--no-progress")
    assert resumed.returncode == 0, resumed.stderr
    assert f"{total} cases, {done} already in" in resumed.stderr
    assert f"ran {total - done} cases" in resumed.stdout
    # The chunks finished before the kill are kept as they were, not run again.
    assert {name: (out / "chunks" / name).stat().st_mtime_ns for name in before} == before
    cases = [row["case"] for row in results(out)]
    assert cases == list(range(total))
    assert [row["seed"] for row in results(out)] == list(range(1, total + 1))


def test_a_case_the_fmu_refuses_is_recorded_with_its_error(
        tmp_path, harness_binary, fmu_dir, dask_scheduler):
    # A sensor period of 1e-300 s gives the ReferenceVehicle an internal step it refuses at
    # fmi2ExitInitializationMode; the other cases of the chunk still run.
    path = write_campaign(tmp_path, '[[axis]]\nparameter = "vehicle.sensor_sample_period"\n'
                                    'values = [0.001, 1e-300]\n'
                                    '[[axis]]\nseeds = ["vehicle.seed"]\ncount = 2\n')
    completed = vse_campaign(path, "--out", tmp_path / "out", "--chunk", 4, "--scheduler",
                             dask_scheduler, "--harness", harness_binary, "--fmu-dir", fmu_dir)
    assert completed.returncode == 0, completed.stderr
    rows = results(tmp_path / "out")
    assert [row["status"] for row in rows] == ["ok", "ok", "error", "error"]
    for row in rows[2:]:
        assert "fmi2ExitInitializationMode" in row["error"] and "1e-300" in row["error"]
        assert row["UKF.vy.rmse"] is None
    assert all(math.isfinite(row["UKF.vy.rmse"]) and row["error"] is None for row in rows[:2])
    assert "Failed cases (2)" in (tmp_path / "out" / "summary.md").read_text()


@pytest.mark.parametrize("text, field", [
    ('scenario = "nowhere.toml"\n[[axis]]\nseeds = ["vehicle.seed"]\ncount = 2\n', "scenario"),
    (f'scenario = "{SCENARIO}"\n[[axis]]\nparameter = "UKF.sample_time"\nrange = [0.01, 0.001]\ncount = 3\n',
     "axis[0].range"),
    (f'scenario = "{SCENARIO}"\n[sample]\nmethod = "sobol"\n[[axis]]\nmanoeuvre = ["x"]\n', "sample.method"),
    (f'scenario = "{SCENARIO}"\n[[axis]]\nseeds = ["vehicle.seed"]\ncount = 2\n'
     f'[[axis]]\nparameter = "noseparator"\nvalues = [1]\n', "axis[1].parameter"),
    (f'scenario = "{SCENARIO}"\n[sample]\nmethod = "random"\nsize = 4\n[[axis]]\nmanoeuvre = ["x"]\n',
     "sample.seed"),
])
def test_a_malformed_campaign_file_is_named_with_its_field(tmp_path, text, field):
    path = tmp_path / "broken.toml"
    path.write_text(text)
    with pytest.raises(campaign_file.CampaignError) as error:
        campaign_file.load(path)
    assert str(path) in str(error.value) and f"`{field}`" in str(error.value)


def test_the_command_names_a_campaign_file_that_is_not_toml(tmp_path, harness_binary):
    path = tmp_path / "not_toml.toml"
    path.write_text("scenario = [unclosed\n")
    completed = vse_campaign(path, "--out", tmp_path / "out", "--harness", harness_binary)
    assert completed.returncode == 2
    assert f"campaign {path}: not valid TOML" in completed.stderr
    assert not (tmp_path / "out").exists()


def test_grid_random_and_latin_hypercube_expansions(tmp_path):
    axes = ('[[axis]]\nparameter = "UKF.process_noise_std_vy"\nrange = [1e-5, 1e-3]\nscale = "log"\n'
            '[[axis]]\nmanoeuvre = ["seed000_ramp_high_ay", "seed000_ramp_moderate_ay"]\n')
    lhs = campaign_file.load(write_campaign(
        tmp_path, '[sample]\nmethod = "latin_hypercube"\nsize = 10\nseed = 3\n' + axes, "lhs.toml"))
    cases = lhs.cases()
    assert cases == lhs.cases() and [c["case"] for c in cases] == list(range(10))
    # One point in each of the 10 equal strata of the (log) range.
    strata = sorted(int(10 * math.log(c["UKF.process_noise_std_vy"] / 1e-5) / math.log(100)) for c in cases)
    assert strata == list(range(10))
    assert [c["manoeuvre"] for c in cases].count("seed000_ramp_high_ay") == 5
    entry = lhs.harness_case(cases[0])
    assert set(entry) == {"id", "set", "manoeuvre"} and list(entry["set"]) == ["UKF.process_noise_std_vy"]

    grid = campaign_file.load(write_campaign(
        tmp_path, '[[axis]]\nseeds = ["vehicle.seed", "UKF.seed"]\nvalues = [5, 9]\n'
                  '[[axis]]\nparameter = "UKF.sample_time"\nrange = [0.001, 0.003]\ncount = 3\n',
        "grid.toml"))
    assert [(c["seed"], c["UKF.sample_time"]) for c in grid.cases()] == [
        (s, t) for s in (5, 9) for t in (0.001, 0.002, 0.003)]
    assert grid.harness_case(grid.cases()[4])["set"] == {
        "vehicle.seed": 9, "UKF.seed": 9, "UKF.sample_time": 0.002}

    random = campaign_file.load(write_campaign(
        tmp_path, '[sample]\nmethod = "random"\nsize = 6\nseed = 1\n' + axes, "random.toml"))
    values = [c["UKF.process_noise_std_vy"] for c in random.cases()]
    assert values == [c["UKF.process_noise_std_vy"] for c in random.cases()]
    assert all(1e-5 <= v <= 1e-3 for v in values) and len(set(values)) == 6
    assert os.path.basename(str(random.path)) == "random.toml"


def test_a_worker_killed_mid_campaign_loses_only_its_chunk_which_runs_again(
        tmp_path, harness_binary, fmu_dir, dask_scheduler):
    from distributed import Client
    total = 16
    path = write_campaign(tmp_path, f'[[axis]]\nseeds = ["vehicle.seed"]\ncount = {total}\n')
    out = tmp_path / "out"
    # The client connects and learns the workers' processes before the campaign starts: under
    # the load of the other tests (the Rust tests and the other xdist worker run beside this
    # one) connecting took long enough that the campaign had ended before the first look.
    with Client(dask_scheduler, timeout=30) as client:
        pids = client.run(os.getpid)
        process = subprocess.Popen(
            [sys.executable, "-m", "vse_campaign", str(path), "--out", str(out), "--chunk", "2",
             "--scheduler", dask_scheduler,
             "--harness", str(held_back_harness(tmp_path, harness_binary, immediate=1, delay=2.0)),
             "--fmu-dir", str(fmu_dir), "--no-progress"],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 60
        while not chunk_files(out) and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        # The victim is a worker with a chunk in hand. The first worker by address may have none
        # at that moment (between two chunks): under the other xdist worker's load that
        # happened, and the test failed without having killed anything in flight. The held-back
        # harness keeps every chunk after the first in hand for 2 s, so under load too the
        # campaign cannot end between the first chunk file and this look.
        busy = {}
        while not busy and process.poll() is None and time.monotonic() < deadline:
            busy = {address: keys for address, keys in client.processing().items() if keys}
        if not busy:
            process.kill()
        assert busy, "no worker had a chunk: the campaign ended before the kill"
        address = sorted(busy)[0]
        victim, in_flight = pids[address], busy[address]  # the chunks given to that worker
        os.kill(victim, 9)
        stdout, stderr = process.communicate(timeout=120)
        client.wait_for_workers(2, timeout=60)  # the nanny starts a new one for the next tests
    assert process.returncode == 0, stderr
    assert "lost chunk" not in stderr and f"{total} of {total} cases in the results" in stdout
    rows = results(out)
    assert [row["case"] for row in rows] == list(range(total))
    assert {row["status"] for row in rows} == {"ok"}
    # Its chunks (keys chunk-<first>-<last>) were run again by another worker process.
    rerun = {case for key in in_flight for case in range(int(key.split("-")[1]), int(key.split("-")[2]) + 1)}
    assert all(not row["worker"].endswith(f":{victim}") for row in rows if row["case"] in rerun)
