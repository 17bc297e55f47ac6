"""The campaign file (TOML) and its expansion into cases.

A campaign names a scenario of the Rust master and the axes to vary; harness/campaign/README.md
describes every field. Each case is a dict: its id (the index in the expansion, so the same file
always gives the same ids), one value per axis, and what the harness must change for it
(parameters to set, a library manoeuvre, parameter-value files)."""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import itertools
import json
import math
import pathlib
import tomllib
from typing import Any

import numpy as np
from scipy.stats import qmc

# The workspace this package sits in (harness/campaign/vse_campaign).
ROOT = pathlib.Path(__file__).resolve().parents[3]
METHODS = ("grid", "random", "latin_hypercube")
AXIS_KINDS = ("seeds", "parameter", "parameter_set", "manoeuvre")
TOP_KEYS = {"name", "description", "scenario", "instances", "sample", "axis", "summary"}


class CampaignError(ValueError):
    """A campaign file that cannot be used; the message names the file and the field."""


@dataclasses.dataclass(frozen=True)
class Axis:
    name: str
    kind: str
    # The instance.variable refs a value is set to (seeds, parameter), the instance of a
    # parameter set; empty for a manoeuvre.
    targets: tuple[str, ...]
    # Discrete values, or None for a continuous range.
    values: tuple[Any, ...] | None
    low: float = 0.0
    high: float = 0.0
    log: bool = False

    def pick(self, unit: float) -> Any:
        """The value at `unit` in [0, 1): a value index for discrete axes, else a point of the range."""
        if self.values is not None:
            return self.values[min(int(unit * len(self.values)), len(self.values) - 1)]
        if self.log:
            return float(math.exp(math.log(self.low) + unit * (math.log(self.high) - math.log(self.low))))
        return float(self.low + unit * (self.high - self.low))


@dataclasses.dataclass(frozen=True)
class Campaign:
    path: pathlib.Path
    name: str
    scenario: pathlib.Path
    instances: tuple[str, ...]
    method: str
    size: int | None
    seed: int | None
    axes: tuple[Axis, ...]
    main_score: str | None
    main_axes: tuple[str, ...]

    def cases(self) -> list[dict]:
        """Every case: {"case": id, <axis name>: value, ...} (expanded once; do not modify)."""
        return self._expanded

    @functools.cached_property
    def _expanded(self) -> list[dict]:
        if self.method == "grid":
            rows = itertools.product(*(axis.values for axis in self.axes))
        else:
            rows = (tuple(axis.pick(u) for axis, u in zip(self.axes, point))
                    for point in self._unit_points())
        return [{"case": index, **{axis.name: value for axis, value in zip(self.axes, row)}}
                for index, row in enumerate(rows)]

    def _unit_points(self) -> np.ndarray:
        dimensions = len(self.axes)
        if self.method == "random":
            return np.random.default_rng(self.seed).random((self.size, dimensions))
        # Latin hypercube (McKay, Beckman & Conover 1979): each axis cut into `size` equal
        # strata, one point in each.
        return qmc.LatinHypercube(d=dimensions, rng=np.random.default_rng(self.seed)).random(self.size)

    def harness_case(self, case: dict) -> dict:
        """What the harness changes for `case` (a chunk file's [[case]] entry)."""
        entry: dict = {"id": case["case"], "set": {}}
        for axis in self.axes:
            value = case[axis.name]
            if axis.kind in ("seeds", "parameter"):
                entry["set"].update({target: value for target in axis.targets})
            elif axis.kind == "parameter_set":
                path = (self.path.parent / value).resolve()
                entry.setdefault("parameter_files", {})[axis.targets[0]] = [str(path)]
            else:
                entry["manoeuvre"] = value
        return entry

    def fingerprint(self) -> str:
        """Identifies the expanded cases and what runs them: a results folder belongs to one."""
        identity = {"scenario": str(self.scenario), "instances": self.instances,
                    "cases": [self.harness_case(case) for case in self.cases()]}
        return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def load(path: str | pathlib.Path) -> Campaign:
    """Read and check a campaign file; every error names the file and the field."""
    path = pathlib.Path(path).resolve()
    try:
        with open(path, "rb") as file:
            document = tomllib.load(file)
    except OSError as error:
        raise CampaignError(f"campaign {path}: cannot be read: {error.strerror}") from None
    except tomllib.TOMLDecodeError as error:
        raise CampaignError(f"campaign {path}: not valid TOML: {error}") from None
    return _parse(path, document)


def _fail(path, field, message):
    raise CampaignError(f"campaign {path}: field `{field}`: {message}")


def _parse(path: pathlib.Path, document: dict) -> Campaign:
    unknown = sorted(set(document) - TOP_KEYS)
    if unknown:
        _fail(path, unknown[0], f"unknown field; expected one of {', '.join(sorted(TOP_KEYS))}")
    scenario = document.get("scenario")
    if not isinstance(scenario, str):
        _fail(path, "scenario", "expected the path of a scenario file (relative to the campaign file)")
    scenario_path = (path.parent / scenario).resolve()
    if not scenario_path.is_file():
        _fail(path, "scenario", f"{scenario_path} does not exist")
    instances = document.get("instances", [])
    if not (isinstance(instances, list) and all(isinstance(i, str) for i in instances)):
        _fail(path, "instances", "expected a list of [[fmu]] instance names")
    method, size, seed = _sample(path, document.get("sample", {}))
    raw_axes = document.get("axis")
    if not isinstance(raw_axes, list) or not raw_axes:
        _fail(path, "axis", "expected at least one [[axis]] table")
    axes = tuple(_axis(path, index, raw, method) for index, raw in enumerate(raw_axes))
    names = [axis.name for axis in axes]
    for name in names:
        if names.count(name) > 1 or name in ("case", "status", "error", "wall_time", "worker"):
            _fail(path, "axis", f"axis name {name!r} is used twice or is a result column; give one a `name`")
    main_score, main_axes = _summary(path, document.get("summary", {}), names)
    return Campaign(path=path, name=str(document.get("name", path.stem)), scenario=scenario_path,
                    instances=tuple(instances), method=method, size=size, seed=seed, axes=axes,
                    main_score=main_score, main_axes=main_axes)


def _sample(path, sample) -> tuple[str, int | None, int | None]:
    if not isinstance(sample, dict):
        _fail(path, "sample", "expected a table")
    unknown = sorted(set(sample) - {"method", "size", "seed"})
    if unknown:
        _fail(path, f"sample.{unknown[0]}", "unknown field; expected method, size, seed")
    method = sample.get("method", "grid")
    if method not in METHODS:
        _fail(path, "sample.method", f"{method!r}; expected one of {', '.join(METHODS)}")
    if method == "grid":
        if "size" in sample or "seed" in sample:
            _fail(path, "sample", "a grid takes every combination: size and seed are for random and latin_hypercube")
        return method, None, None
    size, seed = sample.get("size"), sample.get("seed")
    if not (isinstance(size, int) and size >= 1):
        _fail(path, "sample.size", f"expected the number of cases (an integer >= 1) for {method}")
    if not (isinstance(seed, int) and seed >= 0):
        _fail(path, "sample.seed", f"expected an integer >= 0 (the sample's random seed) for {method}")
    return method, size, seed


def _axis(path, index: int, raw: dict, method: str) -> Axis:
    at = f"axis[{index}]"
    if not isinstance(raw, dict):
        _fail(path, at, "expected a table")
    kinds = [kind for kind in AXIS_KINDS if kind in raw]
    if len(kinds) != 1:
        _fail(path, at, f"expected exactly one of {', '.join(AXIS_KINDS)}")
    kind = kinds[0]
    parse = {"seeds": _seeds_axis, "parameter": _parameter_axis,
             "parameter_set": _parameter_set_axis, "manoeuvre": _manoeuvre_axis}[kind]
    axis = parse(path, at, raw)
    if axis.values is None and method == "grid":
        _fail(path, f"{at}.range", "a grid needs discrete points: give `count` with the range")
    if axis.values is not None and not axis.values:
        _fail(path, at, "no values")
    name = raw.get("name", axis.name)
    if not isinstance(name, str) or not name:
        _fail(path, f"{at}.name", "expected a non-empty string")
    return dataclasses.replace(axis, name=name)


def _allowed(path, at, raw, keys):
    unknown = sorted(set(raw) - set(keys) - {"name"})
    if unknown:
        _fail(path, f"{at}.{unknown[0]}", f"unknown field; this axis takes {', '.join(sorted(keys))}, name")


def _reference(path, field, text) -> str:
    if not (isinstance(text, str) and "." in text.strip(".") and not text.startswith("*")):
        _fail(path, field, f"{text!r}; expected instance.variable")
    return text


def _seeds_axis(path, at, raw) -> Axis:
    _allowed(path, at, raw, {"seeds", "first", "count", "values"})
    targets = raw["seeds"]
    if not (isinstance(targets, list) and targets):
        _fail(path, f"{at}.seeds", "expected a list of Integer parameters (instance.variable)")
    targets = tuple(_reference(path, f"{at}.seeds", t) for t in targets)
    if "values" in raw:
        values = raw["values"]
        if not (isinstance(values, list) and all(_is_int(v) for v in values)):
            _fail(path, f"{at}.values", "expected a list of integer seeds")
        return Axis("seed", "seeds", targets, tuple(values))
    first, count = raw.get("first", 1), raw.get("count")
    if not (_is_int(first) and _is_int(count) and count >= 1):
        _fail(path, at, "expected `first` (an integer, default 1) and `count` (>= 1), or `values`")
    if first + count - 1 > 2**31 - 1 or first < -(2**31):
        _fail(path, at, "the seeds leave the 32-bit fmi2Integer range")
    return Axis("seed", "seeds", targets, tuple(range(first, first + count)))


def _parameter_axis(path, at, raw) -> Axis:
    _allowed(path, at, raw, {"parameter", "values", "range", "count", "scale"})
    target = _reference(path, f"{at}.parameter", raw["parameter"])
    if ("values" in raw) == ("range" in raw):
        _fail(path, at, "expected either `values` or `range`")
    if "values" in raw:
        values = raw["values"]
        if not (isinstance(values, list) and values and _one_type(values)):
            _fail(path, f"{at}.values", "expected a non-empty list of numbers, booleans or strings")
        if all(_is_number(v) for v in values) and not all(_is_int(v) for v in values):
            values = [float(v) for v in values]
        return Axis(target, "parameter", (target,), tuple(values))
    bounds, scale = raw["range"], raw.get("scale", "linear")
    if not (isinstance(bounds, list) and len(bounds) == 2 and all(_is_number(b) for b in bounds)
            and bounds[0] < bounds[1]):
        _fail(path, f"{at}.range", "expected [low, high] with low < high")
    if scale not in ("linear", "log") or (scale == "log" and bounds[0] <= 0):
        _fail(path, f"{at}.scale", "expected \"linear\" or \"log\" (log needs low > 0)")
    low, high = float(bounds[0]), float(bounds[1])
    count = raw.get("count")
    if count is None:
        return Axis(target, "parameter", (target,), None, low, high, scale == "log")
    if not (_is_int(count) and count >= 2):
        _fail(path, f"{at}.count", "expected an integer >= 2 (points from low to high inclusive)")
    points = np.geomspace(low, high, count) if scale == "log" else np.linspace(low, high, count)
    return Axis(target, "parameter", (target,), tuple(float(p) for p in points))


def _parameter_set_axis(path, at, raw) -> Axis:
    _allowed(path, at, raw, {"parameter_set", "files"})
    instance, files = raw["parameter_set"], raw.get("files")
    if not isinstance(instance, str) or "." in instance:
        _fail(path, f"{at}.parameter_set", "expected the [[fmu]] instance name the files apply to")
    if not (isinstance(files, list) and files and all(isinstance(f, str) for f in files)):
        _fail(path, f"{at}.files", "expected a list of .ssv files (relative to the campaign file)")
    for file in files:
        if not (path.parent / file).is_file():
            _fail(path, f"{at}.files", f"{(path.parent / file).resolve()} does not exist")
    return Axis(f"{instance}.parameter_set", "parameter_set", (instance,), tuple(files))


def _manoeuvre_axis(path, at, raw) -> Axis:
    _allowed(path, at, raw, {"manoeuvre"})
    names = raw["manoeuvre"]
    if not (isinstance(names, list) and names and all(isinstance(n, str) for n in names)):
        _fail(path, f"{at}.manoeuvre", "expected a list of library manoeuvre names (`harness manoeuvres` lists them)")
    return Axis("manoeuvre", "manoeuvre", (), tuple(names))


def _summary(path, summary, names) -> tuple[str | None, tuple[str, ...]]:
    if not isinstance(summary, dict):
        _fail(path, "summary", "expected a table")
    unknown = sorted(set(summary) - {"score", "axes"})
    if unknown:
        _fail(path, f"summary.{unknown[0]}", "unknown field; expected score, axes")
    score = summary.get("score")
    if score is not None and not isinstance(score, str):
        _fail(path, "summary.score", "expected a score column, e.g. \"UKF.vy.rmse\"")
    axes = summary.get("axes", [])
    if not (isinstance(axes, list) and len(axes) <= 2 and all(a in names for a in axes)):
        _fail(path, "summary.axes", f"expected up to two axis names out of {names}")
    return score, tuple(axes)


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _one_type(values) -> bool:
    if all(_is_number(v) for v in values):
        return True
    return len({type(v) for v in values}) == 1 and isinstance(values[0], (bool, str))
