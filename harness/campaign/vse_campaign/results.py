"""The results folder: one Parquet file per finished chunk, so an interrupted campaign keeps what
it finished and the same command runs only the missing cases.

    OUT/campaign.json          what the folder belongs to (campaign file, fingerprint of its cases)
    OUT/chunks/cases-<first>-<last>.parquet   one row per case, written whole (temp name, rename)
    OUT/results.parquet        every case, sorted by case id (written at the end)
"""

from __future__ import annotations

import json
import os
import pathlib

import pyarrow as pa
import pyarrow.parquet as pq

from .campaign import Campaign

FIRST_COLUMNS = ("case", "status")
LAST_COLUMNS = ("wall_time", "error", "worker", "chunk_wall_time")


class ResultsError(RuntimeError):
    """A results folder that cannot be resumed (another campaign's, or damaged)."""


def _write_atomically(table: pa.Table, path: pathlib.Path) -> None:
    partial = path.with_name(path.name + ".partial")
    pq.write_table(table, partial)
    os.replace(partial, path)


class ResultStore:
    def __init__(self, out: pathlib.Path, campaign: Campaign):
        self.out = out
        self.chunks = out / "chunks"
        self.campaign = campaign

    def open(self) -> set[int]:
        """Prepare the folder; return the ids of the cases already done."""
        self.chunks.mkdir(parents=True, exist_ok=True)
        identity = self.out / "campaign.json"
        fingerprint = self.campaign.fingerprint()
        if identity.exists():
            stored = json.loads(identity.read_text())
            if stored.get("fingerprint") != fingerprint:
                raise ResultsError(
                    f"{self.out} holds the results of another campaign ({stored.get('campaign')}, other "
                    f"cases); give another --out or remove the folder")
        else:
            identity.write_text(json.dumps({"campaign": str(self.campaign.path),
                                            "fingerprint": fingerprint}, indent=1) + "\n")
        for stale in self.chunks.glob("*.partial"):  # a kill during a write
            stale.unlink()
        return self.done_cases()

    def chunk_files(self) -> list[pathlib.Path]:
        return sorted(self.chunks.glob("cases-*.parquet"))

    def done_cases(self) -> set[int]:
        done: set[int] = set()
        for file in self.chunk_files():
            ids = pq.read_table(file, columns=["case"]).column("case").to_pylist()
            twice = done.intersection(ids)
            if twice:
                raise ResultsError(f"{file}: cases {sorted(twice)[:5]} are also in another chunk file")
            done.update(ids)
        return done

    def write_chunk(self, rows: list[dict]) -> pathlib.Path:
        """Write one finished chunk: the case's axis values joined to its results."""
        cases = self.campaign.cases()
        axis_names = [axis.name for axis in self.campaign.axes]
        records = []
        for row in rows:
            case = cases[row["case"]]
            scores = {k: v for k, v in row.items() if k not in FIRST_COLUMNS + LAST_COLUMNS}
            records.append({"case": row["case"], "status": row["status"],
                            **{name: case[name] for name in axis_names}, **scores,
                            **{k: row.get(k) for k in LAST_COLUMNS}})
        ids = [row["case"] for row in rows]
        path = self.chunks / f"cases-{min(ids):07d}-{max(ids):07d}.parquet"
        _write_atomically(pa.Table.from_pylist(records), path)
        return path

    def table(self) -> pa.Table:
        tables = [pq.read_table(file) for file in self.chunk_files()]
        if not tables:
            return pa.table({"case": pa.array([], pa.int64())})
        merged = pa.concat_tables(tables, promote_options="permissive")
        return merged.sort_by("case")

    def write_results(self) -> pathlib.Path:
        path = self.out / "results.parquet"
        _write_atomically(self.table(), path)
        return path
