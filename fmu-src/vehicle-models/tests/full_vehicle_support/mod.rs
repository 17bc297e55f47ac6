//! Shared by the full-vehicle tests: the car files and small driving helpers.
#![allow(dead_code)]

use std::path::PathBuf;

use vehicle_models::full_vehicle::{
    CarData, FullVehicle, FullVehicleInput, FullVehicleParams, FullVehicleTruth,
};

/// The FMU's communication step, also the model's internal step.
pub const STEP: f64 = 1e-3;

/// The car files shipped in `cars/`.
pub const CAR_FILES: [&str; 4] = [
    "seed_car.toml",
    "ford_escort.toml",
    "bmw_320i.toml",
    "vw_vanagon.toml",
];

/// A car file from `cars/`.
pub fn car(file: &str) -> CarData {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("cars")
        .join(file);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    toml::from_str(&text).unwrap_or_else(|e| panic!("{path:?}: {e}"))
}

/// Every car's parameters with its file name.
pub fn every_car() -> Vec<(&'static str, FullVehicleParams)> {
    CAR_FILES
        .iter()
        .map(|file| (*file, car(file).vehicle))
        .collect()
}

/// Runs `seconds` with the input of `input(t, truth before the step)`, calling `each(t, truth)` after every step;
/// panics on a non-finite state.
pub fn drive(
    vehicle: &mut FullVehicle,
    seconds: f64,
    mut input: impl FnMut(f64, &FullVehicleTruth) -> FullVehicleInput,
    mut each: impl FnMut(f64, &FullVehicleTruth),
) {
    let steps = (seconds / STEP).round() as usize;
    for k in 0..steps {
        let t = k as f64 * STEP;
        let input = input(t, vehicle.truth());
        vehicle.step(&input, STEP);
        assert!(
            vehicle.state().iter().all(|x| x.is_finite()),
            "non-finite state at t = {t}: {:?}",
            vehicle.state()
        );
        each(t + STEP, vehicle.truth());
    }
}

/// Drive torque of a proportional speed controller (2 m/s² per m/s of speed error).
pub fn speed_keeping_torque(params: &FullVehicleParams, target: f64, speed: f64) -> f64 {
    2.0 * params.body.mass * params.wheels.radius * (target - speed)
}

/// Input with only a steering angle.
pub fn steer(angle: f64) -> FullVehicleInput {
    FullVehicleInput {
        steering_angle: angle,
        ..FullVehicleInput::default()
    }
}
