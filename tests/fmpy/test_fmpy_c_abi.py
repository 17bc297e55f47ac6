"""Misuse of the FMI 2.0 C API, driven through ctypes on the shared library extracted from each .fmu.

Each scenario runs in its own Python process (fmi2_misuse_runner.py): a crash shows up as a signal
in the return code and fails that test only. Every misuse must be answered with fmi2Error (or
fmi2Discard where the standard allows it) and a log line through the logger callback, formatted as
"%s" plus the text; afterwards the library must still run a healthy instance and unload cleanly."""

import json
import math
import pathlib
import subprocess
import sys

import pytest

import fmu_support as support

RUNNER = pathlib.Path(__file__).with_name("fmi2_misuse_runner.py")
WARNING, DISCARD, ERROR = 1, 2, 3


def misuse_config(interface, unzip_directory):
    variables = interface.description.modelVariables
    reals = [v for v in variables if v.type == "Real"]
    integers = [v for v in variables if v.type in ("Integer", "Enumeration")]
    real_vrs = {v.valueReference for v in reals}
    fixed_reals = [v for v in reals if v.causality == "parameter" and v.variability == "fixed"]
    bounded = [v for v in fixed_reals if v.min is not None]
    invalid = []
    if bounded:
        below = float(bounded[0].min) - max(1.0, abs(float(bounded[0].min)))
        invalid.append({"name": bounded[0].name, "vr": bounded[0].valueReference, "value": below})
    invalid.append({"name": fixed_reals[0].name, "vr": fixed_reals[0].valueReference, "value": math.nan})
    return {
        "guid": interface.description.guid,
        "resources": pathlib.Path(unzip_directory, "resources").as_uri(),
        "output_vr": next(v.valueReference for v in reals if v.causality == "output"),
        "input_vr": interface.vr("steering_angle"),
        "integer_vr": integers[0].valueReference,
        "integer_only_vr": next((v.valueReference for v in integers if v.valueReference not in real_vrs), None),
        "unknown_vr": max(v.valueReference for v in variables) + 1000,
        "fixed_real_vr": fixed_reals[0].valueReference,
        "fixed_real_start": float(fixed_reals[0].start),
        "invalid_parameters": invalid,
    }


def run_scenario(interface, unzip_directory, scenario):
    identifier = interface.description.coSimulation.modelIdentifier
    library = pathlib.Path(unzip_directory, "binaries", "linux64", f"{identifier}.so")
    assert library.is_file(), f"{library} missing from the extracted FMU"
    process = subprocess.run([sys.executable, str(RUNNER), str(library), scenario,
                              json.dumps(misuse_config(interface, unzip_directory))],
                             capture_output=True, text=True, timeout=120)
    assert process.returncode == 0, (
        f"{identifier} scenario {scenario}: the process died with return code {process.returncode} "
        f"(negative = killed by that signal)\nstdout tail: {process.stdout[-2000:]}\nstderr: {process.stderr[-4000:]}")
    return json.loads(process.stdout.strip().splitlines()[-1])


def check_run(identifier, result, expectations):
    """expectations: label prefix -> (allowed results, log line required)."""
    problems = []
    for call in result["calls"]:
        label = call["call"]
        allowed, needs_log = next(((a, n) for prefix, (a, n) in expectations.items() if label.startswith(prefix)),
                                  (None, None))
        if allowed is None:
            problems.append(f"{label}: no expectation in the test")
            continue
        if call["status"] not in allowed:
            problems.append(f"{label}: returned {call['status']}, expected one of {sorted(allowed, key=str)}; "
                            f"log: {[line['message'] for line in call['logs']]}")
        if needs_log:
            # A warning (a clamped or ignored value) is explained by a warning line.
            matching = [line for line in call["logs"]
                        if (line["status"] in (DISCARD, ERROR, 4) or line["status"] == call["status"] == WARNING)
                        and line["message"]]
            if not matching:
                problems.append(f"{label}: no error/discard log line through the logger "
                                f"(got {call['logs']})")
    for line in result["all_logs"]:
        if line["format"] != "%s":
            problems.append(f"logger called with format {line['format']!r} instead of '%s'")
    health = result["healthy"]
    if any(status != 0 for status in health["statuses"]) or not math.isfinite(health["output"]):
        problems.append(f"healthy run after the misuse failed: {health}")
    assert not problems, f"{identifier}:\n  " + "\n  ".join(problems)


ERROR_ONLY = {ERROR}
ERROR_OR_DISCARD = {ERROR, DISCARD}

EXPECTATIONS = {
    "wrong_guid": {"fmi2Instantiate with a wrong GUID": ({"NULL"}, True)},
    "instantiate_arguments": {
        "fmi2Instantiate with instanceName NULL": ({"NULL"}, True),
        "fmi2Instantiate as Model Exchange": ({"NULL"}, True),
        "fmi2Instantiate with GUID NULL": ({"NULL"}, True),
        "fmi2Instantiate with functions NULL": ({"NULL"}, False),
    },
    "null_pointers": {
        "fmi2DoStep instance NULL": (ERROR_ONLY, False),
        "fmi2GetReal instance NULL": (ERROR_ONLY, False),
        "fmi2FreeInstance NULL": ({0}, False),
        "fmi2": (ERROR_ONLY, True),
    },
    "unknown_value_reference": {"fmi2": (ERROR_ONLY, True)},
    "wrong_state": {"fmi2": (ERROR_ONLY, True)},
    "step_size": {"fmi2DoStep": (ERROR_OR_DISCARD, True)},
    "communication_point": {
        "100 steps with rounded": ({0}, False),
        "fmi2DoStep at 0.009999999999999998": ({0}, False),
        "": (ERROR_OR_DISCARD, True),
    },
    "unsupported": {
        "fmi2GetStatus": (ERROR_OR_DISCARD, True),
        "fmi2": (ERROR_ONLY, True),
    },
    "bad_state_blob": {"fmi2": (ERROR_ONLY, True)},
    # fmi-export clamps an out-of-range value and ignores a NaN parameter in fmi2SetReal, with
    # fmi2Warning and a log line naming the variable.
    "invalid_parameter": {"parameter": ({WARNING}, True)},
}


@pytest.mark.parametrize("scenario", sorted(EXPECTATIONS))
@pytest.mark.parametrize("which", [support.VEHICLE, support.ESTIMATOR])
def test_misuse_is_refused_with_a_log_line(scenario, which, request):
    interface, directory = support.interface_and_directory(request, which)
    result = run_scenario(interface, directory, scenario)
    assert result["calls"], "the scenario recorded no call"
    check_run(which, result, EXPECTATIONS[scenario])
