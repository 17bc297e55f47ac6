//! The full vehicle at low speed and standstill, its drivetrains and brakes,
//! and energy: brake to a stop and hold, pull away, reverse slowly, no wheel spinning up under a
//! brake, no NaN; every drivetrain moves the car; coasting never gains kinetic energy.

use crate::full_vehicle_support;

use full_vehicle_support::{car, drive, every_car, STEP};
use vehicle_models::full_vehicle::{
    wheel_index, FullVehicle, FullVehicleInput, FullVehicleParams, FullVehicleTruth, WHEELS,
};

fn brake(torque: f64) -> FullVehicleInput {
    FullVehicleInput {
        brake_torque: torque,
        ..FullVehicleInput::default()
    }
}

fn drive_torque(torque: f64) -> FullVehicleInput {
    FullVehicleInput {
        drive_torque: torque,
        ..FullVehicleInput::default()
    }
}

fn largest_wheel_speed(truth: &FullVehicleTruth) -> f64 {
    truth
        .wheel_speed
        .iter()
        .map(|w| w.abs())
        .fold(0.0, f64::max)
}

#[test]
fn braking_to_a_stop_then_holding_ten_seconds_stays_still() {
    for (file, p) in every_car() {
        let mut vehicle = FullVehicle::rolling(p, 15.0);
        drive(&mut vehicle, 6.0, |_, _| brake(2500.0), |_, _| {});
        assert!(
            vehicle.truth().longitudinal_velocity.abs() < 0.01,
            "{file}: not stopped"
        );
        drive(
            &mut vehicle,
            10.0,
            |_, _| brake(2500.0),
            |t, truth| {
                assert!(
                    truth.longitudinal_velocity.abs() < 0.01,
                    "{file}: t = {t}: {truth:?}"
                );
                assert!(
                    largest_wheel_speed(truth) < 1e-9,
                    "{file}: wheels turn: {truth:?}"
                );
            },
        );
    }
}

#[test]
fn standing_without_brake_stays_at_rest() {
    for (file, p) in every_car() {
        let mut vehicle = FullVehicle::new(p);
        drive(
            &mut vehicle,
            5.0,
            |_, _| FullVehicleInput::default(),
            |_, truth| {
                assert_eq!(truth.longitudinal_velocity, 0.0, "{file}");
                assert_eq!(largest_wheel_speed(truth), 0.0, "{file}");
            },
        );
    }
}

#[test]
fn a_brake_stronger_than_the_drive_keeps_the_wheels_still() {
    for (file, p) in every_car() {
        let mut vehicle = FullVehicle::new(p);
        let input = FullVehicleInput {
            drive_torque: 800.0,
            // more than the drive torque on every wheel of every car's brake split
            brake_torque: 3000.0,
            ..FullVehicleInput::default()
        };
        drive(
            &mut vehicle,
            3.0,
            |_, _| input,
            |_, truth| {
                assert_eq!(largest_wheel_speed(truth), 0.0, "{file}: {truth:?}");
                assert_eq!(truth.longitudinal_velocity, 0.0, "{file}");
            },
        );
    }
}

#[test]
fn pulling_away_after_a_stop_and_reversing_slowly() {
    for (file, p) in every_car() {
        let radius = p.wheels.radius;
        let mut vehicle = FullVehicle::rolling(p, 10.0);
        drive(&mut vehicle, 5.0, |_, _| brake(2500.0), |_, _| {});
        drive(&mut vehicle, 3.0, |_, _| drive_torque(600.0), |_, _| {});
        let forward = *vehicle.truth();
        assert!(forward.longitudinal_velocity > 1.0, "{file}: {forward:?}");
        // stop again, then creep backwards with a small torque and let it roll
        drive(&mut vehicle, 5.0, |_, _| brake(2500.0), |_, _| {});
        drive(&mut vehicle, 2.0, |_, _| drive_torque(-150.0), |_, _| {});
        drive(
            &mut vehicle,
            2.0,
            |_, _| FullVehicleInput::default(),
            |_, _| {},
        );
        let backward = *vehicle.truth();
        assert!(
            (-1.0..-0.1).contains(&backward.longitudinal_velocity),
            "{file}: {backward:?}"
        );
        for wheel in 0..WHEELS {
            let rolling = backward.wheel_speed[wheel] * radius;
            assert!(
                (rolling - backward.longitudinal_velocity).abs() < 0.01,
                "{file}: wheel {wheel} {backward:?}"
            );
        }
        // braking while reversing stops the car; it may only rock forwards on its tyres'
        // elasticity (the deflection the braking force built up, a few millimetres), never drive
        // forwards
        let (mut position, mut rearmost) = (0.0_f64, 0.0_f64);
        drive(
            &mut vehicle,
            3.0,
            |_, _| brake(2500.0),
            |_, truth| {
                position += STEP * truth.longitudinal_velocity;
                rearmost = rearmost.min(position);
                assert!(
                    position - rearmost < 0.01,
                    "{file}: rocks {} m",
                    position - rearmost
                );
            },
        );
        assert!(vehicle.truth().longitudinal_velocity.abs() < 0.01);
    }
}

/// Seed car with the given front drive share.
fn seed_with_drive_split(front: f64) -> FullVehicleParams {
    let mut p = FullVehicleParams::default();
    p.drivetrain.drive_split_front = front;
    p
}

#[test]
fn every_drivetrain_moves_the_car_through_its_driven_wheels() {
    use wheel_index::*;
    for (front_share, name) in [(1.0, "front"), (0.0, "rear"), (0.4, "all-wheel")] {
        let mut vehicle = FullVehicle::new(seed_with_drive_split(front_share));
        let mut forces = [0.0; WHEELS];
        drive(
            &mut vehicle,
            2.0,
            |_, _| drive_torque(800.0),
            |_, truth| {
                forces = truth.tyre_force_longitudinal;
            },
        );
        let truth = vehicle.truth();
        assert!(truth.longitudinal_velocity > 0.8, "{name}: {truth:?}");
        // open differential: both wheels of an axle alike
        assert!((forces[FRONT_LEFT] - forces[FRONT_RIGHT]).abs() < 1e-9);
        assert!((forces[REAR_LEFT] - forces[REAR_RIGHT]).abs() < 1e-9);
        let (front, rear) = (forces[FRONT_LEFT], forces[REAR_LEFT]);
        match name {
            "front" => assert!(front > 0.0 && rear <= 0.0, "{name}: {forces:?}"),
            "rear" => assert!(rear > 0.0 && front <= 0.0, "{name}: {forces:?}"),
            _ => assert!(front > 0.0 && rear > 0.0, "{name}: {forces:?}"),
        }
    }
    // the car files' drivetrains
    assert_eq!(
        car("ford_escort.toml").vehicle.drivetrain.drive_split_front,
        1.0
    );
    assert_eq!(
        car("bmw_320i.toml").vehicle.drivetrain.drive_split_front,
        0.0
    );
}

/// Kinetic energy of the car: translation, yaw, roll and wheel spin.
fn kinetic_energy(p: &FullVehicleParams, truth: &FullVehicleTruth) -> f64 {
    let speed_squared = truth.longitudinal_velocity.powi(2) + truth.lateral_velocity.powi(2);
    let wheels: f64 = (0..WHEELS)
        .map(|wheel| {
            let inertia = if wheel < wheel_index::REAR_LEFT {
                p.wheels.inertia_front
            } else {
                p.wheels.inertia_rear
            };
            inertia * truth.wheel_speed[wheel].powi(2)
        })
        .sum();
    0.5 * (p.body.mass * speed_squared
        + p.body.yaw_inertia * truth.yaw_rate.powi(2)
        + p.suspension.roll_inertia * truth.roll_rate.powi(2)
        + wheels)
}

#[test]
fn coasting_never_gains_kinetic_energy() {
    for (file, p) in every_car() {
        let mut vehicle = FullVehicle::rolling(p.clone(), 20.0);
        let start = kinetic_energy(&p, vehicle.truth());
        let mut previous = start;
        let mut steps_checked = 0;
        let steering = |t: f64, _: &_| FullVehicleInput {
            steering_angle: 0.06 * (2.0 * std::f64::consts::PI * 0.4 * t).sin(),
            ..FullVehicleInput::default()
        };
        drive(&mut vehicle, 6.0, steering, |t, truth| {
            let energy = kinetic_energy(&p, truth);
            // the tyres' and springs' stored energy is tiny; allow 1e-6 of the energy per step
            assert!(
                energy <= previous * (1.0 + 1e-6),
                "{file}: t = {t}: {energy} > {previous}"
            );
            previous = energy;
            steps_checked += 1;
        });
        println!(
            "{file}: kinetic energy {:.4} of the start",
            previous / start
        );
        assert!(
            previous < 0.99 * start,
            "{file}: the slip must dissipate energy"
        );
        assert_eq!(steps_checked, (6.0 / STEP).round() as usize);
    }
}

#[test]
fn abs_keeps_the_wheels_turning_under_full_braking() {
    let count_locked = |abs: bool| {
        let mut p = FullVehicleParams::default();
        p.drivetrain.abs.enabled = abs;
        let mut vehicle = FullVehicle::rolling(p, 25.0);
        let mut locked = 0;
        drive(
            &mut vehicle,
            3.0,
            |_, _| brake(8000.0),
            |_, truth| {
                if truth.longitudinal_velocity > 5.0 && truth.wheel_speed[0] == 0.0 {
                    locked += 1;
                }
            },
        );
        locked
    };
    let without = count_locked(false);
    let with = count_locked(true);
    println!(
        "steps with a locked front-left wheel above 5 m/s: without ABS {without}, with {with}"
    );
    assert!(without > 500 && with < 50, "{without} {with}");
}

/// A small deterministic pseudo-random sequence in [0, 1) (64-bit LCG, Knuth's MMIX constants).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn random_abuse_never_produces_nan_or_a_negative_load() {
    // every 0.2 s a new input: any steer up to full lock, drive and brake torques of either size,
    // friction from ice to dry; 40 s per car, starting at rest
    for (file, p) in every_car() {
        let mut random = Lcg(0x5eed);
        let mut vehicle = FullVehicle::new(p);
        let mut input = FullVehicleInput::default();
        drive(
            &mut vehicle,
            40.0,
            |t, _| {
                if ((t / STEP).round() as usize).is_multiple_of(200) {
                    input = FullVehicleInput {
                        steering_angle: 1.0 * (random.next() - 0.5),
                        drive_torque: 4000.0 * (random.next() - 0.4),
                        brake_torque: if random.next() < 0.3 {
                            8000.0 * random.next()
                        } else {
                            0.0
                        },
                        road_friction: 0.05 + 1.1 * random.next(),
                        ..FullVehicleInput::default()
                    };
                }
                input
            },
            |t, truth| {
                assert!(
                    truth.wheel_load.iter().all(|f| *f >= 0.0),
                    "{file}: t = {t}"
                );
                assert!(
                    truth.longitudinal_velocity.abs() < 80.0,
                    "{file}: t = {t}: {truth:?}"
                );
            },
        );
    }
}

/// On a grade or a bank gravity pulls the car along the road plane: rolling freely up a 5 %
/// grade it slows at g sin γ m / (m + ΣI_w/r²) (the wheels' spin is slowed too), the brake holds
/// it on a 10 % grade, and on a bank it drifts to the lower side.
#[test]
fn gravity_pulls_along_a_graded_or_banked_road() {
    let grade = 0.05_f64.atan();
    let p = FullVehicleParams::default();
    let wheel_inertia = 2.0 * (p.wheels.inertia_front + p.wheels.inertia_rear);
    let effective_mass = p.body.mass + wheel_inertia / p.wheels.radius.powi(2);
    let expected = vehicle_models::GRAVITY * grade.sin() * p.body.mass / effective_mass;
    let mut vehicle = FullVehicle::rolling(p, 15.0);
    let uphill = FullVehicleInput {
        road_grade_angle: grade,
        ..FullVehicleInput::default()
    };
    drive(&mut vehicle, 2.0, |_, _| uphill, |_, _| {});
    let slowing = (15.0 - vehicle.truth().longitudinal_velocity) / 2.0;
    assert!(
        (slowing / expected - 1.0).abs() < 0.02,
        "slows at {slowing} m/s², expected {expected}"
    );
    assert!((vehicle.truth().longitudinal_acceleration + slowing).abs() < 0.05);

    let mut parked = FullVehicle::new(FullVehicleParams::default());
    let held = FullVehicleInput {
        road_grade_angle: 0.1_f64.atan(),
        brake_torque: 3000.0,
        ..FullVehicleInput::default()
    };
    drive(&mut parked, 5.0, |_, _| held, |_, _| {});
    assert!(parked.truth().longitudinal_velocity.abs() < 1e-3);

    let mut banked = FullVehicle::rolling(FullVehicleParams::default(), 15.0);
    let bank = FullVehicleInput {
        road_bank_angle: 0.05,
        ..FullVehicleInput::default()
    };
    drive(&mut banked, 2.0, |_, _| bank, |_, _| {});
    assert!(
        banked.truth().lateral_velocity < -0.01,
        "{:?}",
        banked.truth()
    );
}

/// A car braked to a stop springs back on its tyres: the braking force it stopped with is held
/// in the tyres' longitudinal deflection (the relaxation states are springs at standstill), and
/// with the car at rest that force pushes it back until the deflection is gone, as a real car
/// rocks back on its tyres and suspension. That is millimetres at a few cm/s, then the car
/// stands: no creep.
#[test]
fn after_a_stop_the_car_rocks_back_millimetres_and_stands() {
    for (file, p) in every_car() {
        for steering in [0.0, 0.2] {
            let mut vehicle = FullVehicle::rolling(p.clone(), 10.0);
            let input = FullVehicleInput {
                steering_angle: steering,
                brake_torque: 2000.0,
                ..FullVehicleInput::default()
            };
            let (mut position, mut stopped_at, mut farthest_back) = (0.0, None, 0.0f64);
            let mut standing_since = None;
            drive(
                &mut vehicle,
                8.0,
                |_, _| input,
                |t, truth| {
                    position += truth.longitudinal_velocity * STEP;
                    if stopped_at.is_none() && truth.longitudinal_velocity <= 0.0 {
                        stopped_at = Some(position);
                    }
                    if let Some(stop) = stopped_at {
                        farthest_back = farthest_back.max(stop - position);
                        if truth.longitudinal_velocity.abs() > 1e-3 {
                            standing_since = None;
                        } else if standing_since.is_none() {
                            standing_since = Some(t);
                        }
                    }
                },
            );
            assert!(stopped_at.is_some(), "{file}: did not stop");
            assert!(
                farthest_back < 0.005,
                "{file} δ={steering}: rolled back {farthest_back} m"
            );
            let since = standing_since.expect("standing at the end");
            assert!(
                since < 6.0,
                "{file} δ={steering}: still moving at {since} s"
            );
        }
    }
}
