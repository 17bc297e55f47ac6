"""Pseudo-random FMI 3.0 call sequences on both packaged FMI 3 libraries, through the raw C API
(ctypes): calls in any state, wrong value-reference types, wrong nValues, null outputs, foreign
instance and FMU-state handles, mutated serialized states, functions of capabilities the FMUs do
not declare. Whatever the sequence, no call may crash or hang the process, and fmi3Reset must
bring the instance back to one that initialises and steps.

Each FMU runs in a child process (this file run as a script), so that a crash (a signal) is a
failed test instead of a dead pytest."""

import ctypes
import random
import subprocess
import sys
import zipfile
from ctypes import (CFUNCTYPE, POINTER, byref, c_bool, c_char_p, c_double, c_int, c_int32, c_int64,
                    c_size_t, c_uint8, c_uint32, c_void_p)

import pytest

SEQUENCES = 300
CALLS = 60
BUFFER = 512
SPECIAL = [0.0, -0.0, 1.0, -1.0, 5e-324, 1e300, float("nan"), float("inf"), float("-inf"), 0.01]
OK, WARNING, DISCARD, ERROR, FATAL = range(5)

LOGGER = CFUNCTYPE(None, c_void_p, c_int, c_char_p, c_char_p)


def run(library_path, token, references, array_sizes):
    """The child process: every sequence, then exit 0 (a crash never gets here)."""
    lib = ctypes.CDLL(library_path)
    lines = []
    logger = LOGGER(lambda env, status, category, message: lines.append(status))
    lib.fmi3InstantiateCoSimulation.restype = c_void_p
    lib.fmi3InstantiateCoSimulation.argtypes = [c_char_p, c_char_p, c_char_p, c_bool, c_bool, c_bool,
                                                c_bool, POINTER(c_uint32), c_size_t, c_void_p,
                                                LOGGER, c_void_p]
    for name in ["fmi3EnterInitializationMode"]:
        getattr(lib, name).argtypes = [c_void_p, c_bool, c_double, c_double, c_bool, c_double]
    lib.fmi3DoStep.argtypes = [c_void_p, c_double, c_double, c_bool, POINTER(c_bool), POINTER(c_bool),
                               POINTER(c_bool), POINTER(c_double)]
    for name, ctype in [("Float64", c_double), ("Int32", c_int32), ("Int64", c_int64),
                        ("Boolean", c_uint8), ("Float32", ctypes.c_float), ("UInt64", ctypes.c_uint64)]:
        for kind in ("Get", "Set"):
            getattr(lib, f"fmi3{kind}{name}").argtypes = [c_void_p, POINTER(c_uint32), c_size_t,
                                                          POINTER(ctype), c_size_t]
    for name in ["fmi3ExitInitializationMode", "fmi3Terminate", "fmi3Reset", "fmi3EnterEventMode",
                 "fmi3EnterConfigurationMode", "fmi3EnterStepMode", "fmi3FreeInstance"]:
        getattr(lib, name).argtypes = [c_void_p]
    lib.fmi3GetFMUState.argtypes = [c_void_p, POINTER(c_void_p)]
    lib.fmi3SetFMUState.argtypes = [c_void_p, c_void_p]
    lib.fmi3FreeFMUState.argtypes = [c_void_p, POINTER(c_void_p)]
    lib.fmi3SerializedFMUStateSize.argtypes = [c_void_p, c_void_p, POINTER(c_size_t)]
    lib.fmi3SerializeFMUState.argtypes = [c_void_p, c_void_p, POINTER(c_uint8), c_size_t]
    lib.fmi3DeserializeFMUState.argtypes = [c_void_p, POINTER(c_uint8), c_size_t, POINTER(c_void_p)]
    lib.fmi3GetNumberOfVariableDependencies.argtypes = [c_void_p, c_uint32, POINTER(c_size_t)]
    lib.fmi3SetTime.argtypes = [c_void_p, c_double]

    rng = random.Random(20)
    floats = (c_double * BUFFER)()
    ints = (c_int32 * BUFFER)()
    longs = (c_int64 * BUFFER)()
    flags = (c_uint8 * BUFFER)()
    others = (ctypes.c_float * BUFFER)()
    wide = (ctypes.c_uint64 * BUFFER)()
    buffers = {"Float64": floats, "Int32": ints, "Int64": longs, "Boolean": flags,
               "Float32": others, "UInt64": wide}

    def value_references():
        chosen = [rng.choice(references) if rng.random() < 0.9 else rng.getrandbits(32)
                  for _ in range(rng.randrange(5))]
        n = sum(array_sizes.get(vr, 1) for vr in chosen)
        if rng.random() < 0.1:
            n = rng.randrange(BUFFER)
        return (c_uint32 * max(len(chosen), 1))(*chosen), len(chosen), min(n, BUFFER)

    for sequence in range(SEQUENCES):
        instance = lib.fmi3InstantiateCoSimulation(b"misuse", token, None, False, False, False,
                                                   False, None, 0, None, logger, None)
        assert instance, f"instantiation refused: {lines[-3:]}"
        states = []
        time = 0.0
        for _ in range(CALLS):
            choice = rng.randrange(14)
            if choice == 0:
                kind = rng.choice(list(buffers))
                vrs, nvr, n = value_references()
                target = None if rng.random() < 0.05 else buffers[kind]
                getattr(lib, f"fmi3Get{kind}")(instance, vrs, nvr, target, n)
            elif choice == 1:
                kind = rng.choice(list(buffers))
                vrs, nvr, n = value_references()
                for k in range(n):
                    floats[k] = rng.choice(SPECIAL) if rng.random() < 0.5 else rng.uniform(-1e3, 1e3)
                    ints[k] = rng.getrandbits(31) - (1 << 30)
                    longs[k] = rng.getrandbits(40) - (1 << 39)
                    flags[k] = rng.getrandbits(8)
                getattr(lib, f"fmi3Set{kind}")(instance, vrs, nvr, buffers[kind], n)
            elif choice == 2:
                time = rng.choice(SPECIAL + [0.0, 0.0])
                lib.fmi3EnterInitializationMode(instance, False, 0.0, time, rng.random() < 0.5,
                                                rng.choice(SPECIAL))
            elif choice == 3:
                lib.fmi3ExitInitializationMode(instance)
            elif choice in (4, 5):
                step = min(abs(rng.choice(SPECIAL + [0.001, 0.01])), 1.0)
                at = rng.choice(SPECIAL) if rng.random() < 0.1 else time
                event, terminate, early, last = c_bool(), c_bool(), c_bool(), c_double()
                pointer = None if rng.random() < 0.05 else byref(event)
                status = lib.fmi3DoStep(instance, at, step, True, pointer, byref(terminate),
                                        byref(early), byref(last))
                if status in (OK, WARNING):
                    time = at + step
            elif choice == 6:
                state = c_void_p()
                if lib.fmi3GetFMUState(instance, byref(state)) == OK and len(states) < 4:
                    states.append(state)
                elif state.value:
                    lib.fmi3FreeFMUState(instance, byref(state))
            elif choice == 7:
                target = rng.choice(states) if states else c_void_p(ctypes.addressof(floats))
                lib.fmi3SetFMUState(instance, target)
            elif choice == 8 and states:
                size = c_size_t()
                if lib.fmi3SerializedFMUStateSize(instance, states[0], byref(size)) == OK:
                    data = (c_uint8 * size.value)()
                    if lib.fmi3SerializeFMUState(instance, states[0], data, size.value) == OK:
                        if size.value and rng.random() < 0.5:
                            data[rng.randrange(size.value)] ^= rng.randrange(1, 256)
                        restored = c_void_p()
                        if lib.fmi3DeserializeFMUState(instance, data, size.value,
                                                       byref(restored)) == OK:
                            lib.fmi3SetFMUState(instance, restored)
                            lib.fmi3FreeFMUState(instance, byref(restored))
            elif choice == 9:
                lib.fmi3Reset(instance)
            elif choice == 10:
                lib.fmi3Terminate(instance)
            elif choice == 11:
                name = rng.choice(["fmi3EnterEventMode", "fmi3EnterConfigurationMode",
                                   "fmi3EnterStepMode"])
                getattr(lib, name)(instance)
                lib.fmi3SetTime(instance, 1.0)
            elif choice == 12:
                count = c_size_t()
                lib.fmi3GetNumberOfVariableDependencies(
                    instance, rng.choice(references), None if rng.random() < 0.1 else byref(count))
            else:
                # A handle that is no instance of this library.
                lib.fmi3Terminate(ctypes.addressof(floats))
        for state in states:
            lib.fmi3FreeFMUState(instance, byref(state))
        assert lib.fmi3Reset(instance) == OK, lines[-3:]
        assert lib.fmi3EnterInitializationMode(instance, False, 0.0, 0.0, False, 0.0) == OK
        assert lib.fmi3ExitInitializationMode(instance) == OK, lines[-3:]
        event, terminate, early, last = c_bool(), c_bool(), c_bool(), c_double()
        status = lib.fmi3DoStep(instance, 0.0, 0.01, True, byref(event), byref(terminate),
                                byref(early), byref(last))
        assert status in (OK, WARNING) and last.value == 0.01, (sequence, status, lines[-3:])
        lib.fmi3FreeInstance(instance)
    print(f"ok {SEQUENCES} sequences")


@pytest.mark.parametrize("model", ["ReferenceVehicle", "VehicleStateEstimator"])
def test_random_fmi3_call_sequences_neither_crash_nor_break_the_instance(model, tmp_path):
    import fmu_support as support
    from fmpy import read_model_description
    path = support.archive_path(f"{model}-fmi3.fmu")
    if not path.is_file():
        pytest.fail(f"{path} does not exist: build the archives with "
                    f"`cargo run --release -p packaging`", pytrace=False)
    zipfile.ZipFile(path).extractall(tmp_path)
    description = read_model_description(str(path))
    references = [v.valueReference for v in description.modelVariables]
    sizes = {v.valueReference: int(__import__("math").prod(int(d.start) for d in v.dimensions))
             for v in description.modelVariables if v.dimensions}
    library = tmp_path / "binaries" / "x86_64-linux" / f"{model}.so"
    completed = subprocess.run(
        [sys.executable, __file__, str(library), description.instantiationToken,
         repr(references), repr(sizes)],
        capture_output=True, text=True, timeout=600)
    assert completed.returncode == 0, completed.stderr[-3000:]
    assert completed.stdout.startswith("ok"), completed.stdout


if __name__ == "__main__":
    import ast
    run(sys.argv[1], sys.argv[2].encode(), ast.literal_eval(sys.argv[3]),
        ast.literal_eval(sys.argv[4]))
