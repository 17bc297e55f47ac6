//! Open-loop responses of the full vehicle against textbook behaviour:
//! understeer gradient, step-steer response time, roll gradient, mirror symmetry, road friction,
//! lifted wheels.

use crate::full_vehicle_support;

use full_vehicle_support::{drive, every_car, speed_keeping_torque, steer, STEP};
use vehicle_models::full_vehicle::{
    wheel_index, FullVehicle, FullVehicleInput, FullVehicleParams, GRAVITY,
};
use vehicle_models::tyre::combined_slip::CombinedSlipTyre;

const SPEED: f64 = 20.0;

/// Linear single-track understeer gradient `K = m/L (l_r/C_F − l_f/C_R)`, rad per m/s², with
/// the axle cornering stiffnesses of both tyres at their static loads (e.g. Mitschke &
/// Wallentowitz, "Dynamik der Kraftfahrzeuge", or Gillespie, "Fundamentals of Vehicle
/// Dynamics", ch. 6: `δ = L/R + K a_y`).
fn linear_understeer_gradient(p: &FullVehicleParams) -> f64 {
    let (front_load, rear_load) = p.static_wheel_loads();
    let front = 2.0 * CombinedSlipTyre::new(p.tyre_front.clone()).cornering_stiffness(front_load);
    let rear = 2.0 * CombinedSlipTyre::new(p.tyre_rear.clone()).cornering_stiffness(rear_load);
    p.body.mass / p.wheelbase()
        * (p.body.cog_to_rear_axle / front - p.body.cog_to_front_axle / rear)
}

/// Slope of the least-squares line through `(x, y)`.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    sxy / sxx
}

/// Understeer gradient measured on a slow steer ramp at constant speed: the slope of
/// `δ − L r/v_x` over `a_y` within `accelerations` (m/s²).
fn measured_understeer_gradient(
    p: &FullVehicleParams,
    accelerations: std::ops::RangeInclusive<f64>,
) -> f64 {
    let mut vehicle = FullVehicle::rolling(p.clone(), SPEED);
    let ramp_rate = 0.002; // rad/s road-wheel angle: quasi-static
    let mut points = Vec::new();
    drive(
        &mut vehicle,
        15.0,
        |t, now| FullVehicleInput {
            steering_angle: ramp_rate * t,
            drive_torque: speed_keeping_torque(p, SPEED, now.longitudinal_velocity),
            ..FullVehicleInput::default()
        },
        |t, truth| {
            let ay = truth.lateral_acceleration;
            if accelerations.contains(&ay) {
                let kinematic = p.wheelbase() * truth.yaw_rate / truth.longitudinal_velocity;
                // the commanded angle of the step just taken (`t` is its end)
                let commanded = ramp_rate * (t - STEP);
                points.push((ay, commanded - kinematic));
            }
        },
    );
    slope(&points)
}

#[test]
fn understeer_gradient_matches_the_linear_single_track_formula() {
    for (file, p) in every_car() {
        let linear = linear_understeer_gradient(&p);
        let measured = measured_understeer_gradient(&p, 0.1..=0.8);
        let higher = measured_understeer_gradient(&p, 0.3..=2.0);
        println!("{file}: K linear {linear:.3e}, measured {measured:.3e} rad/(m/s²)");
        // At low a_y the linear formula holds: within 5 % or 1.5e-5 rad/(m/s²) (0.009 deg/g,
        // for the nearly neutral seed car). The lateral load transfer, larger at the front
        // (60/40 roll stiffness), lowers the front axle's degressive stiffness more: a little
        // more understeer than linear, growing with a_y.
        let tolerance = (0.05 * linear.abs()).max(1.5e-5);
        assert!(
            (measured - linear).abs() <= tolerance,
            "{file}: {measured} vs {linear}"
        );
        assert!(
            measured > linear && higher > measured,
            "{file}: {linear} {measured} {higher}"
        );
    }
}

/// Yaw-rate response to a steering step at 20 m/s: time from the step to 90 % of the final yaw rate.
fn yaw_rate_rise_time(p: &FullVehicleParams, angle: f64) -> (f64, f64) {
    let mut vehicle = FullVehicle::rolling(p.clone(), SPEED);
    let mut history = Vec::new();
    drive(
        &mut vehicle,
        3.0,
        |_, _| steer(angle),
        |t, truth| history.push((t, truth.yaw_rate)),
    );
    let final_rate = history.last().unwrap().1;
    let rise = history
        .iter()
        .find(|(_, r)| *r >= 0.9 * final_rate)
        .unwrap()
        .0;
    let peak = history.iter().map(|(_, r)| *r).fold(0.0, f64::max);
    (rise, peak / final_rate)
}

#[test]
fn step_steer_yaw_rate_rises_in_a_passenger_car_time() {
    for (file, p) in every_car() {
        let (rise, overshoot) = yaw_rate_rise_time(&p, 0.02);
        println!("{file}: rise {rise:.3} s, overshoot {overshoot:.3}");
        assert!((0.1..=0.4).contains(&rise), "{file}: {rise} s");
        assert!(overshoot < 1.2, "{file}: {overshoot}");
    }
}

/// Roll angle over lateral acceleration in a steady turn.
fn measured_roll_gradient(p: &FullVehicleParams) -> f64 {
    let mut vehicle = FullVehicle::rolling(p.clone(), SPEED);
    drive(&mut vehicle, 4.0, |_, _| steer(0.02), |_, _| {});
    let truth = vehicle.truth();
    truth.roll_angle / truth.lateral_acceleration
}

#[test]
fn roll_gradient_is_plausible_and_as_the_parameters_give() {
    for (file, p) in every_car() {
        let measured = measured_roll_gradient(&p);
        let degrees_per_g = measured.to_degrees() * GRAVITY;
        assert!(
            (2.0..=8.0).contains(&degrees_per_g),
            "{file}: {degrees_per_g} deg/g"
        );
        // m_s h'/(K_φ − m_s g h') of the roll equation at rest, within 0.5 % (the equation's
        // cos φ, sin φ and the roll rate not quite zero after 4 s)
        assert!(
            (measured / p.roll_gradient() - 1.0).abs() < 5e-3,
            "{file}: {measured}"
        );
    }
}

/// The mirrored state: `vy, r, φ, φ̇, δ` change sign, left and right wheels swap.
fn mirrored(truth: &vehicle_models::full_vehicle::FullVehicleTruth) -> [f64; 9] {
    use wheel_index::*;
    [
        truth.longitudinal_velocity,
        -truth.lateral_velocity,
        -truth.yaw_rate,
        -truth.roll_angle,
        -truth.lateral_acceleration,
        truth.wheel_speed[FRONT_RIGHT],
        truth.wheel_speed[REAR_RIGHT],
        truth.wheel_load[FRONT_RIGHT],
        truth.wheel_load[REAR_LEFT],
    ]
}

fn plain(truth: &vehicle_models::full_vehicle::FullVehicleTruth) -> [f64; 9] {
    use wheel_index::*;
    [
        truth.longitudinal_velocity,
        truth.lateral_velocity,
        truth.yaw_rate,
        truth.roll_angle,
        truth.lateral_acceleration,
        truth.wheel_speed[FRONT_LEFT],
        truth.wheel_speed[REAR_LEFT],
        truth.wheel_load[FRONT_LEFT],
        truth.wheel_load[REAR_RIGHT],
    ]
}

#[test]
fn left_and_right_steering_give_mirrored_responses() {
    let p = FullVehicleParams::default();
    let manoeuvre = |sign: f64| {
        move |t: f64, _: &_| FullVehicleInput {
            steering_angle: sign * 0.05 * (2.0 * std::f64::consts::PI * 0.5 * t).sin(),
            drive_torque: 300.0,
            brake_torque: if t > 2.0 { 1500.0 } else { 0.0 },
            ..FullVehicleInput::default()
        }
    };
    let mut left = FullVehicle::rolling(p.clone(), SPEED);
    let mut right = FullVehicle::rolling(p, SPEED);
    let mut lefts = Vec::new();
    drive(&mut left, 3.0, manoeuvre(1.0), |_, truth| {
        lefts.push(plain(truth))
    });
    let mut k = 0;
    drive(&mut right, 3.0, manoeuvre(-1.0), |t, truth| {
        let mirror = mirrored(truth);
        for (a, b) in lefts[k].iter().zip(mirror) {
            assert!(
                (a - b).abs() <= 1e-9 * (1.0 + a.abs()),
                "t = {t}: {a} vs {b}"
            );
        }
        k += 1;
    });
    assert!(
        lefts.iter().any(|x| x[2].abs() > 0.1),
        "the manoeuvre turns the car"
    );
}

/// Largest lateral acceleration of a strong steer at 20 m/s on a road of the given friction.
fn peak_lateral_acceleration(road_friction: f64) -> f64 {
    let mut vehicle = FullVehicle::rolling(FullVehicleParams::default(), SPEED);
    let mut peak: f64 = 0.0;
    let input = |_, _: &_| FullVehicleInput {
        steering_angle: 0.08,
        road_friction,
        ..FullVehicleInput::default()
    };
    drive(&mut vehicle, 3.0, input, |_, truth| {
        peak = peak.max(truth.lateral_acceleration.abs())
    });
    peak
}

#[test]
fn road_friction_input_limits_the_lateral_acceleration() {
    let dry = peak_lateral_acceleration(1.0);
    let wet = peak_lateral_acceleration(0.3);
    println!("peak a_y: dry {dry:.2}, mu 0.3 {wet:.2} m/s²");
    assert!(dry > 7.0, "{dry}");
    // the tyres' peak friction at the loads here is at most 1.35 λ_μ (000: 5.67)
    assert!(wet < 1.35 * 0.3 * GRAVITY && wet < 0.5 * dry, "{wet}");
}

#[test]
fn crossing_from_dry_to_ice_mid_turn_drops_the_lateral_acceleration() {
    let mut vehicle = FullVehicle::rolling(FullVehicleParams::default(), SPEED);
    let mut on_ice = Vec::new();
    let input = |t: f64, _: &_| FullVehicleInput {
        steering_angle: 0.03,
        road_friction: if t < 2.0 { 1.0 } else { 0.1 },
        ..FullVehicleInput::default()
    };
    drive(&mut vehicle, 4.0, input, |t, truth| {
        if t > 2.5 {
            on_ice.push(truth.lateral_acceleration.abs());
        }
    });
    assert!(
        on_ice.iter().all(|ay| *ay < 1.35 * 0.1 * GRAVITY),
        "{on_ice:?}"
    );
}

#[test]
fn a_lifted_wheel_carries_no_load_and_no_force() {
    let mut p = FullVehicleParams::default();
    // a tall car: the inner wheels lift in a hard turn
    p.body.cog_height = 1.4;
    p.suspension.sprung_cog_height = 1.4;
    let mut vehicle = FullVehicle::rolling(p, SPEED);
    let mut lifted = 0;
    drive(
        &mut vehicle,
        3.0,
        |_, _| steer(0.1),
        |_, truth| {
            for wheel in 0..4 {
                assert!(truth.wheel_load[wheel] >= 0.0);
                if truth.wheel_load[wheel] == 0.0 {
                    lifted += 1;
                    assert_eq!(truth.tyre_force_longitudinal[wheel], 0.0);
                    assert_eq!(truth.tyre_force_lateral[wheel], 0.0);
                }
            }
        },
    );
    assert!(lifted > 0, "no wheel lifted");
}

#[test]
fn straight_rolling_without_input_keeps_its_speed_exactly() {
    // zero slip, zero force: no drag in the model, so nothing changes
    let mut vehicle = FullVehicle::rolling(FullVehicleParams::default(), SPEED);
    drive(
        &mut vehicle,
        5.0,
        |_, _| FullVehicleInput::default(),
        |_, _| {},
    );
    let truth = vehicle.truth();
    assert_eq!(truth.longitudinal_velocity, SPEED);
    assert_eq!(truth.lateral_velocity, 0.0);
    assert_eq!(truth.tyre_force_longitudinal, [0.0; 4]);
}

#[test]
fn compliance_steer_adds_its_textbook_understeer() {
    // δ = δ_cmd − c F_y,front with F_y,front = m l_r/L a_y at steady state, so the gradient grows
    // by c m l_r/L (e.g. Gillespie, "Fundamentals of Vehicle Dynamics", ch. 6, compliance steer)
    let rigid = FullVehicleParams::default();
    let mut compliant = rigid.clone();
    compliant.steering.compliance = 3e-6; // rad/N, about 0.17 deg/kN
    let expected = compliant.steering.compliance * rigid.body.mass * rigid.body.cog_to_rear_axle
        / rigid.wheelbase();
    let added = measured_understeer_gradient(&compliant, 0.1..=0.8)
        - measured_understeer_gradient(&rigid, 0.1..=0.8);
    assert!(
        (added / expected - 1.0).abs() < 0.03,
        "{added} vs {expected}"
    );
}

#[test]
fn steering_lag_is_first_order_with_its_time_constant() {
    let mut p = FullVehicleParams::default();
    p.steering.lag_time_constant = 0.1;
    let mut vehicle = FullVehicle::rolling(p, SPEED);
    let mut at_time_constant = 0.0;
    drive(
        &mut vehicle,
        0.5,
        |_, _| steer(0.02),
        |t, truth| {
            if (t - 0.1).abs() < 0.5 * STEP {
                at_time_constant = truth.road_wheel_angle;
            }
        },
    );
    // 1 − e^-1 of the step after one time constant (implicit Euler at 1 ms: within 0.5 %)
    let expected = 0.02 * (1.0 - (-1.0_f64).exp());
    assert!(
        (at_time_constant / expected - 1.0).abs() < 5e-3,
        "{at_time_constant}"
    );
    assert!((vehicle.truth().road_wheel_angle / 0.02 - 1.0).abs() < 1e-2); // e^-5 left
}

#[test]
fn at_walking_pace_the_car_turns_on_its_kinematic_circle() {
    // low a_y: r = v tan δ / L (kinematic single track) within 3 %, also below V_low; up to
    // 0.3 rad road-wheel angle, since both front wheels steer alike (no Ackermann geometry) and
    // scrub at larger angles (at 0.5 rad and 0.5 m/s the seed car turns 4.6 % slower)
    for (file, p) in every_car() {
        for (speed, angle) in [(2.0, 0.3), (0.5, 0.3), (0.2, 0.3)] {
            let mut vehicle = FullVehicle::rolling(p.clone(), speed);
            let input =
                |_, now: &vehicle_models::full_vehicle::FullVehicleTruth| FullVehicleInput {
                    steering_angle: angle,
                    drive_torque: speed_keeping_torque(&p, speed, now.longitudinal_velocity),
                    ..FullVehicleInput::default()
                };
            drive(&mut vehicle, 6.0, input, |_, _| {});
            let truth = vehicle.truth();
            let kinematic = truth.longitudinal_velocity * angle.tan() / p.wheelbase();
            assert!(
                (truth.yaw_rate / kinematic - 1.0).abs() < 0.03,
                "{file} at {speed} m/s: r = {} vs {kinematic}",
                truth.yaw_rate
            );
        }
    }
}

#[test]
fn a_long_step_is_the_same_as_its_internal_steps() {
    let input = FullVehicleInput {
        steering_angle: 0.03,
        drive_torque: 500.0,
        ..FullVehicleInput::default()
    };
    let mut long = FullVehicle::rolling(FullVehicleParams::default(), SPEED);
    let mut short = long.clone();
    for _ in 0..100 {
        long.step(&input, 10.0 * STEP);
        for _ in 0..10 {
            short.step(&input, STEP);
        }
    }
    for (a, b) in long.state().iter().zip(short.state().iter()) {
        assert!((a - b).abs() <= 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
    }
}

#[test]
fn the_slip_angle_builds_up_over_the_relaxation_length() {
    // first-order relaxation (Pacejka 2012, Sect. 7.2): right after a steering step, before the
    // car responds, the front slip angle follows δ (1 − exp(−v t/σα)); the truth of a step
    // reports the slip the step's forces used, i.e. at its start (t − STEP)
    for relaxation_length in [0.5, 1.0] {
        let mut p = FullVehicleParams::default();
        p.tyre_front.relaxation_length_lateral = relaxation_length;
        let mut vehicle = FullVehicle::rolling(p, SPEED);
        let angle = 0.02;
        let mut after_5_ms = 0.0;
        drive(
            &mut vehicle,
            0.005,
            |_, _| steer(angle),
            |_, truth| {
                after_5_ms = truth.slip_angle[wheel_index::FRONT_LEFT];
            },
        );
        let distance = SPEED * (0.005 - STEP);
        let expected = angle * (1.0 - (-distance / relaxation_length).exp());
        assert!(
            (after_5_ms / expected - 1.0).abs() < 0.04,
            "{after_5_ms} vs {expected}"
        );
    }
}
