"""Both FMUs as FMI 3.0 in fmpy, and the estimator's covariance read as an array.

    .venv/bin/python examples/fmi3_covariance.py [FMU_DIR]

The same step steer as coupled_fmpy.py, with FMU3Slave. Besides the scalar outputs that FMI 2.0
users have, the FMI 3.0 estimator gives its state (`state_estimate`, 11 values) and covariance
(`state_covariance`, 11 x 11, row-major); `state_dimension` says how many of them the running
model uses (the grip model, the default: 11)."""

import sys
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave

HERE = Path(__file__).resolve().parent
FMU_DIR = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "target" / "fmu"
STEP, STOP = 0.01, 6.0
SENSORS = ["yaw_rate_meas", "ay_meas", "omega_front_meas", "omega_rear_meas", "ax_meas", "vx_meas"]


def instantiate(name):
    """An initialised FMU3Slave and a name -> value reference table."""
    path = str(FMU_DIR / f"{name}-fmi3.fmu")
    description = read_model_description(path)
    fmu = FMU3Slave(guid=description.instantiationToken, unzipDirectory=extract(path),
                    modelIdentifier=description.coSimulation.modelIdentifier, instanceName=name)
    fmu.instantiate()
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    return fmu, {v.name: v.valueReference for v in description.modelVariables}


vehicle, vehicle_vr = instantiate("ReferenceVehicle")
estimator, estimator_vr = instantiate("VehicleStateEstimator")

for k in range(int(round(STOP / STEP))):
    time = k * STEP
    steering = 0.03 if time >= 1.0 else 0.0  # a 1.7 deg road-wheel step at 1 s
    for fmu, vr in ((vehicle, vehicle_vr), (estimator, estimator_vr)):
        fmu.setFloat64([vr["steering_angle"]], [steering])
    sensors = vehicle.getFloat64([vehicle_vr[name] for name in SENSORS])
    estimator.setFloat64([estimator_vr[name] for name in SENSORS], sensors)
    vehicle.doStep(currentCommunicationPoint=time, communicationStepSize=STEP)
    estimator.doStep(currentCommunicationPoint=time, communicationStepSize=STEP)

n = estimator.getInt32([estimator_vr["state_dimension"]])[0]
x = np.array(estimator.getFloat64([estimator_vr["state_estimate"]], nValues=11))[:n]
P = np.array(estimator.getFloat64([estimator_vr["state_covariance"]], nValues=121)).reshape(11, 11)[:n, :n]
truth = vehicle.getFloat64([vehicle_vr["sideslip"]])[0]
estimate = estimator.getFloat64([estimator_vr["sideslip_est"]])[0]
for fmu in (vehicle, estimator):
    fmu.terminate()
    fmu.freeInstance()

# Model A's first states are vx and vy: the covariance's leading 2 x 2 block is theirs.
print(f"state dimension {n}; vx {x[0]:.3f} m/s +- {np.sqrt(P[0, 0]):.4f}, "
      f"vy {x[1]:.4f} m/s +- {np.sqrt(P[1, 1]):.4f}; covariance symmetric: "
      f"{np.allclose(P, P.T)}, smallest eigenvalue {np.linalg.eigvalsh(P).min():.3g}")
print(f"sideslip: true {np.degrees(truth):.3f} deg, estimate {np.degrees(estimate):.3f} deg")
