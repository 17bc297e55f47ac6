"""The campaign's summary: per-axis statistics of the main score, statistics of every score, the
worst and the failed cases (Markdown), and a plot of the main score over the main axes."""

from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyarrow as pa  # noqa: E402
import pyarrow.compute as pc  # noqa: E402

from .campaign import Campaign  # noqa: E402
from .results import FIRST_COLUMNS, LAST_COLUMNS  # noqa: E402

# An axis with more distinct values than this is summarised in quantile bins.
MOST_GROUPS = 12
BINS = 5
WORST = 10


def score_columns(table: pa.Table, campaign: Campaign) -> list[str]:
    axes = {axis.name for axis in campaign.axes}
    return [name for name in table.column_names
            if name not in axes and name not in FIRST_COLUMNS + LAST_COLUMNS]


def main_score(table: pa.Table, campaign: Campaign) -> str | None:
    scores = score_columns(table, campaign)
    if campaign.main_score:
        if campaign.main_score not in scores:
            raise ValueError(f"campaign {campaign.path}: field `summary.score`: {campaign.main_score!r} "
                             f"is not a score of this scenario; it has {', '.join(scores[:8])} ...")
        return campaign.main_score
    return next((name for name in scores if name.endswith(".rmse")), scores[0] if scores else None)


def main_axes(campaign: Campaign) -> list[str]:
    if campaign.main_axes:
        return list(campaign.main_axes)
    varied = [axis.name for axis in campaign.axes if axis.kind != "seeds"]
    return (varied or [campaign.axes[0].name])[:2]


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _groups(values: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """(label, mask) per distinct value, or per quantile bin of a many-valued numeric axis."""
    distinct = list(dict.fromkeys(values.tolist()))
    if len(distinct) <= MOST_GROUPS or values.dtype == object:
        return [(_fmt(v), values == v) for v in sorted(distinct, key=str if values.dtype == object else None)]
    edges = np.unique(np.quantile(values.astype(float), np.linspace(0, 1, BINS + 1)))
    groups = []
    for index, (low, high) in enumerate(zip(edges[:-1], edges[1:])):
        upper = values <= high if index == len(edges) - 2 else values < high
        groups.append((f"[{_fmt(float(low))}, {_fmt(float(high))}{']' if index == len(edges) - 2 else ')'}",
                       (values >= low) & upper))
    return groups


def _stats_row(label: str, scores: np.ndarray) -> str:
    finite = scores[np.isfinite(scores)]
    if not finite.size:
        return f"| {label} | {scores.size} | - | - | - | - |"
    return (f"| {label} | {scores.size} | {finite.mean():.4g} | {finite.std(ddof=1) if finite.size > 1 else 0:.2g} "
            f"| {finite.min():.4g} | {finite.max():.4g} |")


def markdown(table: pa.Table, campaign: Campaign, outcome) -> str:
    ok = table.filter(pc.equal(table["status"], "ok")) if table.num_rows else table
    failed = table.num_rows - ok.num_rows
    score = main_score(table, campaign)
    lines = [f"# Campaign {campaign.name}", "",
             f"Scenario `{campaign.scenario}`" + (f", instances {', '.join(campaign.instances)}"
                                                 if campaign.instances else "")
             + f"; {campaign.method} over {', '.join(a.name for a in campaign.axes)}.", "",
             f"{table.num_rows} of {outcome.cases} cases have results ({ok.num_rows} ok, {failed} failed); "
             f"this invocation ran {outcome.ran} cases in {outcome.wall_time:.1f} s.", ""]
    if score is not None and ok.num_rows:
        values = ok[score].to_numpy(zero_copy_only=False).astype(float)
        lines += [f"## Main score `{score}` per axis", ""]
        for axis in campaign.axes:
            lines += [f"### {axis.name}", "", "| value | cases | mean | std | min | max |",
                      "|---|---|---|---|---|---|"]
            column = ok[axis.name].to_numpy(zero_copy_only=False)
            lines += [_stats_row(label, values[mask]) for label, mask in _groups(column)] + [""]
        lines += _worst(ok, campaign, score, values)
    if ok.num_rows:
        lines += ["## Every score over the ok cases", "", "| score | cases | mean | std | min | max |",
                  "|---|---|---|---|---|---|"]
        lines += [_stats_row(f"`{name}`", ok[name].to_numpy(zero_copy_only=False).astype(float))
                  for name in score_columns(table, campaign)] + [""]
    lines += _failures(table)
    return "\n".join(lines) + "\n"


def _worst(ok: pa.Table, campaign: Campaign, score: str, values: np.ndarray) -> list[str]:
    order = np.argsort(-np.where(np.isfinite(values), values, np.inf), kind="stable")[:WORST]
    names = [axis.name for axis in campaign.axes]
    lines = [f"## The {min(WORST, len(order))} worst cases by `{score}`", "",
             "| case | " + " | ".join(names) + f" | {score} |", "|---" * (len(names) + 2) + "|"]
    for index in order:
        row = ok.slice(int(index), 1).to_pylist()[0]
        lines.append(f"| {row['case']} | " + " | ".join(_fmt(row[n]) for n in names) + f" | {_fmt(row[score])} |")
    return lines + [""]


def _failures(table: pa.Table) -> list[str]:
    if not table.num_rows:
        return []
    bad = table.filter(pc.not_equal(table["status"], "ok"))
    if not bad.num_rows:
        return []
    lines = [f"## Failed cases ({bad.num_rows})", "", "| case | error |", "|---|---|"]
    for row in bad.slice(0, 20).to_pylist():
        message = (row.get("error") or "").replace("|", "\\|").replace("\n", " ")
        lines.append(f"| {row['case']} | {message[:300]} |")
    return lines + [""]


def plot(table: pa.Table, campaign: Campaign, path: pathlib.Path) -> pathlib.Path | None:
    """The main score over the main axes: a histogram for seeds alone, the score against one
    axis, or two axes coloured by the score."""
    ok = table.filter(pc.equal(table["status"], "ok")) if table.num_rows else table
    score = main_score(table, campaign)
    if score is None or not ok.num_rows:
        return None
    values = ok[score].to_numpy(zero_copy_only=False).astype(float)
    axes = main_axes(campaign)
    kinds = {axis.name: axis.kind for axis in campaign.axes}
    logarithmic = {axis.name for axis in campaign.axes if axis.log}
    figure, ax = plt.subplots(figsize=(7, 4.5))
    if len(axes) == 1 and kinds[axes[0]] == "seeds":
        ax.hist(values[np.isfinite(values)], bins=min(50, max(5, ok.num_rows // 10)))
        ax.set_xlabel(score)
        ax.set_ylabel("cases")
    elif len(axes) == 1:
        x, ticks = _positions(ok[axes[0]].to_numpy(zero_copy_only=False))
        ax.plot(x, values, ".", alpha=0.6)
        ax.set_xlabel(axes[0])
        ax.set_ylabel(score)
        if ticks:
            ax.set_xticks(range(len(ticks)), ticks, rotation=20, fontsize=8)
        if axes[0] in logarithmic:
            ax.set_xscale("log")
    else:
        x, xticks = _positions(ok[axes[0]].to_numpy(zero_copy_only=False))
        y, yticks = _positions(ok[axes[1]].to_numpy(zero_copy_only=False))
        points = ax.scatter(x, y, c=values, cmap="viridis", s=25)
        figure.colorbar(points, ax=ax, label=score)
        ax.set_xlabel(axes[0])
        ax.set_ylabel(axes[1])
        if xticks:
            ax.set_xticks(range(len(xticks)), xticks, rotation=20, fontsize=8)
        if yticks:
            ax.set_yticks(range(len(yticks)), yticks, fontsize=8)
        if axes[0] in logarithmic:
            ax.set_xscale("log")
        if axes[1] in logarithmic:
            ax.set_yscale("log")
    ax.set_title(f"{campaign.name}: {score} ({ok.num_rows} cases)")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def _positions(values: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Numbers as they are; text (manoeuvres, parameter sets) as category positions."""
    if values.dtype != object:
        return values.astype(float), []
    labels = sorted(set(values.tolist()))
    return np.array([labels.index(v) for v in values]), [pathlib.Path(v).stem for v in labels]


def write(table: pa.Table, campaign: Campaign, outcome, out: pathlib.Path) -> tuple[pathlib.Path, pathlib.Path | None]:
    summary = out / "summary.md"
    partial = out / "summary.md.partial"
    partial.write_text(markdown(table, campaign, outcome), encoding="utf-8")
    partial.replace(summary)
    return summary, plot(table, campaign, out / "summary.png")
