//! One 1 ms step of the full vehicle (budget: within 10 µs), in a hard turn of the seed car and
//! of the VW Vanagon, and standing still under the brake.
//!
//! Run with: `cargo bench -p vehicle-models --bench full_vehicle`

use std::hint::black_box;

use vehicle_models::full_vehicle::{CarData, FullVehicle, FullVehicleInput, FullVehicleParams};

fn main() {
    divan::main();
}

const STEP: f64 = 1e-3;

/// The car after two seconds of a 0.04 rad steer at 20 m/s with some drive torque.
fn cornering(params: FullVehicleParams) -> (FullVehicle, FullVehicleInput) {
    let mut vehicle = FullVehicle::rolling(params, 20.0);
    let input = FullVehicleInput {
        steering_angle: 0.04,
        drive_torque: 300.0,
        ..FullVehicleInput::default()
    };
    for _ in 0..2000 {
        vehicle.step(&input, STEP);
    }
    (vehicle, input)
}

fn vanagon() -> FullVehicleParams {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/cars/vw_vanagon.toml");
    let text = std::fs::read_to_string(path).expect("car file");
    let data: CarData = toml::from_str(&text).expect("car file parses");
    data.vehicle
}

#[divan::bench]
fn seed_car_cornering_step(bencher: divan::Bencher) {
    let (vehicle, input) = cornering(FullVehicleParams::default());
    bencher
        .with_inputs(|| vehicle.clone())
        .bench_local_refs(|v| v.step(black_box(&input), black_box(STEP)));
}

#[divan::bench]
fn vanagon_cornering_step(bencher: divan::Bencher) {
    let (vehicle, input) = cornering(vanagon());
    bencher
        .with_inputs(|| vehicle.clone())
        .bench_local_refs(|v| v.step(black_box(&input), black_box(STEP)));
}

#[divan::bench]
fn seed_car_standstill_braked_step(bencher: divan::Bencher) {
    let vehicle = FullVehicle::new(FullVehicleParams::default());
    let input = FullVehicleInput {
        brake_torque: 2000.0,
        ..FullVehicleInput::default()
    };
    bencher
        .with_inputs(|| vehicle.clone())
        .bench_local_refs(|v| v.step(black_box(&input), black_box(STEP)));
}
