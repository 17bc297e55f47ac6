"""Drives one FMU shared library through the raw FMI 2.0 C API (ctypes) with one misuse scenario
and prints what happened as JSON: the status of every call and the log lines it produced.

Run as a separate process by test_fmpy_c_abi.py, so that a crash (a signal) is reported as a failed
test instead of killing pytest:

    python fmi2_misuse_runner.py <library.so> <scenario> '<json: guid, resources, vrs...>'

Every scenario ends with a healthy run (instantiate, initialise, ten steps, free) to show that the
library still works after the misuse, then unloads the library (dlclose) and exits normally.
"""

import ctypes
import json
import math
import sys
from ctypes import (CFUNCTYPE, POINTER, Structure, byref, c_char, c_char_p, c_double, c_int, c_size_t,
                    c_uint, c_void_p)

OK, WARNING, DISCARD, ERROR, FATAL, PENDING = range(6)
MODEL_EXCHANGE, CO_SIMULATION = 0, 1

LOGGER = CFUNCTYPE(None, c_void_p, c_char_p, c_int, c_char_p, c_char_p, c_void_p)
ALLOCATE = CFUNCTYPE(c_void_p, c_size_t, c_size_t)
FREE = CFUNCTYPE(None, c_void_p)
STEP_FINISHED = CFUNCTYPE(None, c_void_p, c_int)


class CallbackFunctions(Structure):
    _fields_ = [("logger", LOGGER), ("allocateMemory", ALLOCATE), ("freeMemory", FREE),
                ("stepFinished", STEP_FINISHED), ("componentEnvironment", c_void_p)]


libc = ctypes.CDLL(None)
libc.calloc.restype = c_void_p
libc.calloc.argtypes = [c_size_t, c_size_t]
libc.free.argtypes = [c_void_p]

log_lines = []


def _logger(environment, instance_name, status, category, message_format, argument):
    # The FMU must pass "%s" as the format and the text as the first variadic argument (a text used
    # as format would break on a '%'); only then is the argument a string we may read.
    entry = {"instance": instance_name.decode("utf-8", "replace") if instance_name else None,
             "status": status,
             "category": category.decode("utf-8", "replace") if category else None,
             "format": message_format.decode("utf-8", "replace") if message_format else None}
    if message_format == b"%s" and argument:
        entry["message"] = ctypes.string_at(argument).decode("utf-8", "replace")
    else:
        entry["message"] = entry["format"]
    log_lines.append(entry)


logger = LOGGER(_logger)
allocate = ALLOCATE(lambda count, size: libc.calloc(count, size))
free = FREE(lambda pointer: libc.free(pointer))
callbacks = CallbackFunctions(logger, allocate, free, STEP_FINISHED(), None)


def bind(library):
    """Declares the signatures of the FMI 2.0 functions used here (FMI 2.0.4, sections 2.1, 4.2)."""
    component = c_void_p
    signatures = {
        "fmi2Instantiate": (c_void_p, [c_char_p, c_int, c_char_p, c_char_p, POINTER(CallbackFunctions), c_int, c_int]),
        "fmi2FreeInstance": (None, [component]),
        "fmi2SetDebugLogging": (c_int, [component, c_int, c_size_t, POINTER(c_char_p)]),
        "fmi2SetupExperiment": (c_int, [component, c_int, c_double, c_double, c_int, c_double]),
        "fmi2EnterInitializationMode": (c_int, [component]),
        "fmi2ExitInitializationMode": (c_int, [component]),
        "fmi2Terminate": (c_int, [component]),
        "fmi2Reset": (c_int, [component]),
        "fmi2GetReal": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_double)]),
        "fmi2SetReal": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_double)]),
        "fmi2GetInteger": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_int)]),
        "fmi2SetInteger": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_int)]),
        "fmi2GetBoolean": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_int)]),
        "fmi2SetBoolean": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_int)]),
        "fmi2GetString": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_char_p)]),
        "fmi2SetString": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_char_p)]),
        "fmi2GetFMUstate": (c_int, [component, POINTER(c_void_p)]),
        "fmi2SetFMUstate": (c_int, [component, c_void_p]),
        "fmi2FreeFMUstate": (c_int, [component, POINTER(c_void_p)]),
        "fmi2SerializedFMUstateSize": (c_int, [component, c_void_p, POINTER(c_size_t)]),
        "fmi2SerializeFMUstate": (c_int, [component, c_void_p, POINTER(c_char), c_size_t]),
        "fmi2DeSerializeFMUstate": (c_int, [component, POINTER(c_char), c_size_t, POINTER(c_void_p)]),
        "fmi2GetDirectionalDerivative": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_uint), c_size_t,
                                                 POINTER(c_double), POINTER(c_double)]),
        "fmi2SetRealInputDerivatives": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_int), POINTER(c_double)]),
        "fmi2GetRealOutputDerivatives": (c_int, [component, POINTER(c_uint), c_size_t, POINTER(c_int), POINTER(c_double)]),
        "fmi2DoStep": (c_int, [component, c_double, c_double, c_int]),
        "fmi2CancelStep": (c_int, [component]),
        "fmi2GetStatus": (c_int, [component, c_int, POINTER(c_int)]),
    }
    for name, (restype, argtypes) in signatures.items():
        function = getattr(library, name)
        function.restype = restype
        function.argtypes = argtypes


def uints(*values):
    return (c_uint * len(values))(*values)


def doubles(*values):
    return (c_double * len(values))(*values)


class Session:
    """One scenario: runs cases and records, per call, the status and the log lines it caused."""

    def __init__(self, library, config):
        self.f = library
        self.config = config
        self.calls = []
        self.instances = 0
        self.mark = 0

    def record(self, label, status):
        """Records a call's result; the log lines since the last mark are the call's."""
        self.calls.append({"call": label, "status": status, "logs": log_lines[self.mark:]})
        self.mark = len(log_lines)
        return status

    def skip_logs(self):
        """Log lines of set-up calls are not attributed to the next recorded call."""
        self.mark = len(log_lines)

    def instantiate(self, guid=None, name=None, kind=CO_SIMULATION, functions=True):
        self.instances += 1
        instance_name = name if name is not None else f"misuse{self.instances}".encode()
        component = self.f.fmi2Instantiate(instance_name, kind, (guid or self.config["guid"]).encode(),
                                           self.config["resources"].encode(),
                                           byref(callbacks) if functions else None, 0, 1)
        return component

    def fresh(self, initialised=True):
        """A new, valid instance, optionally initialised at t = 0; its set-up logs are skipped."""
        component = self.instantiate()
        if not component:
            raise RuntimeError("a valid fmi2Instantiate returned NULL")
        statuses = [self.f.fmi2SetupExperiment(component, 0, 0.0, 0.0, 0, 0.0)]
        if initialised:
            statuses.append(self.f.fmi2EnterInitializationMode(component))
            statuses.append(self.f.fmi2ExitInitializationMode(component))
        if any(status != OK for status in statuses):
            raise RuntimeError(f"set-up of a valid instance failed: {statuses}")
        self.skip_logs()
        return component

    def healthy_run(self):
        """Instantiate, initialise, ten steps of 10 ms, read an output, free: all must be fmi2OK."""
        component = self.fresh()
        statuses = []
        time = 0.0
        for _ in range(10):
            statuses.append(self.f.fmi2DoStep(component, time, 0.01, 1))
            time += 0.01
        value = doubles(math.nan)
        statuses.append(self.f.fmi2GetReal(component, uints(self.config["output_vr"]), 1, value))
        statuses.append(self.f.fmi2Terminate(component))
        self.f.fmi2FreeInstance(component)
        self.skip_logs()
        return {"statuses": statuses, "output": value[0]}


def scenario_wrong_guid(s):
    component = s.instantiate(guid="{00000000-0000-0000-0000-000000000000}")
    s.record("fmi2Instantiate with a wrong GUID returns NULL", "non-NULL" if component else "NULL")
    if component:
        s.f.fmi2FreeInstance(component)


def scenario_instantiate_arguments(s):
    component = s.f.fmi2Instantiate(None, CO_SIMULATION, s.config["guid"].encode(), s.config["resources"].encode(),
                                    byref(callbacks), 0, 1)
    s.record("fmi2Instantiate with instanceName NULL returns NULL", "non-NULL" if component else "NULL")
    if component:
        s.f.fmi2FreeInstance(component)
    component = s.instantiate(kind=MODEL_EXCHANGE)
    s.record("fmi2Instantiate as Model Exchange (not supported) returns NULL", "non-NULL" if component else "NULL")
    if component:
        s.f.fmi2FreeInstance(component)
    component = s.f.fmi2Instantiate(b"x", CO_SIMULATION, None, s.config["resources"].encode(), byref(callbacks), 0, 1)
    s.record("fmi2Instantiate with GUID NULL returns NULL", "non-NULL" if component else "NULL")
    if component:
        s.f.fmi2FreeInstance(component)
    # Without callback functions the FMU cannot log; it must still refuse without crashing.
    component = s.instantiate(functions=False)
    s.record("fmi2Instantiate with functions NULL returns NULL (no logger to call)", "non-NULL" if component else "NULL")
    if component:
        s.f.fmi2FreeInstance(component)


def scenario_null_pointers(s):
    f = s.f
    vr = uints(s.config["output_vr"])
    value = doubles(0.0)
    s.record("fmi2GetReal vr NULL", f.fmi2GetReal(s.fresh(), None, 1, value))
    s.record("fmi2GetReal value NULL", f.fmi2GetReal(s.fresh(), vr, 1, None))
    s.record("fmi2SetReal vr NULL", f.fmi2SetReal(s.fresh(), None, 1, doubles(0.0)))
    s.record("fmi2SetReal value NULL", f.fmi2SetReal(s.fresh(), uints(s.config["input_vr"]), 1, None))
    s.record("fmi2GetInteger value NULL", f.fmi2GetInteger(s.fresh(), uints(s.config["integer_vr"]), 1, None))
    s.record("fmi2GetFMUstate state pointer NULL", f.fmi2GetFMUstate(s.fresh(), None))
    s.record("fmi2SetFMUstate state NULL", f.fmi2SetFMUstate(s.fresh(), None))
    size = c_size_t(0)
    s.record("fmi2SerializedFMUstateSize state NULL", f.fmi2SerializedFMUstateSize(s.fresh(), None, byref(size)))
    state = c_void_p()
    s.record("fmi2DeSerializeFMUstate bytes NULL", f.fmi2DeSerializeFMUstate(s.fresh(), None, 16, byref(state)))
    s.record("fmi2SetDebugLogging categories NULL", f.fmi2SetDebugLogging(s.fresh(), 1, 1, None))
    # A NULL instance: nobody to log through, but an error status and no crash.
    s.record("fmi2DoStep instance NULL", f.fmi2DoStep(None, 0.0, 0.01, 1))
    s.record("fmi2GetReal instance NULL", f.fmi2GetReal(None, vr, 1, value))
    f.fmi2FreeInstance(None)
    s.record("fmi2FreeInstance NULL returned", OK)


def scenario_unknown_value_reference(s):
    f = s.f
    unknown = s.config["unknown_vr"]
    s.record("fmi2GetReal unknown vr", f.fmi2GetReal(s.fresh(), uints(unknown), 1, doubles(0.0)))
    s.record("fmi2SetReal unknown vr", f.fmi2SetReal(s.fresh(), uints(unknown), 1, doubles(1.0)))
    s.record("fmi2GetInteger unknown vr", f.fmi2GetInteger(s.fresh(), uints(unknown), 1, (c_int * 1)()))
    s.record("fmi2GetBoolean unknown vr", f.fmi2GetBoolean(s.fresh(), uints(unknown), 1, (c_int * 1)()))
    s.record("fmi2GetString unknown vr", f.fmi2GetString(s.fresh(), uints(unknown), 1, (c_char_p * 1)()))
    s.record("fmi2SetString unknown vr", f.fmi2SetString(s.fresh(), uints(unknown), 1, (c_char_p * 1)(b"x")))
    # A known vr among unknown ones: still an error for the whole call.
    s.record("fmi2GetReal known + unknown vr",
             f.fmi2GetReal(s.fresh(), uints(s.config["output_vr"], unknown), 2, doubles(0.0, 0.0)))
    # The vr of an Integer/Enumeration variable asked for as Real (FMI 2.0: vrs are per type).
    if s.config.get("integer_only_vr") is not None:
        s.record("fmi2GetReal with an Integer-only vr",
                 f.fmi2GetReal(s.fresh(), uints(s.config["integer_only_vr"]), 1, doubles(0.0)))


def scenario_wrong_state(s):
    f = s.f
    s.record("fmi2DoStep before initialisation", f.fmi2DoStep(s.fresh(initialised=False), 0.0, 0.01, 1))
    s.record("fmi2ExitInitializationMode without Enter", f.fmi2ExitInitializationMode(s.fresh(initialised=False)))
    component = s.fresh(initialised=False)
    f.fmi2EnterInitializationMode(component)
    s.skip_logs()
    s.record("fmi2EnterInitializationMode twice", f.fmi2EnterInitializationMode(component))
    s.record("fmi2SetupExperiment after initialisation", f.fmi2SetupExperiment(s.fresh(), 0, 0.0, 0.0, 0, 0.0))
    s.record("fmi2EnterInitializationMode after initialisation", f.fmi2EnterInitializationMode(s.fresh()))
    s.record("fmi2GetReal before initialisation (instantiated state)",
             f.fmi2GetReal(s.fresh(initialised=False), uints(s.config["output_vr"]), 1, doubles(0.0)))
    s.record("fmi2SetReal of a fixed parameter after initialisation",
             f.fmi2SetReal(s.fresh(), uints(s.config["fixed_real_vr"]), 1,
                           doubles(s.config["fixed_real_start"])))
    component = s.fresh()
    f.fmi2Terminate(component)
    s.skip_logs()
    s.record("fmi2DoStep after fmi2Terminate", f.fmi2DoStep(component, 0.0, 0.01, 1))
    component = s.fresh()
    f.fmi2Terminate(component)
    s.skip_logs()
    s.record("fmi2Terminate twice", f.fmi2Terminate(component))


def scenario_step_size(s):
    f = s.f
    s.record("fmi2DoStep h = 0", f.fmi2DoStep(s.fresh(), 0.0, 0.0, 1))
    s.record("fmi2DoStep h < 0", f.fmi2DoStep(s.fresh(), 0.0, -0.01, 1))
    s.record("fmi2DoStep h = NaN", f.fmi2DoStep(s.fresh(), 0.0, math.nan, 1))
    s.record("fmi2DoStep h = inf", f.fmi2DoStep(s.fresh(), 0.0, math.inf, 1))


def scenario_communication_point(s):
    f = s.f
    s.record("first fmi2DoStep at t = 0.3, start time 0", f.fmi2DoStep(s.fresh(), 0.3, 0.01, 1))
    component = s.fresh()
    f.fmi2DoStep(component, 0.0, 0.01, 1)
    s.skip_logs()
    s.record("fmi2DoStep skipping ahead (0.5 after a step to 0.01)", f.fmi2DoStep(component, 0.5, 0.01, 1))
    component = s.fresh()
    f.fmi2DoStep(component, 0.0, 0.01, 1)
    s.skip_logs()
    s.record("fmi2DoStep repeating t = 0 after a step to 0.01", f.fmi2DoStep(component, 0.0, 0.01, 1))
    component = s.fresh()
    f.fmi2DoStep(component, 0.0, 0.01, 1)
    s.skip_logs()
    s.record("fmi2DoStep going back (0.005 after a step to 0.01)", f.fmi2DoStep(component, 0.005, 0.01, 1))
    # Rounding as masters produce it must be accepted: steps of 0.009999999999999998 and
    # communication points accumulated by repeated addition.
    component = s.fresh()
    statuses = set()
    time = 0.0
    for k in range(1, 101):
        next_time = k * 0.01
        statuses.add(f.fmi2DoStep(component, time, next_time - time, 1))
        time += 0.01
    s.record("100 steps with rounded communication points (must be fmi2OK)", max(statuses))
    component = s.fresh()
    f.fmi2DoStep(component, 0.0, 0.01, 1)
    s.skip_logs()
    s.record("fmi2DoStep at 0.009999999999999998 after a step to 0.01 (must be fmi2OK)",
             f.fmi2DoStep(component, 0.009999999999999998, 0.01, 1))


def scenario_unsupported(s):
    f = s.f
    vr = uints(s.config["output_vr"])
    known = uints(s.config["input_vr"])
    s.record("fmi2GetDirectionalDerivative (providesDirectionalDerivative=false)",
             f.fmi2GetDirectionalDerivative(s.fresh(), vr, 1, known, 1, doubles(1.0), doubles(0.0)))
    s.record("fmi2SetRealInputDerivatives (canInterpolateInputs=false)",
             f.fmi2SetRealInputDerivatives(s.fresh(), known, 1, (c_int * 1)(1), doubles(0.0)))
    s.record("fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder=0)",
             f.fmi2GetRealOutputDerivatives(s.fresh(), vr, 1, (c_int * 1)(1), doubles(0.0)))
    s.record("fmi2CancelStep (canRunAsynchronuously=false)", f.fmi2CancelStep(s.fresh()))
    status = c_int(-1)
    # fmi2DoStepStatus is only defined while an asynchronous step is pending.
    s.record("fmi2GetStatus(fmi2DoStepStatus) without an asynchronous step",
             f.fmi2GetStatus(s.fresh(), 0, byref(status)))


def scenario_bad_state_blob(s):
    f = s.f
    state = c_void_p()
    garbage = (c_char * 64)(*([b"\x5a"] * 64))
    s.record("fmi2DeSerializeFMUstate garbage", f.fmi2DeSerializeFMUstate(s.fresh(), garbage, 64, byref(state)))
    component = s.fresh()
    saved = c_void_p()
    size = c_size_t(0)
    statuses = [f.fmi2GetFMUstate(component, byref(saved)),
                f.fmi2SerializedFMUstateSize(component, saved, byref(size))]
    blob = (c_char * size.value)()
    statuses.append(f.fmi2SerializeFMUstate(component, saved, blob, size.value))
    if any(status != OK for status in statuses) or size.value < 2:
        raise RuntimeError(f"serialising a valid state failed: {statuses}, size {size.value}")
    s.skip_logs()
    too_small = (c_char * 1)()
    s.record("fmi2SerializeFMUstate into a buffer smaller than fmi2SerializedFMUstateSize",
             f.fmi2SerializeFMUstate(component, saved, too_small, 1))
    f.fmi2FreeFMUstate(component, byref(saved))
    s.skip_logs()
    truncated = c_void_p()
    s.record("fmi2DeSerializeFMUstate truncated by one byte",
             f.fmi2DeSerializeFMUstate(component, blob, size.value - 1, byref(truncated)))
def scenario_invalid_parameter(s):
    f = s.f
    for case in s.config["invalid_parameters"]:
        component = s.fresh(initialised=False)
        status = f.fmi2SetReal(component, uints(case["vr"]), 1, doubles(case["value"]))
        if status == OK:
            # Accepted when set; then initialisation must refuse it.
            status = max(f.fmi2EnterInitializationMode(component), f.fmi2ExitInitializationMode(component))
        s.record(f"parameter {case['name']} = {case['value']} (outside min/max or not finite)", status)


SCENARIOS = {name[len("scenario_"):]: function for name, function in globals().items()
             if name.startswith("scenario_")}


def main():
    library_path, scenario, config = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    handle = ctypes.CDLL(library_path, mode=ctypes.RTLD_LOCAL)
    bind(handle)
    session = Session(handle, config)
    SCENARIOS[scenario](session)
    health = session.healthy_run()
    result = {"calls": session.calls, "healthy": health, "all_logs": log_lines}
    # Unload like fmpy does after each instance; a crash here (e.g. from thread-local destructors)
    # would show as a signal in the return code.
    import _ctypes
    _ctypes.dlclose(handle._handle)
    print(json.dumps(result))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
