//! The VehicleStateEstimator with `model = 2` (the 3-state seed-001 form) through its C ABI, fed
//! by a model-B reference vehicle (two-track, Magic Formula) with ESP-like sensor noise generated
//! here: the Kalman estimators and the Luenberger observer track the sideslip, the outputs
//! follow the XML descriptions, FMU states continue bit-identically.

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::{Fmi2Api, Slave};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use vehicle_models::{
    DriverInputVector, ReferenceModelKind, ReferenceVehicle, ReferenceVehicleParams,
};
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel, GUID};
use VehicleStateEstimator::status;

fn api() -> Fmi2Api {
    fmi2_api_of!(VehicleStateEstimator)
}

/// The sensors model B reads: `[yaw_rate, ay, omega_front, omega_rear, vx]`.
const SENSORS: [u32; 5] = [
    vr::YAW_RATE_MEAS,
    vr::AY_MEAS,
    vr::OMEGA_FRONT_MEAS,
    vr::OMEGA_REAR_MEAS,
    vr::VX_MEAS,
];
const ESTIMATES: [u32; 18] = [
    vr::VX_EST,
    vr::VY_EST,
    vr::YAW_RATE_EST,
    vr::OMEGA_FRONT_EST,
    vr::OMEGA_REAR_EST,
    vr::SIDESLIP_EST,
    vr::AY_EST,
    vr::SLIP_ANGLE_FRONT_EST,
    vr::SLIP_ANGLE_REAR_EST,
    vr::SLIP_FRONT_EST,
    vr::SLIP_REAR_EST,
    vr::VX_STD,
    vr::VY_STD,
    vr::YAW_RATE_STD,
    vr::OMEGA_FRONT_STD,
    vr::OMEGA_REAR_STD,
    vr::SIDESLIP_STD,
    vr::NIS,
];

/// Sensor noise `[yaw_rate, ay, omega, vx]`: the ESP-sensor levels the estimation crate assumes
/// for seed 001 (0.005 rad/s, 0.05 m/s²), wheel speeds and CAN speed a little noisy.
const SENSOR_STD: [f64; 4] = [0.005, 0.05, 0.05, 0.02];
const SAMPLE_TIME: f64 = 0.01;
const SPEED: f64 = 65.0 / 3.6;

/// A 2.5° road-wheel steering step at 1 s, ramped over 0.1 s: a seed-001-like step manoeuvre at
/// 65 km/h that reaches about 6 m/s².
fn steering(t: f64) -> f64 {
    2.5_f64.to_radians() * ((t - 1.0) / 0.1).clamp(0.0, 1.0)
}

/// Model B at 1 ms, no process noise, with the sensor noise above.
struct Truth {
    vehicle: ReferenceVehicle,
    rng: ChaCha20Rng,
}

impl Truth {
    fn new(seed: u64) -> Self {
        let params = ReferenceVehicleParams {
            model: ReferenceModelKind::TwoTrack,
            ..ReferenceVehicleParams::default()
        };
        Self {
            vehicle: ReferenceVehicle::new(&params, SPEED),
            rng: ChaCha20Rng::seed_from_u64(seed),
        }
    }

    fn noise(&mut self, std: f64) -> f64 {
        let draw: f64 = StandardNormal.sample(&mut self.rng);
        std * draw
    }

    /// `[yaw_rate, ay, omega_front, omega_rear, vx]` as measured.
    fn measure(&mut self, input: &DriverInputVector) -> [f64; 5] {
        let truth = self.vehicle.truth(input);
        [
            truth.yaw_rate + self.noise(SENSOR_STD[0]),
            truth.lateral_acceleration + self.noise(SENSOR_STD[1]),
            truth.omega_front + self.noise(SENSOR_STD[2]),
            truth.omega_rear + self.noise(SENSOR_STD[2]),
            truth.longitudinal_velocity + self.noise(SENSOR_STD[3]),
        ]
    }
}

/// An instance with model 2, the given estimator and the seed-001 noise settings of the
/// estimation crate (`SEED_001_PROCESS_NOISE_STD`, `SEED_001_MEASUREMENT_NOISE_STD`).
/// The robustness options (start from the measurements, gate) are off: these tests check
/// seed 001's filters.
fn slave(estimator: i32) -> Slave {
    let mut s = Slave::instantiate(api(), "estimator", GUID).expect("instantiate");
    for flag in [vr::START_FROM_MEASUREMENTS, vr::GATE_MEASUREMENTS] {
        assert_eq!(s.set_boolean(flag, false), Fmi2Status::Ok);
    }
    assert_eq!(
        s.set_integer(vr::MODEL, EstimatorModel::TwoTrack3State as i32),
        Fmi2Status::Ok
    );
    assert_eq!(s.set_integer(vr::ESTIMATOR, estimator), Fmi2Status::Ok);
    assert_eq!(s.set_integer(vr::PARTICLE_COUNT, 200), Fmi2Status::Ok);
    let settings = [
        (vr::SAMPLE_TIME, SAMPLE_TIME),
        (vr::PROCESS_NOISE_STD_SIDESLIP, 1e-3),
        (vr::PROCESS_NOISE_STD_YAW_RATE, 2e-3),
        (vr::PROCESS_NOISE_STD_AY, 0.1),
        (vr::MEASUREMENT_NOISE_STD_AY, SENSOR_STD[1]),
        (vr::MEASUREMENT_NOISE_STD_YAW_RATE, SENSOR_STD[0]),
        (vr::MEASUREMENT_NOISE_STD_VX, SENSOR_STD[3]),
        (vr::LKF_VX, SPEED),
        // The truth is the filter's own model: no tyre-law error to carry (seed 001).
        (vr::AY_MODEL_ERROR, 0.0),
        // Seed 001's linear comparison filter is linearised once; see
        // `the_gain_scheduled_lkf_on_model_b_tracks_as_the_ekf_does` for the scheduled one.
        (vr::SCHEDULE_THRESHOLD, 0.0),
        (vr::OBSERVER_SCHEDULE_THRESHOLD, 0.0),
    ];
    for (reference, value) in settings {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
    }
    s
}

/// Steps of 10 ms (one sample each) from sample `first`; returns every output bitwise and the
/// squared sideslip errors against the truth.
fn run(s: &mut Slave, truth: &mut Truth, first: usize, steps: usize) -> (Vec<u64>, f64) {
    let (trace, errors) = run_with_errors(s, truth, first, steps);
    (trace, errors.iter().map(|e| e * e).sum())
}

/// [`run`] with the sideslip error of every step.
fn run_with_errors(
    s: &mut Slave,
    truth: &mut Truth,
    first: usize,
    steps: usize,
) -> (Vec<u64>, Vec<f64>) {
    let mut trace = Vec::new();
    let mut errors = Vec::with_capacity(steps);
    for k in first..first + steps {
        let t = k as f64 * SAMPLE_TIME;
        let input = DriverInputVector::new(steering(t), 0.0, 0.0);
        let y = truth.measure(&input);
        assert_eq!(s.set_real(vr::STEERING_ANGLE, input[0]), Fmi2Status::Ok);
        assert_eq!(s.set_reals(&SENSORS, &y), Fmi2Status::Ok);
        assert_eq!(
            s.do_step(t, SAMPLE_TIME),
            Fmi2Status::Ok,
            "{:?}",
            s.log.last()
        );
        for _ in 0..10 {
            truth.vehicle.step(&input, 0.001).expect("reference step");
        }
        let estimate = s.reals(&ESTIMATES);
        assert!(
            estimate.iter().all(|v| v.is_finite()),
            "k = {k}: {estimate:?}"
        );
        // The outputs hold the prediction for the next sample instant: compare with the truth there.
        let sideslip = truth.vehicle.truth(&input).sideslip;
        errors.push(estimate[5] - sideslip);
        trace.extend(estimate.iter().map(|v| v.to_bits()));
        trace.push(s.get_integer(vr::STATUS).1 as u64);
    }
    (trace, errors)
}

/// Sideslip RMSE over 4 s of the steering step.
fn sideslip_rmse(estimator: i32) -> f64 {
    sideslip_rmse_scheduled(estimator, 0.0)
}

/// [`sideslip_rmse`] with the linear estimators (LKF and observer) gain-scheduled at
/// `schedule_threshold`.
fn sideslip_rmse_scheduled(estimator: i32, schedule_threshold: f64) -> f64 {
    let mut s = slave(estimator);
    for threshold in [vr::SCHEDULE_THRESHOLD, vr::OBSERVER_SCHEDULE_THRESHOLD] {
        assert_eq!(s.set_real(threshold, schedule_threshold), Fmi2Status::Ok);
    }
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    let mut truth = Truth::new(3);
    let steps = 400;
    let (_, squared) = run(&mut s, &mut truth, 0, steps);
    (squared / steps as f64).sqrt()
}

#[test]
fn kalman_estimators_on_model_b_track_the_sideslip_of_the_two_track_vehicle() {
    let ekf = sideslip_rmse(EstimatorKind::Ekf as i32);
    let ukf = sideslip_rmse(EstimatorKind::Ukf as i32);
    let scaled = sideslip_rmse(EstimatorKind::UkfScaled as i32);
    let lkf = sideslip_rmse(EstimatorKind::Lkf as i32);
    let particle = sideslip_rmse(EstimatorKind::ParticleFilter as i32);
    println!("sideslip RMSE: EKF {ekf}, UKF {ukf}, scaled UKF {scaled}, LKF {lkf}, PF {particle}");
    // Measured with this seed: EKF ≈ UKF ≈ scaled UKF ≈ 3.4e-4 rad, PF (200
    // particles) 3.9e-4 rad, the linear comparison filter of seed 001 1.6e-3 rad.
    for (name, rmse) in [
        ("EKF", ekf),
        ("UKF", ukf),
        ("scaled UKF", scaled),
        ("PF", particle),
    ] {
        assert!(rmse < 1e-3, "{name} sideslip RMSE {rmse} rad");
    }
    // Seed 001's finding: the Magic-Formula filters beat the linear single-track filter.
    assert!(
        lkf > 3.0 * ekf.max(ukf),
        "LKF {lkf} vs EKF {ekf}, UKF {ukf}"
    );
}

#[test]
fn the_gain_scheduled_lkf_on_model_b_tracks_as_the_ekf_does() {
    // Seed 001's finding holds for the LKF linearised once (above); re-linearised about its
    // estimate (schedule_threshold 1, coarser than the default 0.001) it is within 10 % of the
    // EKF.
    let scheduled = sideslip_rmse_scheduled(EstimatorKind::Lkf as i32, 1.0);
    let ekf = sideslip_rmse(EstimatorKind::Ekf as i32);
    assert!(
        scheduled < 1.1 * ekf,
        "scheduled LKF {scheduled}, EKF {ekf}"
    );
}

#[test]
fn model_b_outputs_follow_the_descriptions() {
    let mut s = slave(EstimatorKind::Ekf as i32);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let mut truth = Truth::new(4);
    run(&mut s, &mut truth, 0, 250);
    let e = s.reals(&ESTIMATES);
    let (vx, vy, sideslip) = (e[0], e[1], e[5]);
    // vx_est is the speed input: the last vx_meas.
    assert_eq!(vx, s.get_real(vr::VX_MEAS).1);
    assert!((vy - vx * sideslip.tan()).abs() < 1e-12, "vy {vy}");
    // The wheel speeds are the last measurements, with the measurement noise as their std.
    assert_eq!(e[3], s.get_real(vr::OMEGA_FRONT_MEAS).1);
    assert_eq!(e[4], s.get_real(vr::OMEGA_REAR_MEAS).1);
    assert_eq!(e[11], SENSOR_STD[3], "vx_std = measurement_noise_std_vx");
    assert_eq!(e[14], s.get_real(vr::MEASUREMENT_NOISE_STD_OMEGA_FRONT).1);
    // In the turn: positive yaw rate, ay, front slip angle; the slips are small when rolling.
    assert!(e[2] > 0.1 && e[6] > 3.0 && e[7] > 0.0, "{e:?}");
    assert!(e[9].abs() < 0.02 && e[10].abs() < 0.02, "{e:?}");
    assert!(e[16] > 0.0 && e[12] > 0.0, "{e:?}");
    assert_eq!(s.get_integer(vr::ROWS_USED), (Fmi2Status::Ok, 2));

    // vx_meas missing: the wheel-speed fallback stands in (status bit 1), nothing is NaN.
    let input = DriverInputVector::new(steering(2.5), 0.0, 0.0);
    let mut y = truth.measure(&input);
    y[4] = f64::NAN;
    s.set_reals(&SENSORS, &y);
    assert_eq!(s.do_step(2.5, SAMPLE_TIME), Fmi2Status::Ok);
    let e = s.reals(&ESTIMATES);
    assert!(e.iter().all(|v| v.is_finite()), "{e:?}");
    let fallback = 0.3 * 0.5 * (y[2] + y[3]);
    assert!(
        (e[0] - fallback).abs() < 1e-12,
        "vx_est {} vs {fallback}",
        e[0]
    );
    assert_eq!(
        s.get_integer(vr::STATUS).1 & status::ROW_SKIPPED,
        status::ROW_SKIPPED
    );

    // No speed at all: the filter holds (status bit 32), the outputs stay finite.
    s.set_reals(&SENSORS, &[y[0], y[1], 0.0, 0.0, 0.0]);
    assert_eq!(s.do_step(2.51, SAMPLE_TIME), Fmi2Status::Ok);
    assert_eq!(s.get_integer(vr::STATUS).1, status::BELOW_MIN_SPEED);
    assert!(s.reals(&ESTIMATES).iter().all(|v| v.is_finite()));
}

/// The Luenberger observer on model B (the design of `TwoTrackEstimationModel::
/// default_observer_design`: `β` through `ay`, `r` through the yaw rate, `ay` without feedback),
/// started about straight driving at `lkf_vx`, tracks the step on the filter's own model as the
/// Kalman filters do (measured: 2.0e-4 rad against the EKF's 3.4e-4).
#[test]
fn the_luenberger_observer_on_model_b_tracks_the_sideslip_of_the_two_track_vehicle() {
    let observer = sideslip_rmse_scheduled(EstimatorKind::Luenberger as i32, 1.0);
    let ekf = sideslip_rmse(EstimatorKind::Ekf as i32);
    println!("sideslip RMSE: Luenberger {observer}, EKF {ekf}");
    assert!(observer < 1e-3, "Luenberger sideslip RMSE {observer} rad");
}

#[test]
fn model_b_states_continue_bit_identically() {
    for estimator in [
        EstimatorKind::Lkf as i32,
        EstimatorKind::Ekf as i32,
        EstimatorKind::Ukf as i32,
        EstimatorKind::UkfScaled as i32,
        EstimatorKind::ParticleFilter as i32,
        EstimatorKind::Luenberger as i32,
    ] {
        let mut s = slave(estimator);
        assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
        let mut truth = Truth::new(6);
        run(&mut s, &mut truth, 0, 120);
        let (status, mut state) = s.get_state();
        assert_eq!(status, Fmi2Status::Ok);
        let saved = Truth {
            vehicle: truth.vehicle.clone(),
            rng: truth.rng.clone(),
        };
        let (reference, _) = run(&mut s, &mut truth, 120, 50);

        assert_eq!(s.set_state(&state), Fmi2Status::Ok);
        let mut again = Truth {
            vehicle: saved.vehicle.clone(),
            rng: saved.rng.clone(),
        };
        assert_eq!(
            run(&mut s, &mut again, 120, 50).0,
            reference,
            "estimator {estimator}"
        );

        let bytes = s.serialize(&state).expect("serialize");
        let mut fresh = Slave::instantiate(api(), "fresh", GUID).expect("instantiate");
        let (status, mut restored) = fresh.deserialize(&bytes);
        assert_eq!(status, Fmi2Status::Ok, "{:?}", fresh.log.last());
        assert_eq!(fresh.set_state(&restored), Fmi2Status::Ok);
        let mut again = saved;
        assert_eq!(
            run(&mut fresh, &mut again, 120, 50).0,
            reference,
            "estimator {estimator}: deserialized"
        );
        fresh.free_state(&mut restored);
        s.free_state(&mut state);
    }
}

/// Sideslip RMSE and mean NEES (`e² / sideslip_std²`) of the EKF on model B over the 4 s of the
/// steering step, its tyres' cornering stiffness scaled by `stiffness_scale` against the truth's
/// (the tyre law of another car), with `ay_model_error` = `model_error`; and the output trace.
fn mismatched_ekf(stiffness_scale: f64, model_error: f64) -> (f64, f64, Vec<u64>) {
    let mut s = slave(EstimatorKind::Ekf as i32);
    for reference in [
        vr::CORNERING_STIFFNESS_SCALE_FRONT,
        vr::CORNERING_STIFFNESS_SCALE_REAR,
    ] {
        assert_eq!(s.set_real(reference, stiffness_scale), Fmi2Status::Ok);
    }
    assert_eq!(s.set_real(vr::AY_MODEL_ERROR, model_error), Fmi2Status::Ok);
    // The filter's own covariance: the reported consider term (tests/stiffness_consider.rs)
    // would hide what ay_model_error does to it.
    assert_eq!(
        s.set_real(vr::CORNERING_STIFFNESS_UNCERTAINTY, 0.0),
        Fmi2Status::Ok
    );
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    let steps = 400;
    let (trace, errors) = run_with_errors(&mut s, &mut Truth::new(3), 0, steps);
    let outputs = ESTIMATES.len() + 1;
    let column = ESTIMATES
        .iter()
        .position(|&r| r == vr::SIDESLIP_STD)
        .unwrap();
    let std = |k: usize| f64::from_bits(trace[k * outputs + column]);
    let nees = errors
        .iter()
        .enumerate()
        .map(|(k, e)| (e / std(k)).powi(2))
        .sum::<f64>()
        / steps as f64;
    let rmse = (errors.iter().map(|e| e * e).sum::<f64>() / steps as f64).sqrt();
    (rmse, nees, trace)
}

#[test]
fn the_ay_model_error_makes_a_mismatched_tyre_law_more_honest() {
    // Tyres 20 % softer than the truth's: the ay row pins the sideslip through the wrong law.
    // Measured: NEES 13.5 -> 6.2 (k = 0.15), RMSE 5.55e-3 -> 5.47e-3 rad; the rest of the NEES
    // is the law's error in the prediction, which this term does not touch.
    let (rmse_sensor, nees_sensor, _) = mismatched_ekf(0.8, 0.0);
    let (rmse_model, nees_model, _) = mismatched_ekf(0.8, 0.15);
    assert!(
        nees_model < 0.6 * nees_sensor && rmse_model < rmse_sensor,
        "RMSE {rmse_sensor} -> {rmse_model}, NEES {nees_sensor} -> {nees_model}"
    );
    // On the filter's own tyre law the term costs little.
    let (rmse_own, _, _) = mismatched_ekf(1.0, 0.0);
    let (rmse_own_model, _, _) = mismatched_ekf(1.0, 0.15);
    assert!(
        rmse_own_model < 1.5 * rmse_own,
        "{rmse_own} -> {rmse_own_model}"
    );
}

#[test]
fn an_ay_model_error_too_small_to_add_noise_is_the_sensor_alone_bit_for_bit() {
    // (1e-200 ay)² underflows to 0: the runner takes the path with an extra noise of exactly 0,
    // which must be the update with the sensor's R alone (ay_model_error = 0) to the bit.
    let (_, _, sensor) = mismatched_ekf(1.25, 0.0);
    let (_, _, underflow) = mismatched_ekf(1.25, 1e-200);
    assert_eq!(sensor, underflow);
}
