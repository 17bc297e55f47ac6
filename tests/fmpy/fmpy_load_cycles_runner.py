"""Loads, instantiates, runs, frees and unloads one FMU many times in one process with fmpy's
FMU2Slave, which dlopens the shared library for each instance and dlcloses it in freeInstance.
Run in a separate process by test_fmpy_instances.py: a crash (for example from thread-local
destructors of an unloaded library) shows as a signal in the return code.

    python fmpy_load_cycles_runner.py <unzip dir> <guid> <model identifier> <cycles>
"""

import math
import sys

from fmpy.fmi2 import FMU2Slave


def main():
    unzip_directory, guid, identifier, cycles = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    for cycle in range(cycles):
        fmu = FMU2Slave(guid=guid, unzipDirectory=unzip_directory, modelIdentifier=identifier,
                        instanceName=f"cycle{cycle}")
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        time = 0.0
        for _ in range(5):
            fmu.doStep(currentCommunicationPoint=time, communicationStepSize=0.001)
            time += 0.001
        fmu.terminate()
        fmu.freeInstance()  # fmi2FreeInstance, then dlclose of the library
    print(f"completed {cycles}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
