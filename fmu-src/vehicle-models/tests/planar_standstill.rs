//! Models A and B (the ReferenceVehicle's models 1 and 2) brake to a stop, stand under the brake
//! and pull away again, with either integrator. The seed wrote the brake as a torque that keeps
//! acting at standstill: held, it spun the wheels backwards (to about -2100 rad/s) and the tyres
//! dragged the car back to about -1 m/s. The brake is friction now (`vehicle_models::brake`).

use vehicle_models::driver_input::DriverInput;
use vehicle_models::{Integrator, ReferenceModelKind, ReferenceVehicle, ReferenceVehicleParams};

const STEP: f64 = 1e-3;

fn vehicle(kind: ReferenceModelKind, integrator: Integrator, speed: f64) -> ReferenceVehicle {
    ReferenceVehicle::new(
        &ReferenceVehicleParams {
            model: kind,
            integrator,
            ..Default::default()
        },
        speed,
    )
}

/// Runs `seconds` with the input `input`, calling `check(t, state)` after every step.
fn drive(
    vehicle: &mut ReferenceVehicle,
    seconds: f64,
    input: DriverInput,
    mut check: impl FnMut(f64, &[f64]),
) {
    let u = input.to_vector();
    for k in 0..(seconds / STEP).round() as usize {
        vehicle.step(&u, STEP).expect("a finite step");
        check(k as f64 * STEP, vehicle.state());
    }
}

fn brake(torque: f64, steering_angle: f64) -> DriverInput {
    DriverInput {
        steering_angle,
        drive_torque: 0.0,
        brake_torque: torque,
    }
}

fn every_model() -> Vec<(ReferenceModelKind, Integrator)> {
    let mut all = Vec::new();
    for kind in [
        ReferenceModelKind::SingleTrack,
        ReferenceModelKind::TwoTrack,
    ] {
        for integrator in [Integrator::SemiImplicitEuler, Integrator::RungeKutta4] {
            all.push((kind, integrator));
        }
    }
    all
}

/// The largest |wheel speed| of a state (model A: 2 wheels, model B: 4).
fn largest_wheel_speed(state: &[f64]) -> f64 {
    state[3..].iter().fold(0.0, |a, w| a.max(w.abs()))
}

#[test]
fn braking_to_a_stop_and_holding_ten_seconds_never_rolls_back() {
    for (kind, integrator) in every_model() {
        for steering in [0.0, 0.2] {
            let mut car = vehicle(kind, integrator, 10.0);
            let mut slowest = f64::INFINITY;
            drive(&mut car, 6.0, brake(2000.0, steering), |t, x| {
                slowest = slowest.min(x[0]);
                assert!(
                    x.iter().all(|v| v.is_finite()),
                    "{kind:?} {integrator:?} t={t}"
                );
            });
            assert!(
                slowest > -0.01,
                "{kind:?} {integrator:?}: rolled back to {slowest} m/s"
            );
            assert!(
                car.state()[0].abs() < 0.01,
                "{kind:?} {integrator:?} δ={steering}: not stopped: {:?}",
                car.state()
            );
            drive(&mut car, 10.0, brake(2000.0, steering), |t, x| {
                assert!(
                    x[0].abs() < 0.01 && x[1].abs() < 0.01 && x[2].abs() < 0.01,
                    "{kind:?} {integrator:?} δ={steering}: moves at t = {t}: {x:?}"
                );
                assert!(
                    largest_wheel_speed(x) < 0.05,
                    "{kind:?} {integrator:?} δ={steering}: wheels turn at t = {t}: {x:?}"
                );
            });
        }
    }
}

#[test]
fn a_car_held_by_the_brake_pulls_away_when_it_is_released() {
    for (kind, integrator) in every_model() {
        let mut car = vehicle(kind, integrator, 8.0);
        drive(&mut car, 5.0, brake(2000.0, 0.0), |_, _| {});
        assert!(car.state()[0].abs() < 0.01, "{kind:?} {integrator:?}");
        let pull = DriverInput {
            steering_angle: 0.1,
            drive_torque: 600.0,
            brake_torque: 0.0,
        };
        drive(&mut car, 3.0, pull, |t, x| {
            assert!(
                x.iter().all(|v| v.is_finite()),
                "{kind:?} {integrator:?} t={t}"
            );
        });
        let x = car.state();
        assert!(
            (2.0..8.0).contains(&x[0]),
            "{kind:?} {integrator:?}: after 3 s of drive torque: {x:?}"
        );
        // the wheels roll with the car (small slip), forwards
        assert!(x[3] * 0.3 > 0.9 * x[0], "{kind:?} {integrator:?}: {x:?}");
    }
}

#[test]
fn a_drive_torque_below_the_brake_does_not_move_a_standing_car() {
    for (kind, integrator) in every_model() {
        let mut car = vehicle(kind, integrator, 0.0);
        let input = DriverInput {
            steering_angle: 0.0,
            drive_torque: 500.0,
            // 60 % front: 1200 N·m against 500 N·m of drive
            brake_torque: 2000.0,
        };
        drive(&mut car, 3.0, input, |t, x| {
            assert!(
                x[0].abs() < 1e-3 && largest_wheel_speed(x) < 0.01,
                "{kind:?} {integrator:?}: t = {t}: {x:?}"
            );
        });
    }
}
