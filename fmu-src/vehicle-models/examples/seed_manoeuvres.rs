//! Runs model A (and model B) on the seed-000 manoeuvres (SPEC §7: moderate ramp, high ramp,
//! high ramp with braking, 2° step steer; noise off, T = 1 ms) and prints the final values.
//!
//! `cargo run --release -p vehicle-models --example seed_manoeuvres`

use manoeuvres::seed000::{SeedManoeuvre, SEED_INITIAL_SPEED, SEED_MANOEUVRE_DURATION};
use vehicle_models::{Integrator, SingleTrackHsri, TwoTrackMagicFormula, VehicleTruth};

/// Sample time of the reference runs, s (000: ch. 7, T = 0.001 s).
const SAMPLE_TIME: f64 = 1e-3;

fn run_model_a(manoeuvre: SeedManoeuvre) -> VehicleTruth {
    let model = SingleTrackHsri::default();
    let mut state = model.straight_rolling_state(SEED_INITIAL_SPEED);
    let steps = (SEED_MANOEUVRE_DURATION / SAMPLE_TIME).round() as usize;
    for k in 0..steps {
        let input = manoeuvre.input_at(k as f64 * SAMPLE_TIME).to_vector();
        state = model.step(&state, &input, SAMPLE_TIME, Integrator::SemiImplicitEuler);
    }
    let input = manoeuvre.input_at(SEED_MANOEUVRE_DURATION).to_vector();
    model.truth(&state, &input)
}

fn run_model_b(manoeuvre: SeedManoeuvre) -> VehicleTruth {
    let model = TwoTrackMagicFormula::default();
    let mut state = model.straight_rolling_state(SEED_INITIAL_SPEED);
    let steps = (SEED_MANOEUVRE_DURATION / SAMPLE_TIME).round() as usize;
    for k in 0..steps {
        let input = manoeuvre.input_at(k as f64 * SAMPLE_TIME).to_vector();
        state = model.step(&state, &input, SAMPLE_TIME, Integrator::SemiImplicitEuler);
    }
    let input = manoeuvre.input_at(SEED_MANOEUVRE_DURATION).to_vector();
    model.truth(&state, &input)
}

fn print_row(model: &str, manoeuvre: SeedManoeuvre, t: &VehicleTruth) {
    println!(
        "{:<6} {:<20} {:>7.3} {:>7.3} {:>7.3} {:>8.4} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>9.5}",
        model,
        manoeuvre.name(),
        t.lateral_acceleration,
        t.longitudinal_acceleration,
        t.longitudinal_velocity,
        t.lateral_velocity,
        t.sideslip.to_degrees(),
        t.yaw_rate.to_degrees(),
        t.slip_angle_front.to_degrees(),
        t.slip_angle_rear.to_degrees(),
        t.slip_front,
    );
}

fn main() {
    println!(
        "Seed-000 manoeuvres, T = {} ms, noise off, values at t = {} s",
        SAMPLE_TIME * 1e3,
        SEED_MANOEUVRE_DURATION
    );
    println!(
        "{:<6} {:<20} {:>7} {:>7} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9}",
        "model", "manoeuvre", "ay", "ax", "vx", "vy", "beta", "r", "alphaF", "alphaR", "sF"
    );
    println!(
        "{:<6} {:<20} {:>7} {:>7} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9}",
        "", "", "m/s2", "m/s2", "m/s", "m/s", "deg", "deg/s", "deg", "deg", "-"
    );
    let mut moderate_ay = f64::NAN;
    let mut braking_ax = f64::NAN;
    for manoeuvre in SeedManoeuvre::ALL {
        let a = run_model_a(manoeuvre);
        print_row("A", manoeuvre, &a);
        print_row("B", manoeuvre, &run_model_b(manoeuvre));
        match manoeuvre {
            SeedManoeuvre::ModerateRamp => moderate_ay = a.lateral_acceleration,
            SeedManoeuvre::HighRampBraking => braking_ax = a.longitudinal_acceleration,
            _ => {}
        }
    }
    println!();
    println!("A = single-track + HSRI (seed 000), B = two-track + Magic Formula (seed 001 car matched to A)");
    println!(
        "check: model A moderate ramp ay = {moderate_ay:.3} m/s2 (seed 000 fig. 7.4: about 3.7; SPEC: 3.65)"
    );
    println!(
        "check: model A braking ax = {braking_ax:.3} m/s2 (seed 000 fig. 7.11 text: about -4 with M_B = -2000 N m)"
    );
}
