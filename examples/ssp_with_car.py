"""The shipped system VehicleWithEstimator.ssp in fmpy, with a car file bound to the reference
vehicle: the BMW 320i (fmu-src/reference-vehicle/cars/bmw_320i.ssv), which switches it to the
full vehicle (model 3); the estimator gets the same car's basic data from that file.

    .venv/bin/python examples/ssp_with_car.py [FMU_DIR]

fmpy's SSP runner applies one parameter set with names prefixed by the component, and converts
no enumeration or boolean literal, so this script reads the .ssv files itself: the system's own
driver-input binding and the car file."""

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from fmpy import read_model_description
from fmpy.ssp.simulation import simulate_ssp
from fmpy.ssp.ssd import Parameter, ParameterSet

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FMU_DIR = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "target" / "fmu"
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
CAR = ROOT / "fmu-src" / "reference-vehicle" / "cars" / "bmw_320i.ssv"
# What the estimator is told of the car: its basic data, by the same names in both FMUs.
BASIC_DATA = ["mass", "cog_to_front_axle", "cog_to_rear_axle", "yaw_inertia", "wheel_load_front",
              "wheel_load_rear", "wheel_inertia_front", "wheel_inertia_rear"]


def ssv_values(path, variables):
    """name -> value of an SSP parameter-value file, as fmpy sets them: enumeration items by
    their number, booleans as 0/1, numbers as floats."""
    values = {}
    for parameter in ET.parse(path).iter(SSV + "Parameter"):
        element = next(iter(parameter))
        kind, text = element.tag.removeprefix(SSV), element.get("value")
        if kind == "Enumeration":
            items = variables[parameter.get("name")].declaredType.items
            values[parameter.get("name")] = next(int(i.value) for i in items if i.name == text)
        elif kind == "Boolean":
            values[parameter.get("name")] = int(text in ("true", "1"))
        else:
            values[parameter.get("name")] = float(text)
    return values


vehicle = {v.name: v for v in read_model_description(str(FMU_DIR / "ReferenceVehicle.fmu")).modelVariables}
parameters = ParameterSet(name="car")
car = ssv_values(CAR, vehicle)
for name, value in car.items():
    parameters.parameters.append(Parameter(name=f"ReferenceVehicle.{name}", type="Real", value=value))
for name in BASIC_DATA:
    parameters.parameters.append(Parameter(name=f"VehicleStateEstimator.{name}", type="Real",
                                           value=car[name]))
for axle in ("front", "rear"):
    parameters.parameters.append(Parameter(name=f"VehicleStateEstimator.wheel_radius_{axle}",
                                           type="Real", value=car.get("wheel_radius", 0.3)))
# The system's driver inputs: a 2 deg road-wheel step held from the start, as its own binding says.
for component in ("ReferenceVehicle", "VehicleStateEstimator"):
    parameters.parameters.append(Parameter(name=f"{component}.steering_angle", type="Real",
                                           value=np.radians(2.0)))

result = simulate_ssp(str(FMU_DIR / "VehicleWithEstimator.ssp"), start_time=0.0, stop_time=3.0,
                      step_size=0.001, parameter_set=parameters)
truth = result["ReferenceVehicle.sideslip"]
estimate = result["VehicleStateEstimator.sideslip_est"]
late = result["time"] > 1.0
print(f"BMW 320i on the full vehicle: "
      f"sideslip {np.degrees(truth[-1]):.3f} deg, estimate {np.degrees(estimate[-1]):.3f} deg, "
      f"RMSE after 1 s {np.degrees(np.sqrt(np.mean((estimate - truth)[late] ** 2))):.3f} deg")
