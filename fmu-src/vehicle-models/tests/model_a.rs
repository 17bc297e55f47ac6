//! Physics and Jacobian checks of model A (seed 000).

use crate::common;

use common::{assert_jacobian_close, central_difference};
use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::{index as input_index, DriverInputVector};
use vehicle_models::manoeuvre::{SeedManoeuvre, SEED_INITIAL_SPEED, SEED_MANOEUVRE_DURATION};
use vehicle_models::single_track::{state_index, SingleTrackState};
use vehicle_models::tyre::{HsriTyre, LinearTyre, MagicFormulaTyre, TyreModel};
use vehicle_models::{Integrator, SingleTrackHsri, SingleTrackModel, SingleTrackParams};

const SAMPLE_TIME: f64 = 1e-3;

fn simulate<T: TyreModel>(
    model: &SingleTrackModel<T>,
    manoeuvre: SeedManoeuvre,
    integrator: Integrator,
    mirror: bool,
) -> (SingleTrackState, DriverInputVector) {
    let mut state = model.straight_rolling_state(SEED_INITIAL_SPEED);
    let steps = (SEED_MANOEUVRE_DURATION / SAMPLE_TIME).round() as usize;
    let input_at = |t: f64| {
        let mut u = manoeuvre.input_at(t).to_vector();
        if mirror {
            u[input_index::STEERING_ANGLE] = -u[input_index::STEERING_ANGLE];
        }
        u
    };
    for k in 0..steps {
        state = model.step(
            &state,
            &input_at(k as f64 * SAMPLE_TIME),
            SAMPLE_TIME,
            integrator,
        );
    }
    (state, input_at(SEED_MANOEUVRE_DURATION))
}

#[test]
fn stiffness_check_values_of_seed_000() {
    // 000: after table 5.2: CαF = 6.6109e4, CαR = 6.4639e4 N/rad, CsF = 1.1623e5, CsR = 1.0967e5 N
    let tyre = HsriTyre::default();
    let p = SingleTrackParams::default();
    // The seed quotes five digits; its rear Cs (1.0967e5) is 3.5e-4 above what (000: 5.71) gives
    // at FZR = 3374 N (1.0963e5), so the tolerance is 5e-4.
    let close = |a: f64, b: f64| ((a - b) / b).abs() < 5e-4;
    assert!(close(
        tyre.cornering_stiffness(p.chassis.front_wheel_load),
        6.6109e4
    ));
    assert!(close(
        tyre.cornering_stiffness(p.chassis.rear_wheel_load),
        6.4639e4
    ));
    assert!(close(
        tyre.longitudinal_stiffness(p.chassis.front_wheel_load),
        1.1623e5
    ));
    assert!(close(
        tyre.longitudinal_stiffness(p.chassis.rear_wheel_load),
        1.0967e5
    ));
}

#[test]
fn hsri_small_slip_force_equals_stiffness_times_slip() {
    // The slope of the HSRI force at zero slip is the stiffness of (000: 5.70, 5.71).
    let model = SingleTrackHsri::default();
    let fz = model.vehicle.chassis.front_wheel_load;
    let tiny = 1e-5;
    let lateral = model.tyre.force(&vehicle_models::tyre::TyreKinematics {
        slip: 0.0,
        tan_slip_angle: tiny,
        wheel_velocity: 18.0,
        vertical_load: fz,
    });
    let longitudinal = model.tyre.force(&vehicle_models::tyre::TyreKinematics {
        slip: tiny,
        tan_slip_angle: 0.0,
        wheel_velocity: 18.0,
        vertical_load: fz,
    });
    assert!((lateral.lateral / tiny / model.tyre.cornering_stiffness(fz) - 1.0).abs() < 1e-9);
    assert!(
        (longitudinal.longitudinal / tiny / model.tyre.longitudinal_stiffness(fz) - 1.0).abs()
            < 1e-4
    );
}

#[test]
fn moderate_ramp_settles_near_seed_lateral_acceleration() {
    // SPEC §7 / 000: 7.1: ay "etwa 3.7 m/s²"; independent implementation of SPEC: 3.65.
    let model = SingleTrackHsri::default();
    let (x, u) = simulate(
        &model,
        SeedManoeuvre::ModerateRamp,
        Integrator::SemiImplicitEuler,
        false,
    );
    let ay = model.outputs(&x, &u).lateral_acceleration;
    assert!((ay - 3.65).abs() < 0.03, "ay = {ay}");
    // steady: the measured ay equals vx·r up to the tiny v̇y
    assert!((ay - x[state_index::VX] * x[state_index::YAW_RATE]).abs() < 0.02);
    // speed falls through the cornering drag (000: 7.1 text on fig. 7.3)
    assert!(x[state_index::VX] < SEED_INITIAL_SPEED - 0.1);
}

#[test]
fn runge_kutta_and_seed_scheme_agree_on_the_moderate_ramp() {
    let model = SingleTrackHsri::default();
    let (euler, _) = simulate(
        &model,
        SeedManoeuvre::ModerateRamp,
        Integrator::SemiImplicitEuler,
        false,
    );
    let (rk4, _) = simulate(
        &model,
        SeedManoeuvre::ModerateRamp,
        Integrator::RungeKutta4,
        false,
    );
    let difference = (euler - rk4).abs();
    assert!(difference[state_index::VX] < 1e-2, "{difference}");
    assert!(difference[state_index::VY] < 1e-3, "{difference}");
    assert!(difference[state_index::YAW_RATE] < 1e-3, "{difference}");
}

/// Runs a manoeuvre with step `dt` up to `duration`.
fn simulate_with_step(
    model: &SingleTrackHsri,
    manoeuvre: SeedManoeuvre,
    integrator: Integrator,
    dt: f64,
    duration: f64,
) -> SingleTrackState {
    let mut state = model.straight_rolling_state(SEED_INITIAL_SPEED);
    for k in 0..(duration / dt).round() as usize {
        let u = manoeuvre.input_at(k as f64 * dt).to_vector();
        state = model.step(&state, &u, dt, integrator);
    }
    state
}

#[test]
fn runge_kutta_converges_to_the_fine_solution() {
    // RK4 at 1 ms agrees with RK4 at 0.25 ms to far better than the seed scheme's O(T) error.
    let model = SingleTrackHsri::default();
    let duration = 6.0;
    let fine = simulate_with_step(
        &model,
        SeedManoeuvre::StepSteer,
        Integrator::RungeKutta4,
        2.5e-4,
        duration,
    );
    let rk4 = simulate_with_step(
        &model,
        SeedManoeuvre::StepSteer,
        Integrator::RungeKutta4,
        1e-3,
        duration,
    );
    let euler = simulate_with_step(
        &model,
        SeedManoeuvre::StepSteer,
        Integrator::SemiImplicitEuler,
        1e-3,
        duration,
    );
    let rk4_error = (rk4 - fine).amax();
    let euler_error = (euler - fine).amax();
    assert!(rk4_error < 1e-4, "{rk4_error}");
    assert!(
        euler_error > 10.0 * rk4_error,
        "{euler_error} vs {rk4_error}"
    );
}

#[test]
fn seed_scheme_stays_stable_at_filter_sample_times() {
    // The filters predict with model A at 10 ms and 50 ms on the high ramp and the step steer
    // without braking (000: 7.2.2, 7.3); the semi-implicit wheel step keeps the stiff wheel
    // speeds stable there (000: ch. 6).
    let model = SingleTrackHsri::default();
    let reference = simulate_with_step(
        &model,
        SeedManoeuvre::StepSteer,
        Integrator::SemiImplicitEuler,
        1e-3,
        12.0,
    );
    let reference_ay = model
        .outputs(
            &reference,
            &SeedManoeuvre::StepSteer.input_at(12.0).to_vector(),
        )
        .lateral_acceleration;
    for dt in [0.01, 0.05] {
        for manoeuvre in [SeedManoeuvre::StepSteer, SeedManoeuvre::HighRamp] {
            let x = simulate_with_step(&model, manoeuvre, Integrator::SemiImplicitEuler, dt, 12.0);
            assert!(
                x.iter().all(|v| v.is_finite()),
                "{manoeuvre:?} at {dt}: {x}"
            );
            let o = model.outputs(&x, &manoeuvre.input_at(12.0).to_vector());
            assert!(
                o.slip_front.abs() < 0.05 && o.slip_rear.abs() < 0.05,
                "{o:?}"
            );
        }
        let x = simulate_with_step(
            &model,
            SeedManoeuvre::StepSteer,
            Integrator::SemiImplicitEuler,
            dt,
            12.0,
        );
        let ay = model
            .outputs(&x, &SeedManoeuvre::StepSteer.input_at(12.0).to_vector())
            .lateral_acceleration;
        assert!(
            ((ay - reference_ay) / reference_ay).abs() < 0.05,
            "dt {dt}: {ay} vs {reference_ay}"
        );
    }
}

#[test]
fn braking_reaches_the_seed_deceleration() {
    // 000: fig. 7.11 text: about 4 m/s² deceleration from 11 s with M_B = −2000 N·m.
    let model = SingleTrackHsri::default();
    let (x, u) = simulate(
        &model,
        SeedManoeuvre::HighRampBraking,
        Integrator::SemiImplicitEuler,
        false,
    );
    let o = model.outputs(&x, &u);
    assert!(
        (o.longitudinal_acceleration + 4.0).abs() < 0.5,
        "ax = {}",
        o.longitudinal_acceleration
    );
    assert!(
        o.slip_front < 0.0 && o.slip_rear < 0.0,
        "braking slips must be negative"
    );
    assert!(x.iter().all(|v| v.is_finite()));
}

#[test]
fn steering_left_and_right_gives_mirrored_states() {
    let model = SingleTrackHsri::default();
    for manoeuvre in [SeedManoeuvre::HighRamp, SeedManoeuvre::HighRampBraking] {
        let (left, _) = simulate(&model, manoeuvre, Integrator::SemiImplicitEuler, false);
        let (right, _) = simulate(&model, manoeuvre, Integrator::SemiImplicitEuler, true);
        let mirror = SVector::<f64, 5>::new(1.0, -1.0, -1.0, 1.0, 1.0);
        let difference = left - right.component_mul(&mirror);
        assert!(difference.amax() < 1e-9, "{manoeuvre:?}: {difference}");
        assert!(
            left[state_index::YAW_RATE] > 0.1,
            "left steer must turn left"
        );
    }
}

#[test]
fn straight_coasting_stays_straight_and_wheels_roll_freely() {
    let model = SingleTrackHsri::default();
    let mut x = model.straight_rolling_state(18.0);
    let u = DriverInputVector::zeros();
    for integrator in [Integrator::SemiImplicitEuler, Integrator::RungeKutta4] {
        for _ in 0..5000 {
            x = model.step(&x, &u, SAMPLE_TIME, integrator);
        }
        assert_eq!(x[state_index::VY], 0.0);
        assert_eq!(x[state_index::YAW_RATE], 0.0);
        // no rolling resistance in the model (000: 5.42-5.46 neglect it): speed is kept
        assert!((x[state_index::VX] - 18.0).abs() < 1e-9);
        let o = model.outputs(&x, &u);
        assert!(o.slip_front.abs() < 1e-12 && o.slip_rear.abs() < 1e-12);
        assert_eq!(o.sideslip, 0.0);
    }
}

#[test]
fn freely_rolling_wheels_keep_zero_slip_while_cornering() {
    // Undriven, unbraked wheels carry only the force that decelerates their own spin inertia
    // (the car slows through cornering drag, ~0.06 m/s²), so their slip stays ~1e-5.
    let model = SingleTrackHsri::default();
    let (x, u) = simulate(
        &model,
        SeedManoeuvre::ModerateRamp,
        Integrator::SemiImplicitEuler,
        false,
    );
    let o = model.outputs(&x, &u);
    assert!(o.slip_rear.abs() < 1e-4, "sR = {}", o.slip_rear);
    assert!(o.slip_front.abs() < 1e-4, "sF = {}", o.slip_front);
}

#[test]
fn standstill_produces_no_nan() {
    let model = SingleTrackHsri::default();
    let mut x = SingleTrackState::new(0.0, 0.3, 0.1, 0.0, 0.0);
    let u = DriverInputVector::new(0.1, 50.0, 0.0);
    for integrator in [Integrator::SemiImplicitEuler, Integrator::RungeKutta4] {
        for _ in 0..2000 {
            x = model.step(&x, &u, SAMPLE_TIME, integrator);
            assert!(x.iter().all(|v| v.is_finite()), "{x}");
        }
        let (a, b) = model.step_jacobians(&x, &u, SAMPLE_TIME, integrator);
        assert!(a.iter().chain(b.iter()).all(|v| v.is_finite()));
    }
}

/// Operating points covering straight rolling (the LKF point of 000: 5.58-5.62), moderate
/// cornering with drive, sliding under braking, and high lateral slip.
fn operating_points() -> Vec<(SingleTrackState, DriverInputVector)> {
    vec![
        (
            SingleTrackState::new(18.0, 0.0, 0.0, 60.0, 60.0),
            DriverInputVector::new(0.0, 0.0, 0.0),
        ),
        (
            SingleTrackState::new(17.5, -0.03, 0.21, 58.4, 58.3),
            DriverInputVector::new(0.035, 80.0, 0.0),
        ),
        (
            SingleTrackState::new(12.0, 0.3, 0.25, 37.0, 38.5),
            DriverInputVector::new(0.122, 0.0, 1500.0),
        ),
        (
            SingleTrackState::new(15.0, 0.8, 0.45, 49.0, 49.5),
            DriverInputVector::new(0.15, 300.0, 0.0),
        ),
    ]
}

fn check_model_jacobians<T: TyreModel>(model: &SingleTrackModel<T>) {
    for (x, u) in operating_points() {
        for integrator in [Integrator::SemiImplicitEuler, Integrator::RungeKutta4] {
            let (a, b) = model.step_jacobians(&x, &u, SAMPLE_TIME, integrator);
            let a_fd: SMatrix<f64, 5, 5> =
                central_difference(&x, |x| model.step(x, &u, SAMPLE_TIME, integrator));
            let b_fd: SMatrix<f64, 5, 3> =
                central_difference(&u, |u| model.step(&x, u, SAMPLE_TIME, integrator));
            assert_jacobian_close(&format!("A {integrator:?} at {x}"), &a, &a_fd);
            assert_jacobian_close(&format!("B {integrator:?} at {x}"), &b, &b_fd);
        }
        let (c, d) = model.measurement_jacobians(&x, &u);
        let c_fd: SMatrix<f64, 4, 5> = central_difference(&x, |x| model.measurement(x, &u));
        let d_fd: SMatrix<f64, 4, 3> = central_difference(&u, |u| model.measurement(&x, u));
        assert_jacobian_close("C", &c, &c_fd);
        assert_jacobian_close("D", &d, &d_fd);
    }
}

#[test]
fn exact_jacobians_match_central_differences_hsri() {
    let model = SingleTrackHsri::default();
    // the points cover both HSRI branches: at the third (braking) and fourth (large front slip
    // angle) point the front tyre slides, i.e. its force is below the linear one
    let points = operating_points();
    let (x, u) = &points[0];
    let o = model.outputs(x, u);
    assert_eq!(o.longitudinal_force_front, 0.0);
    for (x, u) in &points[2..] {
        let o = model.outputs(x, u);
        let load = model.vehicle.chassis.front_wheel_load;
        let linear_demand = 2.0
            * (model.tyre.cornering_stiffness(load) * o.slip_angle_front.tan())
                .hypot(model.tyre.longitudinal_stiffness(load) * o.slip_front)
            / (1.0 + o.slip_front);
        let force = o.lateral_force_front.hypot(o.longitudinal_force_front);
        assert!(
            force < 0.9 * linear_demand,
            "not sliding at {x}: {force} vs {linear_demand}"
        );
    }
    check_model_jacobians(&model);
}

#[test]
fn exact_jacobians_match_central_differences_other_tyres() {
    check_model_jacobians(&SingleTrackModel::new(
        SingleTrackParams::default(),
        LinearTyre::default(),
    ));
    check_model_jacobians(&SingleTrackModel::new(
        SingleTrackParams::default(),
        MagicFormulaTyre::default(),
    ));
}

#[test]
fn semi_implicit_jacobian_contains_the_differentiated_wheel_stiffness() {
    // The wheel-speed row of the seed scheme differs from explicit Euler exactly by the
    // (1 − T ∂ω̇/∂ω)⁻¹ factor; at T = 10 ms its effect on ∂ωF(k+1)/∂ωF is large, and the exact
    // Jacobian must still match central differences there.
    let model = SingleTrackHsri::default();
    let dt = 0.01;
    let x = SingleTrackState::new(5.0, 0.0, 0.0, 16.0, 16.6);
    let u = DriverInputVector::new(0.0, 100.0, 0.0);
    let (a, _) = model.step_jacobians(&x, &u, dt, Integrator::SemiImplicitEuler);
    let a_fd: SMatrix<f64, 5, 5> =
        central_difference(&x, |x| model.step(x, &u, dt, Integrator::SemiImplicitEuler));
    assert_jacobian_close("A at low speed", &a, &a_fd);
    // The Jacobian with ∂ω̇/∂ω frozen (not differentiated) would be 1/(1 − T ∂ω̇/∂ω) here;
    // the exact one also carries T ω̇ · T ∂²ω̇/∂ω² / (1 − T ∂ω̇/∂ω)², which matters at this point.
    let omega_rate = |omega: f64| {
        let mut y = x;
        y[state_index::OMEGA_FRONT] = omega;
        model.derivatives(&y, &u)[state_index::OMEGA_FRONT]
    };
    let h = 1e-6 * x[state_index::OMEGA_FRONT];
    let rate_slope = (omega_rate(x[state_index::OMEGA_FRONT] + h)
        - omega_rate(x[state_index::OMEGA_FRONT] - h))
        / (2.0 * h);
    assert!(
        rate_slope < 0.0,
        "a gripping wheel damps its own spin: {rate_slope}"
    );
    let frozen = 1.0 / (1.0 - dt * rate_slope);
    let omega = state_index::OMEGA_FRONT;
    assert!(
        (a[(omega, omega)] - frozen).abs() > 1e-2,
        "exact {} vs frozen {frozen}",
        a[(omega, omega)]
    );
}

#[test]
fn linearisation_about_straight_driving_is_the_seed_linear_model() {
    // About the seed's operating point the linear model predicts the nonlinear step with an
    // error of second order in the deviation; its lateral block has the classic single-track
    // entries, e.g. ∂vy(k+1)/∂vy = 1 − T (CαF + CαR)/(m vx) with axle stiffnesses (000: 5.32,
    // 5.53-5.62).
    let model = SingleTrackHsri::default();
    let (x0, u0) = SingleTrackHsri::seed_operating_point();
    let linear = model.linearise(&x0, &u0, SAMPLE_TIME, Integrator::SemiImplicitEuler);
    let p = &model.vehicle;
    let front = 2.0 * model.tyre.cornering_stiffness(p.chassis.front_wheel_load);
    let rear = 2.0 * model.tyre.cornering_stiffness(p.chassis.rear_wheel_load);
    let expected = 1.0 - SAMPLE_TIME * (front + rear) / (p.chassis.mass * x0[state_index::VX]);
    let vy = state_index::VY;
    assert!((linear.transition[(vy, vy)] - expected).abs() < 1e-12);
    let expected_steer = SAMPLE_TIME * front / p.chassis.mass; // (000: 5.32) B entry CF/m
    assert!((linear.input_matrix[(vy, input_index::STEERING_ANGLE)] - expected_steer).abs() < 1e-9);
    let mut errors = Vec::new();
    for scale in [1e-2, 1e-3] {
        let dx = SingleTrackState::new(0.1, 0.05, 0.02, 0.3, -0.2) * scale;
        let du = DriverInputVector::new(0.01, 10.0, 0.0) * scale;
        let (x, u) = (x0 + dx, u0 + du);
        let error = (linear.step(&x, &u)
            - model.step(&x, &u, SAMPLE_TIME, Integrator::SemiImplicitEuler))
        .amax();
        let measurement_error = (linear.measurement(&x, &u) - model.measurement(&x, &u)).amax();
        errors.push(error.max(measurement_error));
    }
    // shrinking the deviation tenfold shrinks the error about a hundredfold
    assert!(errors[1] < errors[0] / 30.0, "{errors:?}");
}

/// The per-axle tyre factors of the chassis (`λμ`, `λFz0`) and the
/// cornering-stiffness scale act on their own axle only. At a cornering point where both axles
/// slide (HSRI sR > 0.5), changing a rear factor changes the rear axle's force and leaves the
/// front's to the bit; factors of 1 are the seed's model to the bit.
#[test]
fn a_rear_tyre_factor_changes_the_rear_axle_force_and_not_the_front() {
    let seed = SingleTrackHsri::default();
    // 20 m/s, sideslip -3°, yaw rate 0.45 rad/s, road-wheel angle 4°: slip angles of 5-6°.
    let x = SingleTrackState::from([20.0, -1.05, 0.45, 20.0 / 0.3, 20.0 / 0.3]);
    let mut u = DriverInputVector::zeros();
    u[input_index::STEERING_ANGLE] = 4f64.to_radians();
    let base = seed.outputs(&x, &u);
    let unit = {
        let mut model = seed.clone();
        let chassis = &mut model.vehicle.chassis;
        chassis.front_tyre_friction_scale = 1.0;
        chassis.rear_tyre_reference_load_scale = 1.0;
        model.outputs(&x, &u)
    };
    assert_eq!(unit, base);
    type Change = fn(&mut SingleTrackParams);
    let changes: [(&str, Change); 3] = [
        ("rear friction", |p| {
            p.chassis.rear_tyre_friction_scale = 0.8
        }),
        ("rear reference load", |p| {
            p.chassis.rear_tyre_reference_load_scale = 0.5
        }),
        ("rear cornering stiffness", |p| {
            p.cornering_stiffness_scale_rear = 0.7
        }),
    ];
    for (name, change) in changes {
        let mut model = seed.clone();
        change(&mut model.vehicle);
        let changed = model.outputs(&x, &u);
        assert_eq!(
            changed.lateral_force_front.to_bits(),
            base.lateral_force_front.to_bits(),
            "{name}"
        );
        let relative = (changed.lateral_force_rear / base.lateral_force_rear - 1.0).abs();
        assert!(
            relative > 0.01,
            "{name}: rear {} -> {}",
            base.lateral_force_rear,
            changed.lateral_force_rear
        );
    }
    // and the other way round
    let mut model = seed.clone();
    model.vehicle.chassis.front_tyre_friction_scale = 1.2;
    let changed = model.outputs(&x, &u);
    assert_eq!(
        changed.lateral_force_rear.to_bits(),
        base.lateral_force_rear.to_bits()
    );
    assert!((changed.lateral_force_front / base.lateral_force_front - 1.0).abs() > 0.01);
}
