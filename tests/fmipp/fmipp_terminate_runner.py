"""FMI++'s documented way to end a co-simulation, run in its own process by test_fmipp.py (an
abort shows as a signal in the return code): `FMUCoSimulationV2.terminate()` calls fmi2Terminate
and fmi2FreeInstance but keeps the component, and the object's destructor, which runs when the
name is bound to the next FMU object (constructed first), calls fmi2Terminate and
fmi2FreeInstance on it again (FMI++ 2.1, import/base/src/FMUCoSimulation_v2.cpp).

    python fmipp_terminate_runner.py <extract dir> <fmu file> <model identifier> ...
"""

import sys

import fmipp


def main():
    extract_directory, pairs = sys.argv[1], sys.argv[2:]
    fmu = None
    for path, identifier in zip(pairs[0::2], pairs[1::2]):
        uri = fmipp.extractFMU(path, extract_directory)
        for cycle in range(3):
            fmu = fmipp.FMUCoSimulationV2(uri, identifier, False, 1e-9)
            assert fmu.instantiate(f"{identifier}{cycle}", 0.0, False, False) == fmipp.statusOK
            assert fmu.initialize(0.0, False, 0.0) == fmipp.statusOK
            for step in range(5):
                assert fmu.doStep(step * 0.001, 0.001, True) == fmipp.statusOK
            fmu.terminate()
    del fmu
    print("completed")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
