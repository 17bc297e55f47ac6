//! One discrete step (and the exact Jacobians) of models A, B (full and 3-state) and C, in ns.
//!
//! Run with:
//! `CARGO_TARGET_DIR=target/models cargo bench -p vehicle-models --bench model_step`
//!
//! Target: model A at most 150 ns per step, release build, on the 2-core CI machine.

use std::hint::black_box;

use vehicle_models::driver_input::DriverInputVector;
use vehicle_models::{Integrator, SingleTrackHsri};

fn main() {
    divan::main();
}

/// Model A in a moderate left turn (the state of the moderate seed ramp at its end).
fn cornering_point() -> (
    SingleTrackHsri,
    vehicle_models::SingleTrackState,
    DriverInputVector,
) {
    let model = SingleTrackHsri::default();
    let x = vehicle_models::SingleTrackState::new(17.49, -0.031, 0.2086, 58.3, 58.3);
    let u = DriverInputVector::new(0.035, 0.0, 0.0);
    (model, x, u)
}

#[divan::bench]
fn model_a_step_seed_scheme(bencher: divan::Bencher) {
    let (model, x, u) = cornering_point();
    bencher.bench_local(|| {
        model.step(
            black_box(&x),
            black_box(&u),
            1e-3,
            Integrator::SemiImplicitEuler,
        )
    });
}

#[divan::bench]
fn model_a_step_rk4(bencher: divan::Bencher) {
    let (model, x, u) = cornering_point();
    bencher.bench_local(|| model.step(black_box(&x), black_box(&u), 1e-3, Integrator::RungeKutta4));
}

#[divan::bench]
fn model_a_measurement(bencher: divan::Bencher) {
    let (model, x, u) = cornering_point();
    bencher.bench_local(|| model.measurement(black_box(&x), black_box(&u)));
}

#[divan::bench]
fn model_a_step_jacobians(bencher: divan::Bencher) {
    let (model, x, u) = cornering_point();
    bencher.bench_local(|| {
        model.step_jacobians(
            black_box(&x),
            black_box(&u),
            1e-3,
            Integrator::SemiImplicitEuler,
        )
    });
}

#[divan::bench]
fn model_b_step_seed_scheme(bencher: divan::Bencher) {
    let model = vehicle_models::TwoTrackMagicFormula::default();
    let x = vehicle_models::TwoTrackState::from([17.48, -0.041, 0.2058, 58.2, 58.5, 58.0, 58.6]);
    let u = DriverInputVector::new(0.035, 0.0, 0.0);
    bencher.bench_local(|| {
        model.step(
            black_box(&x),
            black_box(&u),
            1e-3,
            Integrator::SemiImplicitEuler,
        )
    });
}

#[divan::bench]
fn model_b_three_state_step(bencher: divan::Bencher) {
    use vehicle_models::two_track_lateral::{TwoTrackLateralInput, TwoTrackLateralState};
    let model = vehicle_models::TwoTrackLateralMagicFormula::default();
    let x = TwoTrackLateralState::new(-0.0024, 0.2058, 3.6);
    let u = TwoTrackLateralInput::new(0.035, 17.48, 0.0);
    bencher.bench_local(|| {
        model.step(
            black_box(&x),
            black_box(&u),
            1e-3,
            Integrator::SemiImplicitEuler,
        )
    });
}

#[divan::bench]
fn model_b_three_state_step_jacobians(bencher: divan::Bencher) {
    use vehicle_models::two_track_lateral::{TwoTrackLateralInput, TwoTrackLateralState};
    let model = vehicle_models::TwoTrackLateralMagicFormula::default();
    let x = TwoTrackLateralState::new(-0.0024, 0.2058, 3.6);
    let u = TwoTrackLateralInput::new(0.035, 17.48, 0.0);
    bencher.bench_local(|| {
        model.step_jacobians(
            black_box(&x),
            black_box(&u),
            1e-3,
            Integrator::SemiImplicitEuler,
        )
    });
}

#[divan::bench]
fn model_c_step_rk4(bencher: divan::Bencher) {
    use vehicle_models::rear_axle::{RearAxleInput, RearAxleState};
    let model = vehicle_models::RearAxleModel::default();
    let x = RearAxleState::new(0.2285, -0.4463, 0.1199);
    let u = RearAxleInput::new(0.1, 0.02, 15.0);
    bencher.bench_local(|| model.step(black_box(&x), black_box(&u), 0.01, Integrator::RungeKutta4));
}
