//! Checks of model B (seed 001): full two-track reference vehicle and the 3-state form.

use crate::common;

use common::{assert_jacobian_close, central_difference};
use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::{index as input_index, DriverInputVector};
use vehicle_models::manoeuvre::{SeedManoeuvre, SEED_INITIAL_SPEED, SEED_MANOEUVRE_DURATION};
use vehicle_models::two_track::{state_index, wheel_index, TwoTrackState};
use vehicle_models::two_track_lateral::{
    state_index as lateral_index, TwoTrackLateralInput, TwoTrackLateralState,
};
use vehicle_models::tyre::{HsriTyre, MagicFormulaTyre, TyreKinematics, TyreModel};
use vehicle_models::{
    Integrator, SingleTrackHsri, TwoTrackLateralMagicFormula, TwoTrackMagicFormula, TwoTrackParams,
    VehicleTruth,
};

const SAMPLE_TIME: f64 = 1e-3;

/// Runs the full model B on a seed manoeuvre; returns the final state, input and the history of
/// (input, vx) for driving the 3-state form alongside.
fn simulate_full(
    model: &TwoTrackMagicFormula,
    manoeuvre: SeedManoeuvre,
    mirror: bool,
) -> (TwoTrackState, DriverInputVector, Vec<(f64, f64)>) {
    let mut x = model.straight_rolling_state(SEED_INITIAL_SPEED);
    let steps = (SEED_MANOEUVRE_DURATION / SAMPLE_TIME).round() as usize;
    let input_at = |t: f64| {
        let mut u = manoeuvre.input_at(t).to_vector();
        if mirror {
            u[input_index::STEERING_ANGLE] = -u[input_index::STEERING_ANGLE];
        }
        u
    };
    let mut history = Vec::with_capacity(steps);
    for k in 0..steps {
        let u = input_at(k as f64 * SAMPLE_TIME);
        history.push((u[input_index::STEERING_ANGLE], x[state_index::VX]));
        x = model.step(&x, &u, SAMPLE_TIME, Integrator::SemiImplicitEuler);
    }
    (x, input_at(SEED_MANOEUVRE_DURATION), history)
}

fn simulate_model_a(manoeuvre: SeedManoeuvre) -> VehicleTruth {
    let model = SingleTrackHsri::default();
    let mut x = model.straight_rolling_state(SEED_INITIAL_SPEED);
    let steps = (SEED_MANOEUVRE_DURATION / SAMPLE_TIME).round() as usize;
    for k in 0..steps {
        let u = manoeuvre.input_at(k as f64 * SAMPLE_TIME).to_vector();
        x = model.step(&x, &u, SAMPLE_TIME, Integrator::SemiImplicitEuler);
    }
    model.truth(&x, &manoeuvre.input_at(SEED_MANOEUVRE_DURATION).to_vector())
}

#[test]
fn magic_formula_matches_model_a_stiffness_and_peak_friction() {
    // B·C·D at the nominal loads equals model A's HSRI cornering stiffness; peak = f0·Fz.
    let mf = MagicFormulaTyre::default();
    let hsri = HsriTyre::default();
    let p = TwoTrackParams::default();
    for load in [p.chassis.front_wheel_load, p.chassis.rear_wheel_load] {
        let tiny = 1e-6;
        let force = |tan_slip_angle: f64, slip: f64| {
            mf.force(&TyreKinematics {
                slip,
                tan_slip_angle,
                wheel_velocity: 18.0,
                vertical_load: load,
            })
        };
        let slope = force(tiny, 0.0).lateral / tiny;
        assert!((slope / hsri.cornering_stiffness(load) - 1.0).abs() < 1e-6);
        let long_slope = force(0.0, tiny).longitudinal / tiny;
        assert!((long_slope / hsri.longitudinal_stiffness(load) - 1.0).abs() < 1e-5);
        let peak = (1..400)
            .map(|i| force((i as f64 * 0.1_f64).to_radians().tan(), 0.0).lateral)
            .fold(0.0, f64::max);
        let f0 = hsri.params.friction_potential(load);
        assert!((peak / (f0 * load) - 1.0).abs() < 1e-3, "peak {peak}");
    }
}

#[test]
fn magic_formula_load_dependence_is_degressive() {
    // Moving load ΔFz from one wheel to the other loses lateral force (001: "degressive
    // Abhängigkeit der Seitenkraft von der Aufstandskraft").
    let mf = MagicFormulaTyre::default();
    let force = |load: f64, degrees: f64| {
        mf.force(&TyreKinematics {
            slip: 0.0,
            tan_slip_angle: degrees.to_radians().tan(),
            wheel_velocity: 18.0,
            vertical_load: load,
        })
        .lateral
    };
    for degrees in [0.5, 2.0, 5.0, 10.0] {
        let even = 2.0 * force(3492.0, degrees);
        let shifted = force(3492.0 + 1200.0, degrees) + force(3492.0 - 1200.0, degrees);
        assert!(shifted < even * 0.99, "{degrees}°: {shifted} vs {even}");
    }
}

#[test]
fn full_model_b_agrees_with_model_a_in_the_linear_region() {
    // Moderate ramp (ay ≈ 3.6 m/s², slip angles ≈ 1°): same car, same stiffness.
    let model = TwoTrackMagicFormula::default();
    let (x, u, _) = simulate_full(&model, SeedManoeuvre::ModerateRamp, false);
    let b = model.truth(&x, &u);
    let a = simulate_model_a(SeedManoeuvre::ModerateRamp);
    let relative = |x: f64, y: f64| ((x - y) / y).abs();
    assert!(relative(b.lateral_acceleration, a.lateral_acceleration) < 0.03);
    assert!(relative(b.yaw_rate, a.yaw_rate) < 0.03);
    assert!(relative(b.longitudinal_velocity, a.longitudinal_velocity) < 0.01);
    assert!((b.sideslip - a.sideslip).abs() < 0.1_f64.to_radians());
}

#[test]
fn full_model_b_transfers_load_to_the_outer_wheels() {
    let model = TwoTrackMagicFormula::default();
    let (x, u, _) = simulate_full(&model, SeedManoeuvre::HighRamp, false);
    let loads = model.wheel_loads(&x, &u);
    let ay = model.truth(&x, &u).lateral_acceleration;
    let p = &model.vehicle;
    // left turn: right wheels are outer
    let front_transfer = loads[wheel_index::FRONT_RIGHT] - p.chassis.front_wheel_load;
    let rear_transfer = loads[wheel_index::REAR_RIGHT] - p.chassis.rear_wheel_load;
    let expected = p.chassis.mass * ay * p.cog_height / p.track_width;
    // the load-transfer loop is solved: loads and resulting ay agree to rounding level
    assert!((front_transfer / (p.front_roll_moment_share * expected) - 1.0).abs() < 1e-9);
    assert!((rear_transfer / ((1.0 - p.front_roll_moment_share) * expected) - 1.0).abs() < 1e-9);
    let total: f64 = loads.iter().sum();
    assert!((total - 2.0 * (p.chassis.front_wheel_load + p.chassis.rear_wheel_load)).abs() < 1e-6);
}

#[test]
fn more_front_roll_moment_means_more_understeer() {
    // The roll-moment distribution tunes the self-steering (001: text after eq 5): moving roll
    // moment to the front axle lowers the yaw rate and ay reached with the same steering.
    let run = |share: f64| {
        let mut model = TwoTrackMagicFormula::default();
        model.vehicle.front_roll_moment_share = share;
        let (x, u, _) = simulate_full(&model, SeedManoeuvre::ModerateRamp, false);
        model.truth(&x, &u)
    };
    let shares = [0.3, 0.6, 0.9];
    let results: Vec<VehicleTruth> = shares.iter().map(|&share| run(share)).collect();
    for pair in results.windows(2) {
        assert!(pair[1].yaw_rate < pair[0].yaw_rate - 1e-3, "{pair:?}");
        assert!(pair[1].lateral_acceleration < pair[0].lateral_acceleration - 0.02);
    }
}

#[test]
fn full_model_b_mirrors_and_coasts_straight() {
    let model = TwoTrackMagicFormula::default();
    let (left, _, _) = simulate_full(&model, SeedManoeuvre::HighRampBraking, false);
    let (right, _, _) = simulate_full(&model, SeedManoeuvre::HighRampBraking, true);
    // mirror: vy, r flip; left and right wheels swap
    let mirrored = SVector::<f64, 7>::from([
        right[0], -right[1], -right[2], right[4], right[3], right[6], right[5],
    ]);
    assert!((left - mirrored).amax() < 1e-8, "{left} vs {mirrored}");
    assert!(left.iter().all(|v| v.is_finite()));

    let mut x = model.straight_rolling_state(18.0);
    let u = DriverInputVector::zeros();
    for integrator in [Integrator::SemiImplicitEuler, Integrator::RungeKutta4] {
        for _ in 0..3000 {
            x = model.step(&x, &u, SAMPLE_TIME, integrator);
        }
        assert_eq!(x[state_index::VY], 0.0);
        assert_eq!(x[state_index::YAW_RATE], 0.0);
        let truth = model.truth(&x, &u);
        assert!(truth.slip_front.abs() < 1e-12 && truth.slip_rear.abs() < 1e-12);
        assert!((x[state_index::VX] - 18.0).abs() < 1e-9);
    }
}

#[test]
fn full_model_b_brakes_like_model_a() {
    let model = TwoTrackMagicFormula::default();
    let (x, u, _) = simulate_full(&model, SeedManoeuvre::HighRampBraking, false);
    let truth = model.truth(&x, &u);
    assert!((truth.longitudinal_acceleration + 4.0).abs() < 0.5);
    assert!(truth.slip_front < 0.0 && truth.slip_rear < 0.0);
}

#[test]
fn three_state_form_follows_the_full_model_b() {
    // Driven with the full model's steering and speed, the seed-001 form reproduces the
    // sideslip, yaw rate and ay of the full two-track model (same car, lateral dynamics only).
    let full = TwoTrackMagicFormula::default();
    let lateral = TwoTrackLateralMagicFormula::from(&full);
    for manoeuvre in [SeedManoeuvre::ModerateRamp, SeedManoeuvre::HighRamp] {
        let (x_full, u_full, history) = simulate_full(&full, manoeuvre, false);
        let truth = full.truth(&x_full, &u_full);
        let mut x = TwoTrackLateralState::zeros();
        let mut speed = SEED_INITIAL_SPEED;
        for &(steer, vx) in &history {
            speed = vx;
            x = lateral.step(
                &x,
                &TwoTrackLateralInput::new(steer, vx, 0.0),
                SAMPLE_TIME,
                Integrator::SemiImplicitEuler,
            );
        }
        let u = TwoTrackLateralInput::new(u_full[input_index::STEERING_ANGLE], speed, 0.0);
        let y = lateral.measurement(&x, &u);
        assert!(
            (x[lateral_index::SIDESLIP] - truth.sideslip).abs() < 0.1_f64.to_radians(),
            "{manoeuvre:?}: β {} vs {}",
            x[lateral_index::SIDESLIP],
            truth.sideslip
        );
        assert!(((y[1] - truth.yaw_rate) / truth.yaw_rate).abs() < 0.02);
        assert!(((y[0] - truth.lateral_acceleration) / truth.lateral_acceleration).abs() < 0.02);
        let outputs = lateral.outputs(&x, &u);
        assert!((outputs.slip_angle_front - truth.slip_angle_front).abs() < 0.1_f64.to_radians());
    }
}

#[test]
fn three_state_form_shows_load_transfer_degression() {
    let model = TwoTrackLateralMagicFormula::default();
    let x = TwoTrackLateralState::new(0.0, 0.45, 7.0);
    let u = TwoTrackLateralInput::new(0.12, 15.0, 0.0);
    let without = model.lateral_acceleration_with_loads(&x, &u, 0.0);
    let with = model.lateral_acceleration_with_loads(&x, &u, 7.0);
    assert!(with < without - 0.05, "{with} vs {without}");
}

/// The measured ax shifts the axle loads by the pitch moment (Mitschke and Wallentowitz eq.
/// 4.7): braking at 5 m/s² moves `m ax h / l` to the front axle, the total stays the weight,
/// and in a braked turn the loaded front axle turns the car harder (more yaw acceleration) than
/// the same turn free rolling. (At ax = 0 the seeds' tests check the seed's numbers.)
#[test]
fn braking_moves_load_to_the_front_axle_and_turns_the_car_in() {
    let params = TwoTrackParams::default();
    let chassis = &params.chassis;
    let wheelbase = chassis.cog_to_front_axle + chassis.cog_to_rear_axle;
    let ay = 6.0_f64;
    assert_eq!(
        params.wheel_loads_accelerating(ay, 0.0),
        params.wheel_loads(ay)
    );
    let free = params.wheel_loads(ay);
    let braked = params.wheel_loads_accelerating(ay, -5.0);
    let front = |loads: [f64; 4]| loads[wheel_index::FRONT_LEFT] + loads[wheel_index::FRONT_RIGHT];
    let transfer = chassis.mass * 5.0 * params.cog_height / wheelbase;
    assert!((front(braked) - front(free) - transfer).abs() < 1e-9 * transfer);
    assert!((braked.iter().sum::<f64>() - free.iter().sum::<f64>()).abs() < 1e-6);
    let model = TwoTrackLateralMagicFormula::default();
    let x = TwoTrackLateralState::new(-0.02, 0.3, ay);
    let step = |ax: f64| {
        let u = TwoTrackLateralInput::new(0.06, 20.0, ax);
        model.step(&x, &u, SAMPLE_TIME, Integrator::RungeKutta4)
    };
    assert!(
        step(-5.0)[lateral_index::YAW_RATE] > step(0.0)[lateral_index::YAW_RATE],
        "{} vs {}",
        step(-5.0),
        step(0.0)
    );
}

#[test]
fn three_state_jacobians_match_central_differences() {
    let model = TwoTrackLateralMagicFormula::default();
    let points = [
        (
            TwoTrackLateralState::new(0.0, 0.0, 0.0),
            TwoTrackLateralInput::new(0.0, 18.0, 0.0),
        ),
        (
            TwoTrackLateralState::new(-0.002, 0.21, 3.6),
            TwoTrackLateralInput::new(0.035, 17.5, 0.0),
        ),
        (
            TwoTrackLateralState::new(0.03, 0.5, 7.5),
            TwoTrackLateralInput::new(0.15, 15.0, 0.0),
        ),
        (
            TwoTrackLateralState::new(-0.08, -0.6, -8.0),
            TwoTrackLateralInput::new(-0.3, 12.0, 0.0),
        ),
        // braking and accelerating in a turn: the longitudinal load transfer
        (
            TwoTrackLateralState::new(0.03, 0.5, 7.5),
            TwoTrackLateralInput::new(0.15, 15.0, -5.0),
        ),
        (
            TwoTrackLateralState::new(-0.02, -0.3, -5.0),
            TwoTrackLateralInput::new(-0.08, 20.0, 2.0),
        ),
    ];
    for (x, u) in points {
        for integrator in [Integrator::SemiImplicitEuler, Integrator::RungeKutta4] {
            for dt in [1e-3, 1e-2] {
                let (a, b) = model.step_jacobians(&x, &u, dt, integrator);
                let a_fd: SMatrix<f64, 3, 3> =
                    central_difference(&x, |x| model.step(x, &u, dt, integrator));
                let b_fd: SMatrix<f64, 3, 3> =
                    central_difference(&u, |u| model.step(&x, u, dt, integrator));
                assert_jacobian_close("model B3 A", &a, &a_fd);
                assert_jacobian_close("model B3 B", &b, &b_fd);
            }
        }
        let (c, d) = model.measurement_jacobians();
        let c_fd: SMatrix<f64, 2, 3> = central_difference(&x, |x| model.measurement(x, &u));
        let d_fd: SMatrix<f64, 2, 3> = central_difference(&u, |u| model.measurement(&x, u));
        assert_jacobian_close("model B3 C", &c, &c_fd);
        assert_jacobian_close("model B3 D", &d, &d_fd);
    }
}

/// Each axle of the 3-state model B has its own tyre. Changing a rear
/// parameter (the Magic Formula's shape or curvature, or a factor on friction, reference load
/// or cornering stiffness) changes the rear tyres' force and leaves the front tyres' to the bit,
/// at a point near the limit (slip angles 5-7°, ay 8 m/s²); the same tyre on both axles given
/// per axle is the seed model to the bit.
#[test]
fn a_rear_tyre_parameter_changes_the_rear_axle_force_and_not_the_front() {
    use vehicle_models::tyre::MagicFormulaParams;
    let seed = TwoTrackLateralMagicFormula::default();
    let x = TwoTrackLateralState::new(-0.03, 0.4, 8.0);
    let u = TwoTrackLateralInput::new(0.06, 20.0, 0.0);
    let base = seed.axle_lateral_forces(&x, &u, 8.0);
    let per_axle = TwoTrackLateralMagicFormula::with_axle_tyres(
        TwoTrackParams::default(),
        MagicFormulaTyre::default(),
        MagicFormulaTyre::default(),
    );
    assert_eq!(per_axle.axle_lateral_forces(&x, &u, 8.0), base);
    assert_eq!(
        per_axle.step(&x, &u, SAMPLE_TIME, Integrator::RungeKutta4),
        seed.step(&x, &u, SAMPLE_TIME, Integrator::RungeKutta4)
    );
    let rear_tyre = |change: fn(&mut MagicFormulaParams)| {
        let mut params = MagicFormulaParams::default();
        change(&mut params);
        TwoTrackLateralMagicFormula::with_axle_tyres(
            TwoTrackParams::default(),
            MagicFormulaTyre::default(),
            MagicFormulaTyre::new(params),
        )
    };
    let rear_factor = |change: fn(&mut TwoTrackParams)| {
        let mut vehicle = TwoTrackParams::default();
        change(&mut vehicle);
        TwoTrackLateralMagicFormula::new(vehicle, MagicFormulaTyre::default())
    };
    let changed = [
        ("shape", rear_tyre(|p| p.lateral_shape = 1.6)),
        ("curvature", rear_tyre(|p| p.lateral_curvature = 0.5)),
        (
            "friction",
            rear_factor(|v| v.chassis.rear_tyre_friction_scale = 0.8),
        ),
        (
            "reference load",
            rear_factor(|v| v.chassis.rear_tyre_reference_load_scale = 0.5),
        ),
        (
            "cornering stiffness",
            rear_factor(|v| v.cornering_stiffness_scale_rear = 0.7),
        ),
    ];
    for (name, model) in changed {
        let (front, rear) = model.axle_lateral_forces(&x, &u, 8.0);
        assert_eq!(front.to_bits(), base.0.to_bits(), "{name}");
        assert!(
            (rear / base.1 - 1.0).abs() > 0.01,
            "{name}: rear {} -> {rear}",
            base.1
        );
    }
    let front_changed = rear_factor(|v| v.chassis.front_tyre_friction_scale = 0.8);
    let (front, rear) = front_changed.axle_lateral_forces(&x, &u, 8.0);
    assert_eq!(rear.to_bits(), base.1.to_bits());
    assert!((front / base.0 - 1.0).abs() > 0.01);
}

/// The full model B (the ReferenceVehicle's model 2) takes the per-axle tyres alike: another
/// rear tyre changes the motion, the same tyre given per axle does not change a bit.
#[test]
fn full_model_b_takes_the_rear_tyre() {
    let seed = TwoTrackMagicFormula::default();
    let same = TwoTrackMagicFormula::with_axle_tyres(
        TwoTrackParams::default(),
        MagicFormulaTyre::default(),
        MagicFormulaTyre::default(),
    );
    let mut grippy_rear = vehicle_models::tyre::MagicFormulaParams::default();
    grippy_rear.friction_base *= 1.2;
    let other = TwoTrackMagicFormula::with_axle_tyres(
        TwoTrackParams::default(),
        MagicFormulaTyre::default(),
        MagicFormulaTyre::new(grippy_rear),
    );
    let (seed_end, _, _) = simulate_full(&seed, SeedManoeuvre::HighRamp, false);
    let (same_end, _, _) = simulate_full(&same, SeedManoeuvre::HighRamp, false);
    let (other_end, _, _) = simulate_full(&other, SeedManoeuvre::HighRamp, false);
    assert_eq!(same_end, seed_end);
    assert!((other_end[state_index::VY] - seed_end[state_index::VY]).abs() > 1e-3);
}
