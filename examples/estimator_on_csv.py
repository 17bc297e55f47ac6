"""The estimator FMU on a CSV of sensor signals, in fmpy (the README's ten lines, commented).

    .venv/bin/python examples/estimator_on_csv.py [FMU_DIR]

FMU_DIR defaults to target/fmu, where `cargo run --release -p packaging` writes the archives.
The CSV (data/escort_sensors.csv) is a recorded drive converted to SI units and ISO 8855 signs,
one column per FMU input plus the sideslip reference; the car is given by its basic data only."""

import sys
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu

HERE = Path(__file__).resolve().parent
FMU_DIR = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "target" / "fmu"

# One row per sample; fmpy feeds every column whose name is an FMU input (interpolated between
# rows) and ignores the others, here `sideslip_ref`.
sensors = np.genfromtxt(HERE / "data" / "escort_sensors.csv", delimiter=",", names=True)

# The car's basic data (a Ford Escort); the static wheel loads are per wheel, m g l / (2 L).
car = {"mass": 1225.9, "yaw_inertia": 1538.9, "cog_to_front_axle": 0.884,
       "cog_to_rear_axle": 1.509, "wheel_radius_front": 0.344, "wheel_radius_rear": 0.344,
       "wheel_load_front": 3791.7, "wheel_load_rear": 2221.4}

# Every other parameter keeps its default: the EKF on the grip model. The torques are left at 0,
# which the estimator reads as "unknown", as on most cars.
result = simulate_fmu(str(FMU_DIR / "VehicleStateEstimator.fmu"), start_values=car, input=sensors,
                      stop_time=float(sensors["time"][-1]), output_interval=0.01,
                      output=["sideslip_est", "sideslip_std", "status"])

reference = np.interp(result["time"], sensors["time"], sensors["sideslip_ref"])
error = result["sideslip_est"] - reference
rmse, zero = (np.degrees(np.sqrt(np.mean(e ** 2))) for e in (error, reference))
nees = np.mean(error ** 2 / result["sideslip_std"] ** 2)
print(f"sideslip RMSE {rmse:.2f} deg (answering zero: {zero:.2f} deg), NEES {nees:.2f}")
