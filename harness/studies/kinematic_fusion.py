"""Does a kinematic-dynamic combination of sideslip estimates win?

The published state of the art blends a kinematic sideslip, integrated from the sensors alone,
with the model-based (dynamic) estimate, trusting the kinematics where the tyres saturate and the
model where they are linear (Piyabongkarn, Rajamani, Grogg, Lew, "Development and experimental
evaluation of a slip angle estimator for vehicle stability control", IEEE TCST 17(1), 2009;
Selmanaj, Corno, Panzani, Savaresi, "Vehicle sideslip estimation: a kinematic based approach",
Control Engineering Practice 67, 2017). This study measures that idea on the shipped FMUs before
anything of it is built into the estimator.

What runs: `target/release/harness run` on scenarios this script writes to OUT/scenarios: the
ReferenceVehicle's full vehicle (model 3) with a car file, series sensor noise at 10 ms as in the
mismatch campaigns (harness/scenarios/campaigns/base.toml), the EKF on model A and on model B
at their defaults told the car's basic data (the campaigns' rule, harness/studies/src/campaigns/
car.rs: mass, yaw inertia, axle distances, wheel inertias, brake split and radius copied, static
wheel loads m g l / (2 (lF + lR))). Two accelerometers:

- ideal: the campaigns' sensors (noise only; `gravity_in_accelerometers` off);
- real: gravity through the body's roll (a body-fixed sensor, as in most ESC units) and a bias of
  0.1 m/s^2 on ay and 0.002 rad/s on the yaw rate (the ReferenceVehicle's `bias_*` parameters).

The combination (offline, on the recorded signals): a Kalman filter on x = [sideslip, ay bias]
that predicts with the kinematics beta' = (ay_meas - b - g sin(k ay_meas)) / vx_meas - r_meas
(small-angle form of vy' = ay - r vx; k the roll gradient, rad per m/s^2, 0 when unknown) and
updates with the dynamic filter's published sideslip as a pseudo-measurement whose variance is
its own sideslip_std^2 plus a model-error term (0.01 (1 + 10 (ay/g)^2))^2 rad^2 that grows with
tyre utilisation, so the model is trusted in the linear range and the kinematics near the limit.
With roll compensation the roll gradient is the run's own (least squares of the true roll angle
on the measured ay): the best a user who knows the car's roll gradient could do.

    .venv/bin/python harness/studies/kinematic_fusion.py [--out out/kinematic_fusion]

prints the table (sideslip RMSE in deg; time-averaged NEES) and writes it to OUT/fusion.md.

Measured on the estimator's defaults, sideslip RMSE in deg:

- With the ideal accelerometer the combination wins everywhere, by a lot: BMW slow ramp EKF_A
  1.69 -> 0.29 (NEES 700 -> 1.6), EKF_B 0.99 -> 0.49; lane changes 0.43-0.47 -> 0.08-0.11 (NEES
  0.3-0.5). But that sensor is not a car's.
- With the real accelerometer and no roll compensation the combination loses everywhere and badly
  (slow ramps 3.7-4.0, against zero baselines of 1.3-1.7): the integrated roll gravity and bias.
- With the real accelerometer and the car's own roll gradient it wins on the lane changes (EKF_B
  0.22 -> 0.15, EKF_A 0.27 -> 0.24 and 0.24 -> 0.22, NEES 0.9-1.7) and loses on the slow ramps
  (EKF_B 0.16 -> 0.77-0.79; the ay bias is not observable while the tyres saturate, for 10 s).
- The dynamic filters themselves are better with the real accelerometer than with the ideal one
  on three of the four runs (EKF_B slow ramps 0.99/0.74 -> 0.16/0.16): neither model has roll,
  and the roll gravity's extra ay (about 12 % at the limit) offsets their missing load transfer.
  That is a cancellation of two model errors, not a property to rely on; it also says that the
  campaigns' ideal accelerometer changes the verdicts.

So a kinematic-dynamic combination is not built into the FMU: it wins only with a roll-compensated
(or roll-free) accelerometer, which needs the car's roll gradient and more than the basic data
the campaigns give a user (campaigns/car.rs), and even then not on a long drive at the limit.
"""
import argparse
import csv
import math
import pathlib
import re
import subprocess
import xml.etree.ElementTree as ET

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
GRAVITY = 9.81
CARS = ["bmw_320i", "ford_escort"]
FEEDBACK = (
    'feedback = { longitudinal_velocity = "vehicle.vx", '
    'lateral_velocity = "vehicle.vy", yaw_rate = "vehicle.yaw_rate" }'
)
MANOEUVRES = {
    "slow_ramp": f'library = "fmvss126_slowly_increasing_steer"\n{FEEDBACK}',
    "iso3888_2": f'library = "seed001_moose_test"\n{FEEDBACK}',
}
SENSORS = (
    "seed = 11, noise = true, noise_std_yaw_rate_meas = 0.0035, noise_std_ay_meas = 0.1, "
    "noise_std_ax_meas = 0.1, noise_std_omega_front_meas = 0.1, noise_std_omega_rear_meas = 0.1, "
    "noise_std_vx_meas = 0.05, sensor_sample_period = 0.01"
)
ACCELEROMETERS = {
    "ideal": "",
    "real": ", gravity_in_accelerometers = true, bias_ay_meas = 0.1, bias_yaw_rate_meas = 0.002",
}
ESTIMATORS = {"EKF_A": 1, "EKF_B": 2}
# The campaigns' rule is written once, in Rust: its list of copied parameters is read from there
# (the static wheel loads below follow its formula, 000: after table 5.2).
CAR_RULE = ROOT / "harness/studies/src/campaigns/car.rs"
# The combination's tuning (module text).
MODEL_ERROR_STD = 0.01
UTILISATION_GAIN = 10.0
AY_NOISE_STD = 0.1
YAW_RATE_NOISE_STD = 0.0035
BIAS_RANDOM_WALK = 0.01


def copied_parameters():
    """`COPIED_PARAMETERS` of the campaigns' car rule (harness/studies/src/campaigns/car.rs)."""
    found = re.search(r"COPIED_PARAMETERS: \[&str; \d+\] = \[(.*?)\];", CAR_RULE.read_text(), re.S)
    if not found:
        raise SystemExit(f"{CAR_RULE}: expected the array COPIED_PARAMETERS of the campaigns' car rule")
    return re.findall(r'"([a-z_]+)"', found.group(1))


def car_values(car):
    """The estimator's parameters for a car file, by the campaigns' rule (module text)."""
    path = ROOT / "fmu-src/reference-vehicle/cars" / f"{car}.ssv"
    reals = {}
    for parameter in ET.parse(path).getroot().iter():
        if parameter.tag.endswith("Parameter"):
            for value in parameter:
                if value.tag.endswith("Real"):
                    reals[parameter.get("name")] = float(value.get("value"))
    values = {name: reals[name] for name in copied_parameters()}
    for axle in ["front", "rear"]:
        values[f"wheel_radius_{axle}"] = reals.get(f"wheel_radius_{axle}", reals["wheel_radius"])
    per_wheel = reals["mass"] * GRAVITY / (2 * (reals["cog_to_front_axle"] + reals["cog_to_rear_axle"]))
    values["wheel_load_front"] = per_wheel * reals["cog_to_rear_axle"]
    values["wheel_load_rear"] = per_wheel * reals["cog_to_front_axle"]
    return values


def scenario(name, car, manoeuvre, accelerometer, fmu_dir):
    car_file = ROOT / "fmu-src/reference-vehicle/cars" / f"{car}.ssv"
    data = ", ".join(f"{k} = {v!r}" for k, v in car_values(car).items())
    parts = [
        f'name = "{name}"\ndescription = "kinematic-dynamic study"\nstep = 0.01\n',
        f"[manoeuvre]\n{MANOEUVRES[manoeuvre]}\n",
        f'[[fmu]]\nname = "vehicle"\npath = "{fmu_dir}/ReferenceVehicle.fmu"\n'
        f'parameter_files = ["{car_file}"]\n'
        f"parameters = {{ {SENSORS}{ACCELEROMETERS[accelerometer]} }}\n",
    ]
    for instance, model in ESTIMATORS.items():
        parts.append(
            f'[[fmu]]\nname = "{instance}"\npath = "{fmu_dir}/VehicleStateEstimator.fmu"\n'
            f"parameters = {{ estimator = 2, model = {model}, sample_time = 0.01, {data} }}\n"
            f'[[connection]]\nfrom = "vehicle"\nto = "{instance}"\n'
        )
    for signal, targets in [
        ("steering_angle", '"*.steering_angle"'),
        ("drive_torque", '"vehicle.drive_torque"'),
        ("brake_torque", '"vehicle.brake_torque"'),
        ("initial_speed", '"vehicle.vx0"'),
    ]:
        parts.append(f'[[input]]\nsignal = "{signal}"\nto = [{targets}]\n')
    parts.append('[record]\nvariables = ["vehicle.*", "*.sideslip_est", "*.sideslip_std"]\n')
    return "\n".join(parts)


def combine(run, dynamic, roll_gradient):
    """The combination of the module text on one run; returns (sideslip, variance) arrays."""
    step = run["time"][1] - run["time"][0]
    x, p = np.array([dynamic["est"][0], 0.0]), np.diag([1e-4, 0.3**2])
    estimate, variance = [], []
    for k in range(len(run["time"])):
        utilisation = abs(run["ay_meas"][k]) / GRAVITY
        model_error = MODEL_ERROR_STD * (1.0 + UTILISATION_GAIN * utilisation**2)
        h = np.array([1.0, 0.0])
        gain = p @ h / (h @ p @ h + dynamic["std"][k] ** 2 + model_error**2)
        x = x + gain * (dynamic["est"][k] - x[0])
        p = p - np.outer(gain, h @ p)
        estimate.append(x[0])
        variance.append(p[0, 0])
        speed = max(run["vx_meas"][k], 2.0)
        ay = run["ay_meas"][k] - GRAVITY * math.sin(roll_gradient * run["ay_meas"][k])
        transition = np.array([[1.0, -step / speed], [0.0, 1.0]])
        x = np.array([x[0] + step * ((ay - x[1]) / speed - run["yaw_rate_meas"][k]), x[1]])
        noise = np.diag(
            [step**2 * ((AY_NOISE_STD / speed) ** 2 + YAW_RATE_NOISE_STD**2), (step * BIAS_RANDOM_WALK) ** 2]
        )
        p = transition @ p @ transition.T + noise
    return np.array(estimate), np.array(variance)


def scores(error, variance, moving):
    rmse = math.degrees(math.sqrt(np.mean(error[moving] ** 2)))
    return rmse, float(np.mean((error**2 / variance)[moving]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/kinematic_fusion", type=pathlib.Path)
    parser.add_argument("--harness", default=ROOT / "target/release/harness", type=pathlib.Path)
    parser.add_argument("--fmu-dir", default=ROOT / "target/fmu", type=pathlib.Path)
    arguments = parser.parse_args()
    out, harness = arguments.out, arguments.harness
    for needed in [harness, arguments.fmu_dir / "VehicleStateEstimator.fmu"]:
        if not needed.is_file():
            raise SystemExit(
                f"{needed} does not exist: build and package first (`cargo run --release -p packaging`, "
                f"`cargo build --release -p harness`), or name it with --harness / --fmu-dir"
            )
    (out / "scenarios").mkdir(parents=True, exist_ok=True)
    lines = [
        "| car | manoeuvre | accelerometer | zero baseline | estimator | dynamic: RMSE (NEES) "
        "| combined, roll not compensated | combined, roll compensated with the car's gradient |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for car in CARS:
        for manoeuvre in MANOEUVRES:
            for accelerometer in ACCELEROMETERS:
                name = f"fusion_{car}_{manoeuvre}_{accelerometer}"
                path = out / "scenarios" / f"{name}.toml"
                path.write_text(scenario(name, car, manoeuvre, accelerometer, arguments.fmu_dir))
                subprocess.run(
                    [harness, "run", path, "--out", out / "runs", "--no-plots"],
                    check=True,
                    stdout=subprocess.DEVNULL,
                )
                with open(out / "runs" / name / f"{name}.csv") as f:
                    rows = list(csv.DictReader(f))
                column = lambda key: np.array([float(r[key]) for r in rows])  # noqa: E731
                run = {
                    "time": column("time"),
                    "ay_meas": column("vehicle.ay_meas"),
                    "vx_meas": column("vehicle.vx_meas"),
                    "yaw_rate_meas": column("vehicle.yaw_rate_meas"),
                }
                truth, moving = column("vehicle.sideslip"), column("vehicle.vx") > 2.0
                ay, roll = column("vehicle.ay"), column("vehicle.roll_angle")
                roll_gradient = float(ay @ roll / (ay @ ay))
                zero = math.degrees(math.sqrt(np.mean(truth[moving] ** 2)))
                for instance in ESTIMATORS:
                    dynamic = {"est": column(f"{instance}.sideslip_est"), "std": column(f"{instance}.sideslip_std")}
                    cells = ["%.3f (%.0f)" % scores(dynamic["est"] - truth, dynamic["std"] ** 2, moving)]
                    # Roll compensation only where the accelerometer feels the roll.
                    gradients = [0.0] + ([roll_gradient] if accelerometer == "real" else [])
                    for gradient in gradients:
                        estimate, variance = combine(run, dynamic, gradient)
                        cells.append("%.3f (%.1f)" % scores(estimate - truth, variance, moving))
                    cells += ["-"] * (3 - len(cells))
                    lines.append(
                        f"| {car} | {manoeuvre} | {accelerometer} | {zero:.3f} | {instance} | " + " | ".join(cells) + " |"
                    )
    table = "\n".join(lines) + "\n"
    tmp = out / "fusion.md.tmp"
    tmp.write_text(table)
    tmp.rename(out / "fusion.md")
    print(table)


if __name__ == "__main__":
    main()
