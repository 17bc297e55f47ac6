"""`python -m vse_campaign CAMPAIGN.toml --out DIR [--scheduler ADDRESS] [--chunk K]`."""

from __future__ import annotations

import argparse
import os
import pathlib
import sys

from . import campaign as campaign_file
from .task import ChunkError


def arguments(argv):
    parser = argparse.ArgumentParser(
        prog="python -m vse_campaign",
        description="Run a campaign of co-simulations (harness/campaign/README.md) on Dask: a "
                    "LocalCluster on this machine, or the scheduler at --scheduler. Running the "
                    "same command again resumes: only the cases missing from --out run.")
    parser.add_argument("campaign", type=pathlib.Path, help="campaign file (TOML)")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="results folder")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://host:8786); "
                                            "default: a LocalCluster on this machine")
    parser.add_argument("--chunk", type=int, default=25, help="cases per task (default 25)")
    parser.add_argument("--workers", type=int, help="LocalCluster worker processes (default: cores)")
    parser.add_argument("--harness", type=pathlib.Path,
                        help="the harness binary (default: cargo's release build of this workspace)")
    parser.add_argument("--fmu-dir", type=pathlib.Path,
                        help="folder of the packaged FMUs, replaces {fmu_dir} (default: <target>/fmu)")
    parser.add_argument("--dashboard-address", default="127.0.0.1:8787",
                        help="LocalCluster dashboard address (default 127.0.0.1:8787; a taken port "
                             "gives a random one)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    options = parser.parse_args(argv)
    if options.chunk < 1:
        parser.error(f"--chunk {options.chunk}: expected at least 1 case per task")
    if options.workers is not None and options.workers < 1:
        parser.error(f"--workers {options.workers}: expected at least 1")
    return options


def default_fmu_dir() -> pathlib.Path:
    target = os.environ.get("CARGO_TARGET_DIR")
    root = campaign_file.ROOT
    return (root / target if target else root / "target").resolve() / "fmu"


def main(argv=None) -> int:
    args = arguments(argv)
    try:
        campaign = campaign_file.load(args.campaign)
        # Dask, Arrow and matplotlib load only once the campaign file is known to be good.
        from . import runner, summary
        from .results import ResultsError, ResultStore
        harness = (args.harness or runner.find_harness()).resolve()
        if not harness.is_file():
            raise FileNotFoundError(f"--harness {harness}: no such file")
        options = runner.Options(out=args.out.resolve(), harness=harness,
                                 fmu_dir=(args.fmu_dir or default_fmu_dir()).resolve(),
                                 scheduler=args.scheduler, chunk=args.chunk, workers=args.workers,
                                 dashboard_address=args.dashboard_address,
                                 progress=not args.no_progress)
        outcome = runner.run(campaign, options)
        store = ResultStore(options.out, campaign)
        results = store.write_results()
        table = store.table()
        markdown, png = summary.write(table, campaign, outcome, options.out)
    except (campaign_file.CampaignError, ChunkError, FileNotFoundError, RuntimeError,
            ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    rate = outcome.ran / outcome.wall_time if outcome.wall_time > 0 else float("nan")
    print(f"ran {outcome.ran} cases in {outcome.wall_time:.1f} s ({rate:.1f} cases/s), "
          f"{outcome.failed_cases} failed; {table.num_rows} of {outcome.cases} cases in the results")
    print(f"results: {results}\nsummary: {markdown}" + (f"\nplot:    {png}" if png else ""))
    for chunk in outcome.lost_chunks:
        print(f"lost chunk (run the same command again to retry it): {chunk}", file=sys.stderr)
    return 1 if outcome.lost_chunks else 0


if __name__ == "__main__":
    sys.exit(main())
