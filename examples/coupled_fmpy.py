"""Both FMUs coupled in fmpy: the reference vehicle drives a step steer, its corrupted sensor
signals feed the estimator, and the estimate is compared with the vehicle's true sideslip.

    .venv/bin/python examples/coupled_fmpy.py [FMU_DIR]

A plain co-simulation loop with fmpy's FMU2Slave: at each communication point the driver inputs
go to both FMUs, the vehicle's sensor outputs to the estimator's inputs of the same name, then
both step."""

import sys
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

HERE = Path(__file__).resolve().parent
FMU_DIR = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "target" / "fmu"
STEP, STOP = 0.01, 6.0
SENSORS = ["yaw_rate_meas", "ay_meas", "omega_front_meas", "omega_rear_meas", "ax_meas", "vx_meas"]


def instantiate(name):
    """An initialised FMU2Slave and a name -> value reference table."""
    path = str(FMU_DIR / f"{name}.fmu")
    description = read_model_description(path)
    fmu = FMU2Slave(guid=description.guid, unzipDirectory=extract(path),
                    modelIdentifier=description.coSimulation.modelIdentifier, instanceName=name)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu, {v.name: v.valueReference for v in description.modelVariables}


vehicle, vehicle_vr = instantiate("ReferenceVehicle")
estimator, estimator_vr = instantiate("VehicleStateEstimator")

rows = []
for k in range(int(round(STOP / STEP))):
    time = k * STEP
    steering = 0.03 if time >= 1.0 else 0.0  # a 1.7 deg road-wheel step at 1 s
    for fmu, vr in ((vehicle, vehicle_vr), (estimator, estimator_vr)):
        fmu.setReal([vr["steering_angle"]], [steering])
    # The sensor signals of this instant (the vehicle feeds the steering through at once).
    sensors = vehicle.getReal([vehicle_vr[name] for name in SENSORS])
    estimator.setReal([estimator_vr[name] for name in SENSORS], sensors)
    vehicle.doStep(currentCommunicationPoint=time, communicationStepSize=STEP)
    estimator.doStep(currentCommunicationPoint=time, communicationStepSize=STEP)
    truth = vehicle.getReal([vehicle_vr["sideslip"]])[0]
    estimate, std = estimator.getReal([estimator_vr["sideslip_est"], estimator_vr["sideslip_std"]])
    rows.append((time + STEP, truth, estimate, std))

for fmu in (vehicle, estimator):
    fmu.terminate()
    fmu.freeInstance()

time, truth, estimate, std = np.array(rows).T
turning = time > 1.5
error = np.degrees(estimate - truth)[turning]
print(f"steady turn: true sideslip {np.degrees(truth[-1]):.3f} deg, estimate "
      f"{np.degrees(estimate[-1]):.3f} +- {np.degrees(std[-1]):.3f} deg, "
      f"RMSE {np.sqrt(np.mean(error ** 2)):.3f} deg")
