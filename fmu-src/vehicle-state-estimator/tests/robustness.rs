//! The robustness defaults through the C ABI, with the FMU's defaults (speed rows, start from the measurements,
//! gate): a car that is not the seed car, torques unknown to the estimator, a wrong start speed,
//! glitches, an outage, a zero row, standstill and restart, and the status bits of each.
//!
//! The car: the Ford Escort of fmu-src/vehicle-models/cars/ford_escort.toml (CommonRoad
//! "vehicle 1": mass, yaw inertia, axle distances, wheel radius and inertia; static wheel loads
//! from the axle split), as model A with the seed's HSRI tyre. The truth is model A with that car,
//! driven with a drive torque the estimator is not told, and series-production sensor noise.

use crate::car;

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::{Fmi2Api, Slave};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use vehicle_models::single_track::{Chassis, SingleTrackParams, SingleTrackState};
use vehicle_models::{DriverInputVector, HsriTyre, Integrator, SingleTrackHsri, GRAVITY};
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel, GUID};
use VehicleStateEstimator::status;

pub(crate) const STEP: f64 = 0.01;

/// The Ford Escort's model-A parameters (see the module documentation).
fn escort() -> Chassis {
    let (mass, front, rear) = (1225.9, 0.88392, 1.50876);
    let axle_load = |distance_to_other_axle: f64| {
        mass * GRAVITY * distance_to_other_axle / (front + rear) / 2.0
    };
    Chassis {
        mass,
        cog_to_front_axle: front,
        cog_to_rear_axle: rear,
        yaw_inertia: 1538.9,
        front_wheel_inertia: 3.4,
        rear_wheel_inertia: 3.4,
        brake_split_front: 0.76,
        front_wheel_radius: 0.344,
        rear_wheel_radius: 0.344,
        front_wheel_load: axle_load(rear),
        rear_wheel_load: axle_load(front),
        ..Chassis::default()
    }
}

/// Sensor noise of a series car: yaw rate 0.2 °/s, ay and ax 0.1 m/s², wheel speeds 0.1 rad/s,
/// reference speed 0.05 m/s.
const SENSOR_STD: [f64; 6] = [0.0035, 0.1, 0.1, 0.1, 0.1, 0.05];

/// `[yaw_rate, ay, omega_front, omega_rear, ax, vx]` measured.
pub(crate) type Sensors = [f64; 6];

use car::SENSORS;

pub(crate) struct Truth {
    model: SingleTrackHsri,
    pub(crate) state: SingleTrackState,
    pub(crate) rng: ChaCha20Rng,
}

impl Truth {
    pub(crate) fn new(speed: f64, seed: u64) -> Self {
        let vehicle = SingleTrackParams {
            chassis: escort(),
            ..SingleTrackParams::default()
        };
        let model = SingleTrackHsri::new(vehicle, HsriTyre::default());
        Self {
            state: model.straight_rolling_state(speed),
            model,
            rng: ChaCha20Rng::seed_from_u64(seed),
        }
    }

    pub(crate) fn sensors(&mut self, input: &DriverInputVector) -> Sensors {
        let y = self.model.measurement(&self.state, input);
        let outputs = self.model.outputs(&self.state, input);
        let clean = [
            y[0],
            y[1],
            y[2],
            y[3],
            outputs.longitudinal_acceleration,
            self.state[0],
        ];
        let mut noisy = [0.0; 6];
        for ((value, clean), std) in noisy.iter_mut().zip(clean).zip(SENSOR_STD) {
            let draw: f64 = StandardNormal.sample(&mut self.rng);
            *value = clean + std * draw;
        }
        noisy
    }

    pub(crate) fn step(&mut self, input: &DriverInputVector) {
        // Internal steps of 1 ms, as the reference vehicle runs model A.
        for _ in 0..10 {
            self.state = self
                .model
                .step(&self.state, input, 0.001, Integrator::SemiImplicitEuler);
        }
    }
}

fn api() -> Fmi2Api {
    fmi2_api_of!(VehicleStateEstimator)
}

/// The models the robustness tests run on: the FMU's default, the grip model, and model A.
const MODELS: [EstimatorModel; 2] = [
    EstimatorModel::SingleTrackGrip,
    EstimatorModel::SingleTrack5State,
];

/// An estimator on `model` with only the car's parameters set, at 10 ms.
fn estimator(model: EstimatorModel, kind: i32) -> Slave {
    estimator_with(kind, on(model))
}

/// The setting of `model`, for [`estimator_with`].
fn on(model: EstimatorModel) -> impl Fn(&mut Slave) {
    move |s| assert_eq!(s.set_integer(vr::MODEL, model as i32), Fmi2Status::Ok)
}

/// [`estimator`] with more settings before initialisation.
pub(crate) fn estimator_with(kind: i32, settings: impl FnOnce(&mut Slave)) -> Slave {
    let mut s = Slave::instantiate(api(), "robust", GUID).expect("instantiate");
    car::set_car(&mut s, &escort());
    assert_eq!(s.set_real(vr::SAMPLE_TIME, STEP), Fmi2Status::Ok);
    assert_eq!(s.set_integer(vr::ESTIMATOR, kind), Fmi2Status::Ok);
    assert_eq!(s.set_integer(vr::PARTICLE_COUNT, 200), Fmi2Status::Ok);
    settings(&mut s);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    s
}

/// A sine steer at 0.5 Hz while the engine pulls with 150 N·m; the amplitude keeps the lateral
/// acceleration at about 4 m/s² or below (0.04 rad up to 15 m/s, less above), so that the car
/// does not spin at high speed.
fn driver(t: f64, start_speed: f64) -> DriverInputVector {
    let amplitude = (0.04 * (15.0 / start_speed).powi(2)).min(0.04);
    DriverInputVector::new(amplitude * (std::f64::consts::PI * t).sin(), 150.0, 0.0)
}

/// One sample of a run: time, truth `[vx, vy]`, estimate `[vx, vy]`, status.
#[derive(Clone, Copy, Debug)]
struct Record {
    t: f64,
    truth: [f64; 2],
    estimate: [f64; 2],
    status: i32,
}

/// Runs `duration` seconds; `corrupt` may change the sensors of a sample (time, sensors). The
/// estimator is never told the drive torque.
fn run(
    s: &mut Slave,
    start_speed: f64,
    duration: f64,
    mut corrupt: impl FnMut(f64, &mut Sensors),
) -> Vec<Record> {
    let mut truth = Truth::new(start_speed, 7);
    let steps = (duration / STEP).round() as usize;
    let mut records = Vec::with_capacity(steps);
    for k in 0..steps {
        let t = k as f64 * STEP;
        let input = driver(t, start_speed);
        let mut sensors = truth.sensors(&input);
        corrupt(t, &mut sensors);
        assert_eq!(s.set_real(vr::STEERING_ANGLE, input[0]), Fmi2Status::Ok);
        assert_eq!(s.set_reals(&SENSORS, &sensors), Fmi2Status::Ok);
        assert_step(s.do_step(t, STEP), t, &sensors, s);
        truth.step(&input);
        let estimate = s.reals(&[vr::VX_EST, vr::VY_EST]);
        assert!(estimate.iter().all(|v| v.is_finite()), "t = {t}");
        records.push(Record {
            t: t + STEP,
            truth: [truth.state[0], truth.state[1]],
            estimate: [estimate[0], estimate[1]],
            status: s.get_integer(vr::STATUS).1,
        });
    }
    records
}

/// A doStep answered fmi2OK (also the first, where a measurement-row sensor never had a finite
/// value and the step logs that it is treated as missing: tests/unconnected_sensors.rs).
pub(crate) fn assert_step(status: Fmi2Status, _t: f64, _sensors: &Sensors, s: &Slave) {
    assert_eq!(status, Fmi2Status::Ok, "{:?}", s.log.last());
}

/// The largest relative speed error after `from` seconds.
fn worst_speed_error(records: &[Record], from: f64) -> f64 {
    records
        .iter()
        .filter(|r| r.t >= from)
        .map(|r| ((r.estimate[0] - r.truth[0]) / r.truth[0]).abs())
        .fold(0.0, f64::max)
}

const KALMAN_KINDS: [i32; 3] = [
    EstimatorKind::Ekf as i32,
    EstimatorKind::Ukf as i32,
    EstimatorKind::UkfScaled as i32,
];

#[test]
fn torques_unknown_the_speed_stays_within_two_percent_with_and_without_wheel_speeds() {
    for model in MODELS {
        println!("model {model:?}");
        torques_unknown_the_speed_stays_within_two_percent_with_and_without_wheel_speeds_on(model);
    }
}

fn torques_unknown_the_speed_stays_within_two_percent_with_and_without_wheel_speeds_on(
    model: EstimatorModel,
) {
    for kind in KALMAN_KINDS {
        for wheels in [true, false] {
            let mut s = estimator(model, kind);
            let records = run(&mut s, 20.0, 8.0, |_, sensors| {
                if !wheels {
                    sensors[2] = f64::NAN;
                    sensors[3] = f64::NAN;
                }
            });
            let error = worst_speed_error(&records, 0.0);
            assert!(error < 0.02, "kind {kind} wheels {wheels}: {error}");
        }
    }
}

/// A ramp to the limit with the torques unknown: steering rising by 0.05 rad/s
/// from 1 s (three times FMVSS 126's slowly increasing steer, so that this car, whose tyre is
/// the estimator's own, reaches more than 2 % drive slip in 9 s) at 80 km/h, the speed held by a
/// controller on the front drive torque, which the estimator is never told; returns the largest
/// relative vx error after the first second and the largest true front-wheel slip
/// `r ωF / vx − 1`. Without `ax` (`ax_meas` NaN) the reported speed is model A's own state,
/// with it that of the speed filter model A reports from (`model_a`'s `step_reported_speed`).
/// (The study's case, the ReferenceVehicle's Escort with its own tyres, is
/// checked by `harness::robustness`'s test.)
fn slow_ramp_torques_unknown(kind: i32, wheels: bool, ax: bool, slip_std: f64) -> (f64, f64) {
    slow_ramp_torques_unknown_on(
        EstimatorModel::SingleTrack5State,
        kind,
        wheels,
        ax,
        slip_std,
    )
}

/// [`slow_ramp_torques_unknown`] on `model`.
fn slow_ramp_torques_unknown_on(
    model: EstimatorModel,
    kind: i32,
    wheels: bool,
    ax: bool,
    slip_std: f64,
) -> (f64, f64) {
    let mut s = estimator_with(kind, |s| {
        assert_eq!(s.set_integer(vr::MODEL, model as i32), Fmi2Status::Ok);
        assert_eq!(
            s.set_real(vr::UNKNOWN_TORQUE_SLIP_STD, slip_std),
            Fmi2Status::Ok
        );
    });
    let speed = 80.0 / 3.6;
    let radius = escort().front_wheel_radius;
    let mut truth = Truth::new(speed, 11);
    let (mut worst, mut slip) = (0.0f64, 0.0f64);
    for k in 0..900 {
        let t = k as f64 * STEP;
        let steering = (0.05 * (t - 1.0)).clamp(0.0, 0.4);
        // A proportional speed controller, driving only (the car of the study's case).
        let drive = (3000.0 * (speed - truth.state[0])).clamp(0.0, 1500.0);
        let input = DriverInputVector::new(steering, drive, 0.0);
        let mut sensors = truth.sensors(&input);
        if !wheels {
            sensors[2] = f64::NAN;
            sensors[3] = f64::NAN;
        }
        if !ax {
            sensors[4] = f64::NAN;
        }
        assert_eq!(s.set_real(vr::STEERING_ANGLE, steering), Fmi2Status::Ok);
        assert_eq!(s.set_reals(&SENSORS, &sensors), Fmi2Status::Ok);
        assert_step(s.do_step(t, STEP), t, &sensors, &s);
        truth.step(&input);
        let vx = s.get_real(vr::VX_EST).1;
        if t + STEP >= 1.0 {
            worst = worst.max(((vx - truth.state[0]) / truth.state[0]).abs());
        }
        slip = slip.max(radius * truth.state[3] / truth.state[0] - 1.0);
    }
    (worst, slip)
}

#[test]
fn torques_unknown_on_the_slow_ramp_to_the_limit_the_speed_stays_within_two_percent() {
    for kind in KALMAN_KINDS {
        for (wheels, ax) in [(true, true), (false, true), (true, false), (false, false)] {
            let (error, slip) = slow_ramp_torques_unknown(kind, wheels, ax, 0.02);
            assert!(
                error <= 0.02,
                "kind {kind} wheels {wheels} ax {ax}: vx error {error} (front slip {slip})"
            );
        }
    }
    // The driven wheel slips by more than 2 %; read as a speed (unknown_torque_slip_std = 0)
    // it pulls model A's own speed along (measured without ax: 4.9 % against 0.10 % with the
    // rule; here the estimator's tyre is the truth's).
    let ekf = EstimatorKind::Ekf as i32;
    let (error, slip) = slow_ramp_torques_unknown(ekf, true, false, 0.02);
    let (without, _) = slow_ramp_torques_unknown(ekf, true, false, 0.0);
    println!("model A's own speed: {error} with the rule, {without} without");
    assert!(slip > 0.02, "front slip {slip}");
    assert!(
        error < 0.5 * without,
        "{error} with the rule, {without} without"
    );
}

/// The same ramp on the grip model (model 3), whose wheels carry no speed while the torques are
/// unknown (`estimation::models::unknown_torques`): without `ax` its speed prediction has the
/// car coasting, and at the limit, the front tyres at 0.4 rad of steer, the drag of their side
/// force is 2 m/s² that the engine (unknown to the filter) makes good. With the unknown
/// acceleration's random walk (the FMU's `model_grip`, 6 m/s²) `vx_meas` holds the speed:
/// measured 0.3 % off without `ax` (6.8 % without the term, the measured speed then gated).
#[test]
fn torques_unknown_on_the_slow_ramp_the_grip_models_speed_stays_within_two_percent() {
    for kind in KALMAN_KINDS {
        for (wheels, ax) in [(true, true), (false, true), (true, false), (false, false)] {
            let (error, slip) = slow_ramp_torques_unknown_on(
                EstimatorModel::SingleTrackGrip,
                kind,
                wheels,
                ax,
                0.02,
            );
            assert!(
                error <= 0.02,
                "kind {kind} wheels {wheels} ax {ax}: vx error {error} (front slip {slip})"
            );
        }
    }
}

#[test]
fn every_estimator_starts_from_the_measured_speed_whatever_the_true_start() {
    for model in MODELS {
        println!("model {model:?}");
        every_estimator_starts_from_the_measured_speed_whatever_the_true_start_on(model);
    }
}

fn every_estimator_starts_from_the_measured_speed_whatever_the_true_start_on(
    model: EstimatorModel,
) {
    let kinds = [
        EstimatorKind::Lkf as i32,
        EstimatorKind::Ekf as i32,
        EstimatorKind::Ukf as i32,
        EstimatorKind::UkfScaled as i32,
        EstimatorKind::ParticleFilter as i32,
        EstimatorKind::Luenberger as i32,
    ];
    let mut failures = Vec::new();
    for kind in kinds {
        for speed in [1.5, 3.0, 10.0, 30.0, 55.0] {
            let mut s = estimator(model, kind);
            let records = run(&mut s, speed, 2.0, |_, _| {});
            assert_ne!(records[0].status & status::INITIALISING, 0);
            let error = worst_speed_error(&records, 1.0);
            // The particle filter's 200 particles (a debug-build test) scatter vx more. The
            // Luenberger observer has seed 002's fixed gains without the speed anchor (see
            // model_a.rs): at walking pace, far from any tuning, it keeps within 10 % only.
            let bound = match EstimatorKind::try_from(kind) {
                Ok(EstimatorKind::ParticleFilter) => 0.03,
                Ok(EstimatorKind::Luenberger) if speed < 5.0 => 0.1,
                _ => 0.02,
            };
            if error >= bound {
                failures.push(format!("kind {kind} start {speed} m/s: {error:.3}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The largest |vy| difference between a corrupted run and the same run without corruption,
/// and the status bits of the corrupted run.
fn largest_change(
    model: EstimatorModel,
    kind: i32,
    corrupt: impl FnMut(f64, &mut Sensors),
) -> (f64, i32) {
    largest_change_with(kind, on(model), 20.0, corrupt)
}

/// [`largest_change`] on the estimator `settings` make and from `start_speed`.
fn largest_change_with(
    kind: i32,
    settings: impl Fn(&mut Slave),
    start_speed: f64,
    corrupt: impl FnMut(f64, &mut Sensors),
) -> (f64, i32) {
    let clean = run(
        &mut estimator_with(kind, &settings),
        start_speed,
        4.0,
        |_, _| {},
    );
    let corrupted = run(
        &mut estimator_with(kind, &settings),
        start_speed,
        4.0,
        corrupt,
    );
    let change = clean
        .iter()
        .zip(&corrupted)
        .map(|(a, b)| (a.estimate[1] - b.estimate[1]).abs())
        .fold(0.0, f64::max);
    let bits = corrupted.iter().fold(0, |bits, r| bits | r.status);
    (change, bits)
}

#[test]
fn one_glitch_on_any_sensor_or_a_zero_row_is_gated() {
    for model in MODELS {
        println!("model {model:?}");
        one_glitch_on_any_sensor_or_a_zero_row_is_gated_on(model);
    }
}

fn one_glitch_on_any_sensor_or_a_zero_row_is_gated_on(model: EstimatorModel) {
    // vy's own noise: its standard deviation at the end of a clean run is about 0.05 m/s.
    let glitches: [(usize, f64); 4] = [(0, 3.0), (1, 100.0), (2, 1e4), (3, 1e4)];
    for kind in KALMAN_KINDS {
        for (row, value) in glitches {
            let (change, bits) = largest_change(model, kind, |t, sensors| {
                if (t - 2.0).abs() < 1e-9 {
                    sensors[row] = value;
                }
            });
            assert!(
                change < 0.02,
                "kind {kind} row {row}: vy changed by {change}"
            );
            assert_ne!(bits & status::ROW_GATED, 0);
        }
        let (change, bits) = largest_change(model, kind, |t, sensors| {
            if (t - 2.0).abs() < 1e-9 {
                *sensors = [0.0; 6];
            }
        });
        assert!(
            change < 0.02,
            "kind {kind} zero row: vy changed by {change}"
        );
        assert_ne!(bits & status::ROW_GATED, 0);
    }
}

#[test]
fn after_half_a_second_without_a_sensor_the_estimate_is_back_within_a_second() {
    for model in MODELS {
        println!("model {model:?}");
        after_half_a_second_without_a_sensor_the_estimate_is_back_within_a_second_on(model);
    }
}

fn after_half_a_second_without_a_sensor_the_estimate_is_back_within_a_second_on(
    model: EstimatorModel,
) {
    for kind in KALMAN_KINDS {
        for row in 0..6 {
            let clean = run(&mut estimator(model, kind), 20.0, 4.0, |_, _| {});
            let outage = run(&mut estimator(model, kind), 20.0, 4.0, |t, sensors| {
                if (1.5..2.0).contains(&t) {
                    sensors[row] = f64::NAN;
                }
            });
            for (a, b) in clean.iter().zip(&outage).filter(|(a, _)| a.t >= 3.0) {
                let vy_change = (a.estimate[1] - b.estimate[1]).abs();
                let vx_change = (a.estimate[0] - b.estimate[0]).abs();
                assert!(
                    vy_change < 0.02 && vx_change < 0.01 * a.truth[0],
                    "kind {kind} row {row} at {}: {vx_change} {vy_change}",
                    a.t
                );
            }
        }
    }
}

/// Without the start from the measurements and without vx_meas, the EKF starts at the default
/// 18 m/s against a true 35 m/s, driving straight for `samples` samples; `corrupt` may change
/// the sensors of sample k. Returns the status bits seen, the last vx estimate and the true vx.
fn far_off_start(samples: usize, mut corrupt: impl FnMut(usize, &mut Sensors)) -> (i32, f64, f64) {
    let mut s = estimator_with(EstimatorKind::Ekf as i32, |s| {
        assert_eq!(
            s.set_boolean(vr::START_FROM_MEASUREMENTS, false),
            Fmi2Status::Ok
        );
    });
    let mut truth = Truth::new(35.0, 3);
    let mut bits = 0;
    let mut last = 0.0;
    for k in 0..samples {
        let t = k as f64 * STEP;
        let input = DriverInputVector::new(0.0, 0.0, 0.0);
        let mut sensors = truth.sensors(&input);
        sensors[5] = f64::NAN;
        corrupt(k, &mut sensors);
        s.set_reals(&SENSORS, &sensors);
        assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok);
        truth.step(&input);
        bits |= s.get_integer(vr::STATUS).1;
        last = s.get_real(vr::VX_EST).1;
    }
    (bits, last, truth.state[0])
}

#[test]
fn a_filter_started_far_off_is_readmitted_instead_of_locking_itself_out() {
    // The gate rejects the wheel speeds, and after readmit_time the filter is re-seeded from
    // them.
    let (bits, last, true_vx) = far_off_start(300, |_, _| {});
    assert_ne!(bits & status::ROW_GATED, 0);
    assert_ne!(bits & status::SENSOR_READMITTED, 0);
    assert!((last - true_vx).abs() < 0.05 * true_vx, "{last}");
}

/// The far-off start of the test above, with the wheel speeds logged at half the filter's rate
/// (NaN every other sample, as a replayed log with a slower channel reads): a missing sample
/// neither counts nor breaks the run of rejected samples, so the wheels are still re-admitted.
/// Before, each NaN reset the count and the filter stayed at its wrong start for good.
#[test]
fn a_sensor_at_half_the_rate_is_readmitted_too() {
    let (bits, last, true_vx) = far_off_start(400, |k, sensors| {
        if k % 2 == 1 {
            sensors[2] = f64::NAN;
            sensors[3] = f64::NAN;
        }
    });
    assert_ne!(bits & status::SENSOR_READMITTED, 0);
    assert!((last - true_vx).abs() < 0.05 * true_vx, "{last}");
}

#[test]
fn braking_to_a_stop_standing_and_pulling_away_stay_sane_and_pick_up_again() {
    for model in MODELS {
        println!("model {model:?}");
        braking_to_a_stop_standing_and_pulling_away_stay_sane_and_pick_up_again_on(model);
    }
}

fn braking_to_a_stop_standing_and_pulling_away_stay_sane_and_pick_up_again_on(
    model: EstimatorModel,
) {
    // Sensors of a car that decelerates from 10 m/s to a stop in 5 s, stands 10 s, pulls away
    // to 5 m/s in 5 s and then reverses at -1 m/s (speed sensors only: the estimator has no
    // torques, and model A is not simulated through standstill).
    let radius = escort().front_wheel_radius;
    let speed = |t: f64| match t {
        t if t < 5.0 => 10.0 - 2.0 * t,
        t if t < 15.0 => 0.0,
        t if t < 20.0 => t - 15.0,
        t if t < 22.0 => 5.0 - 3.0 * (t - 20.0),
        _ => -1.0,
    };
    let mut s = estimator(model, EstimatorKind::Ekf as i32);
    let mut picked_up = false;
    for k in 0..2400 {
        let t = k as f64 * STEP;
        let v = speed(t);
        let ax = (speed(t + STEP) - v) / STEP;
        let sensors = [0.0, 0.0, v / radius, v / radius, ax, v];
        s.set_reals(&SENSORS, &sensors);
        assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok);
        let outputs = s.reals(&[vr::VX_EST, vr::SIDESLIP_EST, vr::SIDESLIP_STD]);
        assert!(
            outputs.iter().all(|v| v.is_finite()),
            "t = {t}: {outputs:?}"
        );
        assert!(outputs[1].abs() < 0.2, "t = {t}: sideslip {}", outputs[1]);
        let status = s.get_integer(vr::STATUS).1;
        if (8.0..14.0).contains(&t) {
            assert_ne!(status & status::BELOW_MIN_SPEED, 0, "t = {t}");
            // Standing: the sideslip of the steering geometry (straight: 0), marked uncertain.
            assert_eq!(outputs[1], 0.0);
            assert!(outputs[2] >= 0.1, "t = {t}: sideslip std {}", outputs[2]);
        }
        if (17.5..20.0).contains(&t) {
            // Moving again: never frozen, the estimate follows.
            assert_eq!(status & status::BELOW_MIN_SPEED, 0, "t = {t}");
            assert!(
                (outputs[0] - v).abs() < 0.1 * v,
                "t = {t}: {} vs {v}",
                outputs[0]
            );
            picked_up = true;
        }
    }
    assert!(picked_up);
}

#[test]
fn the_fmu_waits_for_a_measured_speed_before_it_starts() {
    for model in MODELS {
        println!("model {model:?}");
        the_fmu_waits_for_a_measured_speed_before_it_starts_on(model);
    }
}

fn the_fmu_waits_for_a_measured_speed_before_it_starts_on(model: EstimatorModel) {
    let mut s = estimator(model, EstimatorKind::Ekf as i32);
    // The all-zero row a master sends before its first values.
    s.set_reals(&SENSORS, &[0.0; 6]);
    assert_eq!(s.do_step(0.0, STEP), Fmi2Status::Ok);
    assert_ne!(s.get_integer(vr::STATUS).1 & status::INITIALISING, 0);
    s.set_reals(&SENSORS, &[0.0, 0.0, 80.0, 80.0, 0.0, 27.5]);
    assert_eq!(s.do_step(STEP, STEP), Fmi2Status::Ok);
    assert_ne!(s.get_integer(vr::STATUS).1 & status::INITIALISING, 0);
    // Started from vx_meas = 27.5 m/s and predicted one sample on.
    let vx = s.get_real(vr::VX_EST).1;
    assert!((vx - 27.5).abs() < 0.1, "{vx}");
}

/// The outputs of initialisation, before the first doStep: while the filter
/// waits for its measured start they say so (status 512) and give the speed measured so far with
/// the steering geometry's sideslip, not the parameters' start (`vx_initial`, 18 m/s, with its
/// start std and status 0, whatever the sensors read, would look like an estimate).
#[test]
fn the_outputs_of_initialisation_say_initialising_and_give_the_measured_speed() {
    for model in MODELS {
        println!("model {model:?}");
        the_outputs_of_initialisation_say_initialising_and_give_the_measured_speed_on(model);
    }
}

fn the_outputs_of_initialisation_say_initialising_and_give_the_measured_speed_on(
    model: EstimatorModel,
) {
    let mut measured = estimator_with(EstimatorKind::Ekf as i32, |s| {
        on(model)(s);
        assert_eq!(
            s.set_reals(&SENSORS, &[0.05, 0.0, 80.0, 85.0, 0.0, 27.5]),
            Fmi2Status::Ok
        );
    });
    assert_ne!(measured.get_integer(vr::STATUS).1 & status::INITIALISING, 0);
    let [vx, sideslip, sideslip_std] =
        [vr::VX_EST, vr::SIDESLIP_EST, vr::SIDESLIP_STD].map(|r| measured.get_real(r).1);
    assert_eq!(vx, 27.5);
    assert_eq!(sideslip, 0.0);
    assert!(sideslip_std >= 0.1, "{sideslip_std}");
    // The rest as measured too, not the *_initial parameters (omega_initial 60 rad/s read as a
    // wheel slip of 0.147 on a car with 0.344 m wheels): the gyro, the wheels and their slip,
    // tyres without slip angle and the steady turn's ay.
    let outputs = measured.reals(&[
        vr::YAW_RATE_EST,
        vr::OMEGA_FRONT_EST,
        vr::OMEGA_REAR_EST,
        vr::SLIP_FRONT_EST,
        vr::SLIP_REAR_EST,
        vr::SLIP_ANGLE_FRONT_EST,
        vr::SLIP_ANGLE_REAR_EST,
        vr::AY_EST,
    ]);
    let radius = measured.get_real(vr::WHEEL_RADIUS_REAR).1;
    let rear_slip = (85.0 * radius - 27.5) / 27.5;
    let expected = [
        0.05,
        80.0,
        85.0,
        (80.0 * radius - 27.5) / 27.5,
        rear_slip,
        0.0,
        0.0,
        1.375,
    ];
    for (got, want) in outputs.iter().zip(expected) {
        assert!(
            (got - want).abs() < 1e-12,
            "{outputs:?} against {expected:?}"
        );
    }
    // nothing measured yet: still initialising
    let mut unset = estimator(model, EstimatorKind::Ekf as i32);
    assert_ne!(unset.get_integer(vr::STATUS).1 & status::INITIALISING, 0);
}

#[test]
fn model_b_gates_glitches_and_starts_from_the_measurements_too() {
    let model_b = |s: &mut Slave| {
        assert_eq!(
            s.set_integer(vr::MODEL, EstimatorModel::TwoTrack3State as i32),
            Fmi2Status::Ok
        );
    };
    for kind in KALMAN_KINDS {
        let clean = run(&mut estimator_with(kind, model_b), 25.0, 4.0, |_, _| {});
        assert_ne!(clean[0].status & status::INITIALISING, 0);
        // One sample of `value` on sensor `row` at 2 s.
        let glitch = |row: usize, value: f64| {
            move |t: f64, sensors: &mut Sensors| {
                if (t - 2.0).abs() < 1e-9 {
                    sensors[row] = value;
                }
            }
        };
        for (row, value) in [(0, 3.0), (1, 100.0)] {
            let (change, bits) = largest_change_with(kind, model_b, 25.0, glitch(row, value));
            // Model B's default Q gives each ay sample a large gain: losing one moves vy by about
            // 0.02 m/s (0.05° of sideslip at 25 m/s), what one noisy sample does too.
            assert!(
                change < 0.05,
                "kind {kind} row {row}: vy changed by {change}"
            );
            assert_ne!(bits & status::ROW_GATED, 0);
        }
        // ax is no row of model B but shifts its axle loads: one sample of a plausible 14 m/s²
        // (a pitch transfer of 60 % of the front axle's load for 10 ms) or of an implausible
        // 100 m/s² (not used) moves the estimate by no more than a noisy sample does (measured:
        // 0.0085 and 0.0002 m/s of vy).
        for value in [14.0, 100.0] {
            let (change, _) = largest_change_with(kind, model_b, 25.0, glitch(4, value));
            assert!(
                change < 0.05,
                "kind {kind} ax glitch {value}: vy changed by {change}"
            );
        }
    }
}

#[test]
fn standing_and_reversing_report_the_measured_speed_as_uncertain_and_pulling_away_reseeds() {
    for model in MODELS {
        println!("model {model:?}");
        standing_and_reversing_report_the_measured_speed_as_uncertain_and_pulling_away_reseeds_on(
            model,
        );
    }
}

fn standing_and_reversing_report_the_measured_speed_as_uncertain_and_pulling_away_reseeds_on(
    model: EstimatorModel,
) {
    // Sensors of a car that brakes from 3 m/s to a stop, stands 3 s, reverses to -2 m/s, holds
    // it, and drives forward through standstill to 4 m/s. While held, vx_est
    // is the measured speed of this sample (the filter's outputs are one sample ahead), so it
    // lags by one sample, 0.01 m/s at these accelerations.
    let radius = escort().front_wheel_radius;
    let speed = |t: f64| match t {
        t if t < 3.0 => 3.0 - t,
        t if t < 6.0 => 0.0,
        t if t < 8.0 => -(t - 6.0),
        t if t < 10.0 => -2.0,
        t if t < 16.0 => -2.0 + (t - 10.0),
        _ => 4.0,
    };
    let mut s = estimator(model, EstimatorKind::Ekf as i32);
    let (mut stood, mut reversed, mut pulled_away) = (false, false, false);
    for k in 0..1800 {
        let t = k as f64 * STEP;
        let v = speed(t);
        let ax = (speed(t + STEP) - v) / STEP;
        s.set_reals(&SENSORS, &[0.0, 0.0, v / radius, v / radius, ax, v]);
        assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok);
        let [vx, vx_std, sideslip_std] = s.reals(&[vr::VX_EST, vr::VX_STD, vr::SIDESLIP_STD])[..]
        else {
            unreachable!()
        };
        let held = s.get_integer(vr::STATUS).1 & status::BELOW_MIN_SPEED != 0;
        assert!((vx - v).abs() < 0.2, "t = {t}: vx_est {vx} vs {v}");
        if (3.5..6.0).contains(&t) {
            // Standing: the measured 0, with at least vx_meas's std (0.1 m/s, the default of
            // measurement_noise_std_vx) and a sideslip std of at least 5°.
            assert!(held, "t = {t}");
            assert!(vx.abs() < 1e-9 && vx_std >= 0.1, "t = {t}: {vx} ± {vx_std}");
            assert!(sideslip_std >= 5f64.to_radians(), "t = {t}: {sideslip_std}");
            // the wheels stand too, not the estimate of the last sample above min_speed
            let wheels = s.reals(&[vr::OMEGA_FRONT_EST, vr::OMEGA_REAR_EST, vr::SLIP_REAR_EST]);
            assert!(wheels.iter().all(|w| w.abs() < 1e-9), "t = {t}: {wheels:?}");
            stood = true;
        }
        reversed |= (8.5..10.0).contains(&t) && held && (vx + 2.0).abs() < 1e-9;
        if t >= 13.5 {
            // Forward above min_speed again: the filter was re-seeded and runs.
            assert!(!held, "t = {t}: still held at {vx}");
            pulled_away = true;
        }
    }
    assert!(stood && reversed && pulled_away);
}

#[test]
fn pulling_away_with_the_drive_torque_known_the_estimate_follows_without_re_seeding() {
    for model in MODELS {
        println!("model {model:?}");
        pulling_away_with_the_drive_torque_known_the_estimate_follows_without_re_seeding_on(model);
    }
}

fn pulling_away_with_the_drive_torque_known_the_estimate_follows_without_re_seeding_on(
    model: EstimatorModel,
) {
    // Pulling away with the drive torque told (600 N·m on the front axle from
    // 1.2 m/s, series sensor noise): the estimate follows within vx_meas's noise (0.1 m/s) and
    // is never re-seeded. In the study (the ReferenceVehicle's Escort, whose tyres are not the
    // estimator's) the wheel estimates cycled 7.5 / 2.3 rad/s about a true 5.0 there, the gate
    // rejected the wheel rows and the re-admission re-seeded every 0.5 s (vx 0.46-0.60 m/s
    // behind); the low-speed wheel noise of model A ends that, checked on the study's
    // standstill case by harness::robustness's test. On this truth, whose tyre is the
    // estimator's own, the wheels stay in the tyre's linear range and do not cycle even without
    // that rule: this test guards the pull-away itself, not the rule.
    let mut s = estimator(model, EstimatorKind::Ekf as i32);
    let mut truth = Truth::new(1.2, 5);
    let input = DriverInputVector::new(0.0, 600.0, 0.0);
    assert_eq!(s.set_real(vr::DRIVE_TORQUE, 600.0), Fmi2Status::Ok);
    let (mut moving, mut worst) = (0, 0.0f64);
    for k in 0..400 {
        let t = k as f64 * STEP;
        let sensors = truth.sensors(&input);
        s.set_reals(&SENSORS, &sensors);
        assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok);
        truth.step(&input);
        let status = s.get_integer(vr::STATUS).1;
        let vx = s.get_real(vr::VX_EST).1;
        assert_eq!(status & status::SENSOR_READMITTED, 0, "t = {t}");
        if t >= 0.5 {
            worst = worst.max((vx - truth.state[0]).abs());
            moving += 1;
        }
    }
    assert!(
        worst < 0.1,
        "vx error up to {worst} m/s; now at {}",
        truth.state[0]
    );
    assert!(moving > 300);
}

/// Parking steer at walking pace (the robustness case `out_of_range`): a steady
/// turn at 3 m/s with the road wheels at 45° and 1 rad/s of yaw rate, every sensor consistent
/// with it. The rear axle rolls without sliding sideways at such speeds (Rajamani, Vehicle
/// Dynamics and Control, 2nd ed., §2.2), so the sideslip is `atan(lR r / vx)` = 26.7° on the
/// Escort. Started with `vy = 0`, as before, the estimate stayed tens of degrees off and its vx
/// left the measured speed; the start from the rear axle's kinematics and the low-speed model
/// noise keep both sane.
#[test]
fn a_parking_steer_at_walking_pace_gives_the_rear_axles_kinematic_sideslip() {
    for model in MODELS {
        println!("model {model:?}");
        a_parking_steer_at_walking_pace_gives_the_rear_axles_kinematic_sideslip_on(model);
    }
}

fn a_parking_steer_at_walking_pace_gives_the_rear_axles_kinematic_sideslip_on(
    model: EstimatorModel,
) {
    let (speed, yaw_rate, steer) = (3.0, 1.0, std::f64::consts::FRAC_PI_4);
    let car = escort();
    let expected = (car.cog_to_rear_axle * yaw_rate / speed).atan();
    let mut s = estimator(model, EstimatorKind::Ekf as i32);
    let wheel = speed / car.front_wheel_radius;
    // Centripetal only: ay = vx r, and ax = -r vy of the steady turn (dvx/dt = 0).
    let lateral_speed = car.cog_to_rear_axle * yaw_rate;
    let sensors = [
        yaw_rate,
        speed * yaw_rate,
        wheel,
        wheel,
        -yaw_rate * lateral_speed,
        speed,
    ];
    let mut worst = (0.0f64, 0.0f64);
    for k in 0..100 {
        assert_eq!(s.set_real(vr::STEERING_ANGLE, steer), Fmi2Status::Ok);
        assert_eq!(s.set_reals(&SENSORS, &sensors), Fmi2Status::Ok);
        assert_eq!(s.do_step(k as f64 * STEP, STEP), Fmi2Status::Ok);
        let [vx, sideslip] = [vr::VX_EST, vr::SIDESLIP_EST].map(|r| s.reals(&[r])[0]);
        worst.0 = worst.0.max((sideslip - expected).abs());
        worst.1 = worst.1.max((vx - speed).abs() / speed);
    }
    assert!(
        worst.0 < 5f64.to_radians() && worst.1 < 0.05,
        "largest sideslip error {:.1}°, largest vx error {:.1} % (expected sideslip {:.1}°)",
        worst.0.to_degrees(),
        100.0 * worst.1,
        expected.to_degrees()
    );
}

/// A braked turn with the brake torque not reported: the grip model's `ay_est` is its `ay` row's
/// prediction, from the tyre forces of freely rolling wheels, not from its wheel states, which
/// keep the braked wheels' measured slip. Taken from the wheel states the
/// braked tyres' combined slip took the side force off them: on the campaigns' braked turn of the
/// BMW 320i 1.6 against a true 7.5 m/s², and here up to 0.64 m/s² off (now 0.12; 0.25 and
/// 0.14 before at 2000 and 1000 N·m).
#[test]
fn braking_in_a_turn_with_the_torques_unknown_the_grip_model_s_ay_follows_the_car() {
    let mut s = estimator(EstimatorModel::SingleTrackGrip, EstimatorKind::Ekf as i32);
    let mut truth = Truth::new(20.0, 7);
    let mut worst = 0.0f64;
    for k in 0..400 {
        let t = k as f64 * STEP;
        let steer = 0.03 * (t / 0.5).min(1.0);
        let brake = if t >= 2.0 { 3000.0 } else { 0.0 };
        let input = DriverInputVector::new(steer, 0.0, brake);
        let sensors = truth.sensors(&input);
        assert_eq!(s.set_real(vr::STEERING_ANGLE, steer), Fmi2Status::Ok);
        assert_eq!(s.set_reals(&SENSORS, &sensors), Fmi2Status::Ok);
        assert_step(s.do_step(t, STEP), t, &sensors, &s);
        truth.step(&input);
        if t >= 2.5 {
            let ay = truth
                .model
                .outputs(&truth.state, &input)
                .lateral_acceleration;
            worst = worst.max((s.reals(&[vr::AY_EST])[0] - ay).abs());
        }
    }
    assert!(worst < 0.3, "ay_est up to {worst} m/s² off while braking");
}
