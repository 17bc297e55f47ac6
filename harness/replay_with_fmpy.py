"""Replay a CSV log through the VehicleStateEstimator FMU with fmpy alone, as `harness replay` does.

    python harness/replay_with_fmpy.py LOG.csv MAP.toml [CAR.ssv] [--fmu PATH] [--out estimates.csv]

The map is the one `harness replay` reads (harness/logs/README.md): for each FMU input a log
column, its unit, sign and steering ratio, or a constant; the estimator parameters; reference
columns. The map's [estimator.parameters] become fmpy's `start_values`, and the .ssv (e.g.
written by `harness fit`) is applied after them (the last of a name wins), as `harness replay`
does. Samples are aligned as `harness replay` does with
align = "hold": each step takes the latest present sample at or before it, NaN once it is older
than 2.5 of the channel's median sample intervals (the FMU skips a NaN sample). A sensor input
(`*_meas`) the map leaves out is missing: a warning names it and it gets NaN on every step, never
its start value. Prints the RMSE of every estimate the map has a reference for.
"""

import argparse
import math
import sys
import tomllib
import xml.etree.ElementTree as ET

import numpy as np
from fmpy import read_model_description, simulate_fmu

# Factor from a log unit to the SI unit of the FMU variable (harness/studies/src/replay/units.rs).
UNITS = {
    "rad": 1.0, "deg": math.pi / 180.0,
    "rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": math.pi / 30.0,
    "m/s": 1.0, "km/h": 1.0 / 3.6, "mph": 0.44704,
    "m/s2": 1.0, "g": 9.80665, "N.m": 1.0, "1": 1.0,
}
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"


def start_values_from_ssv(path, fmu):
    """The parameters of an SSP 1.0 parameter-value file as fmpy start_values (an enumeration
    item by its number in the FMU's model description)."""
    items = {}
    for variable in read_model_description(fmu).modelVariables:
        if variable.declaredType is not None and variable.type == "Enumeration":
            items[variable.name] = {item.name: int(item.value) for item in variable.declaredType.items}
    values = {}
    for parameter in ET.parse(path).getroot().iter(SSV + "Parameter"):
        element = parameter[0]
        kind, text = element.tag.removeprefix(SSV), element.get("value")
        if kind == "Real":
            values[parameter.get("name")] = float(text)
        elif kind == "Integer":
            values[parameter.get("name")] = int(text)
        elif kind == "Boolean":
            values[parameter.get("name")] = text in ("true", "1")
        elif kind == "Enumeration":
            values[parameter.get("name")] = items[parameter.get("name")][text]
        else:
            values[parameter.get("name")] = text
    return values


def held(times, values, grid):
    """Latest present sample at or before each grid time; NaN when stale."""
    present = np.isfinite(values)
    t, v = times[present], values[present]
    if len(t) < 2:
        return np.full(len(grid), np.nan)
    stale_after = 2.5 * np.median(np.diff(t))
    index = np.searchsorted(t, grid + 1e-6 * (grid[1] - grid[0]), side="right") - 1
    out = np.where(index >= 0, v[np.maximum(index, 0)], np.nan)
    age = grid - t[np.maximum(index, 0)]
    return np.where((index >= 0) & (age <= stale_after), out, np.nan)


def converted(entry, log, times, grid):
    """One map entry on the grid, in SI units."""
    if "value" in entry:
        return np.full(len(grid), float(entry["value"]))
    factor = UNITS[entry["unit"]] * entry.get("sign", 1.0) / entry.get("steering_ratio", 1.0)
    raw = held(times, log[entry["column"]], grid)
    return factor * (raw - entry.get("offset", 0.0))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("log")
    parser.add_argument("map")
    parser.add_argument("ssv", nargs="?")
    parser.add_argument("--fmu", default="target/fmu/VehicleStateEstimator.fmu")
    parser.add_argument("--out", default="estimates_fmpy.csv")
    args = parser.parse_args()

    with open(args.map, "rb") as file:
        mapping = tomllib.load(file)
    log = np.genfromtxt(args.log, delimiter=",", names=True, comments="#", dtype=float)
    times = log[mapping.get("log", {}).get("time", "time")]
    step = mapping.get("log", {}).get("step") or float(np.median(np.diff(times)))
    grid = times[0] + step * np.arange(int((times[-1] - times[0]) / step + 1e-9) + 1)

    start_values = dict(mapping.get("estimator", {}).get("parameters", {}))
    if args.ssv:
        start_values.update(start_values_from_ssv(args.ssv, args.fmu))
    start_values.setdefault("sample_time", step)

    names = list(mapping["inputs"])
    sensors = [v.name for v in read_model_description(args.fmu).modelVariables
               if v.causality == "input" and v.name.endswith("_meas")]
    missing = [name for name in sensors if name not in names]
    for name in missing:
        print(f"warning: map {args.map} leaves out the FMU sensor input {name}: fed as missing (NaN) on every row",
              file=sys.stderr)
    table = np.zeros(len(grid), dtype=[("time", float)] + [(name, float) for name in names + missing])
    table["time"] = grid
    for name in names:
        table[name] = converted(mapping["inputs"][name], log, times, grid)
    for name in missing:
        table[name] = np.nan

    references = {name: converted(entry, log, times, grid) for name, entry in mapping.get("reference", {}).items()}
    outputs = ["vx_est", "vy_est", "yaw_rate_est", "sideslip_est", "sideslip_std", "nis", "status"]
    outputs += [f"{name}_est" for name in references if f"{name}_est" not in outputs]
    result = simulate_fmu(
        args.fmu,
        start_time=grid[0],
        stop_time=grid[-1],
        output_interval=step,
        step_size=step,
        start_values=start_values,
        input=table,
        output=outputs,
    )
    np.savetxt(args.out, result, delimiter=",", header=",".join(result.dtype.names), comments="")
    for name, truth in references.items():
        estimate = np.interp(grid, result["time"], result[f"{name}_est"])
        error = estimate - truth
        rmse = math.sqrt(np.nanmean(error**2))
        print(f"{name}: RMSE {rmse:.6g} (SI units) over {np.isfinite(error).sum()} samples")
    print(f"estimates: {args.out}")


if __name__ == "__main__":
    main()
