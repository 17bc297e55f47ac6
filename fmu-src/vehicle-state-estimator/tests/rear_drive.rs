//! A rear-drive car, its torques unknown, through the C ABI. The car is the BMW 320i of
//! fmu-src/vehicle-models/cars/bmw_320i.toml (CommonRoad "vehicle 2", rear-wheel drive: mass,
//! yaw inertia, axle distances, wheel radius 0.344 m, wheel inertia 1.7 kg m² per wheel, brake
//! split 0.66), as model A with the seed's HSRI tyre; the truth is model A with a drive torque on
//! the rear axle only ([`SingleTrackModel::step_with_rear_drive`]).
//!
//! The estimator gets no wheel speed and no speed measurement, so its wheel speeds come from its
//! model and the torques it is told: told `drive_torque_rear` it follows the rear wheels' spin-up;
//! told the same torque as `drive_torque` (the front axle, all a user could do before), it spins
//! up the wrong wheels.

use crate::car;

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use vehicle_models::single_track::{state_index, Chassis, SingleTrackParams, SingleTrackState};
use vehicle_models::{DriverInputVector, HsriTyre, Integrator, SingleTrackHsri, GRAVITY};
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel, GUID};

const STEP: f64 = 0.01;
const START_SPEED: f64 = 15.0;
/// Drive torque on the rear axle, N·m: about 1 m/s² of acceleration for this car.
const REAR_TORQUE: f64 = 400.0;

fn bmw_320i() -> Chassis {
    let car = Chassis {
        brake_split_front: 0.66,
        front_wheel_radius: 0.344,
        rear_wheel_radius: 0.344,
        front_wheel_inertia: 3.4,
        rear_wheel_inertia: 3.4,
        yaw_inertia: 1791.6,
        mass: 1093.3,
        cog_to_front_axle: 1.1562,
        cog_to_rear_axle: 1.42272,
        ..Chassis::default()
    };
    let (front_wheel_load, rear_wheel_load) = car.static_wheel_loads(GRAVITY);
    Chassis {
        front_wheel_load,
        rear_wheel_load,
        ..car
    }
}

/// An EKF on model A (the truth's own model) told the car, starting from the true state,
/// without wheel-speed or speed rows.
fn estimator(car: &Chassis) -> Slave {
    let mut s =
        Slave::instantiate(fmi2_api_of!(VehicleStateEstimator), "rear", GUID).expect("instantiate");
    assert_eq!(
        s.set_integer(vr::MODEL, EstimatorModel::SingleTrack5State as i32),
        Fmi2Status::Ok
    );
    let rolling = START_SPEED / car.front_wheel_radius;
    car::set_car(&mut s, car);
    let parameters = [
        (vr::SAMPLE_TIME, STEP),
        (vr::VX_INITIAL, START_SPEED),
        (vr::OMEGA_FRONT_INITIAL, rolling),
        (vr::OMEGA_REAR_INITIAL, rolling),
    ];
    for (reference, value) in parameters {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
    }
    assert_eq!(
        s.set_integer(vr::ESTIMATOR, EstimatorKind::Ekf as i32),
        Fmi2Status::Ok
    );
    for flag in [
        vr::USE_SPEED_MEASUREMENTS,
        vr::START_FROM_MEASUREMENTS,
        vr::GATE_MEASUREMENTS,
    ] {
        assert_eq!(s.set_boolean(flag, false), Fmi2Status::Ok);
    }
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    s
}

/// Runs 3 s of a gentle sine steer under `REAR_TORQUE` on the true car's rear axle; the
/// estimator is told the torque on `told` (an input's value reference). Returns the largest
/// errors over the run of the estimated `[ωR, ωF, rear slip, front slip]` and the true rear
/// slip at the end. The truth steps with the estimator's own sample time and scheme, so what is
/// tested is the torque's path through the interface, not model error.
fn run(told: u32) -> ([f64; 4], f64) {
    let car = bmw_320i();
    let truth = SingleTrackHsri::new(
        SingleTrackParams {
            chassis: car.clone(),
            ..SingleTrackParams::default()
        },
        HsriTyre::default(),
    );
    let mut state: SingleTrackState = truth.straight_rolling_state(START_SPEED);
    let start_rear = state[state_index::OMEGA_REAR];
    let mut s = estimator(&car);
    let mut worst = [0.0f64; 4];
    for k in 0..300 {
        let t = k as f64 * STEP;
        let input = DriverInputVector::new(0.01 * (std::f64::consts::PI * t).sin(), 0.0, 0.0);
        let y = truth.measurement(&state, &input);
        s.set_reals(
            &[vr::STEERING_ANGLE, vr::YAW_RATE_MEAS, vr::AY_MEAS, told],
            &[input[0], y[0], y[1], REAR_TORQUE],
        );
        s.set_reals(
            &[vr::OMEGA_FRONT_MEAS, vr::OMEGA_REAR_MEAS, vr::VX_MEAS],
            &[f64::NAN; 3],
        );
        // Without wheel speeds the first doStep logs that they are not connected (fmi2OK).
        assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok);
        state = truth
            .step_with_rear_drive(
                &state.data.0[0],
                &input.data.0[0],
                Some(REAR_TORQUE),
                STEP,
                Integrator::SemiImplicitEuler,
            )
            .into();
        let estimate = s.reals(&[
            vr::OMEGA_REAR_EST,
            vr::OMEGA_FRONT_EST,
            vr::SLIP_REAR_EST,
            vr::SLIP_FRONT_EST,
        ]);
        let slips = truth.outputs(&state, &input);
        let truth_now = [
            state[state_index::OMEGA_REAR],
            state[state_index::OMEGA_FRONT],
            slips.slip_rear,
            slips.slip_front,
        ];
        for ((worst, estimate), truth) in worst.iter_mut().zip(estimate).zip(truth_now) {
            *worst = worst.max((estimate - truth).abs());
        }
    }
    assert!(
        state[state_index::OMEGA_REAR] - start_rear > 5.0,
        "the rear wheels hardly spun up"
    );
    (
        worst,
        truth.outputs(&state, &DriverInputVector::zeros()).slip_rear,
    )
}

#[test]
fn told_the_rear_drive_torque_the_estimate_follows_the_rear_wheels() {
    let ([rear, front, rear_slip, front_slip], true_rear_slip) = run(vr::DRIVE_TORQUE_REAR);
    // The rear wheels spin up by about 9 rad/s in 3 s with a drive slip of about 0.9 %.
    assert!(true_rear_slip > 1e-3, "true rear slip {true_rear_slip}");
    assert!(
        rear < 1e-3 && front < 1e-3,
        "wheel speed errors {rear}, {front} rad/s"
    );
    assert!(
        rear_slip < 0.01 * true_rear_slip && front_slip < 0.01 * true_rear_slip,
        "slip errors {rear_slip}, {front_slip}"
    );
}

#[test]
fn told_the_torque_on_the_front_axle_the_estimate_misses_the_rear_wheels() {
    let ([_, _, rear_slip, front_slip], true_rear_slip) = run(vr::DRIVE_TORQUE);
    // The estimate puts the drive slip on the wrong axle.
    assert!(
        rear_slip > 0.5 * true_rear_slip,
        "rear slip error {rear_slip}"
    );
    assert!(
        front_slip > 0.5 * true_rear_slip,
        "front slip error {front_slip}"
    );
}
