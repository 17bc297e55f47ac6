//! Seed 001's steering step at library level (001: §4, fig. 5): 40° at the steering wheel
//! (steering ratio 14.97) at 65 km/h. The truth is the full model B (7 states, Magic Formula,
//! roll-moment load transfer) at 1 ms; the estimators run the 3-state form of seed 001 at 10 ms
//! with noisy `ay`, yaw rate and measured `vx`. The seed's finding: beyond the linear range the
//! linear single-track Kalman filter gets the sideslip wrong, the UKF on the nonlinear two-track
//! model gets it clearly better.

use estimation::kalman::{InitialEstimate, LinearKalmanFilter, SigmaPoints, UnscentedKalmanFilter};
use estimation::models::two_track::{
    seed_001_operating_point, TwoTrackEstimationModel, SEED_001_MEASUREMENT_NOISE_STD,
    SEED_001_SPEED,
};
use estimation::Estimator;
use nalgebra::SVector;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use vehicle_models::{DriverInput, Integrator, TwoTrackMagicFormula};

const REFERENCE_SAMPLE_TIME: f64 = 1e-3;
const FILTER_SAMPLE_TIME: f64 = 0.01;
const STEP_TIME: f64 = 1.0;
const DURATION: f64 = 6.0;
const STEERING_WHEEL_ANGLE_DEG: f64 = 40.0;
/// Standard deviation of the measured longitudinal speed, m/s (a wheel-speed based signal).
const SPEED_NOISE_STD: f64 = 0.05;

struct Run {
    times: Vec<f64>,
    inputs: Vec<SVector<f64, 3>>,
    measurements: Vec<SVector<f64, 2>>,
    sideslip: Vec<f64>,
    lateral_acceleration: Vec<f64>,
}

/// The reference run of model B, sampled every 10 ms, deterministic for `seed`.
fn reference_run(seed: u64) -> Run {
    let vehicle = TwoTrackMagicFormula::default();
    let road_wheel_angle =
        STEERING_WHEEL_ANGLE_DEG.to_radians() / vehicle.vehicle.chassis.steering_ratio;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let ay_noise = Normal::new(0.0, SEED_001_MEASUREMENT_NOISE_STD[0]).unwrap();
    let yaw_rate_noise = Normal::new(0.0, SEED_001_MEASUREMENT_NOISE_STD[1]).unwrap();
    let speed_noise = Normal::new(0.0, SPEED_NOISE_STD).unwrap();
    let ratio = (FILTER_SAMPLE_TIME / REFERENCE_SAMPLE_TIME).round() as usize;
    let steps = (DURATION / REFERENCE_SAMPLE_TIME).round() as usize;
    let mut x = vehicle.straight_rolling_state(SEED_001_SPEED);
    let mut run = Run {
        times: Vec::new(),
        inputs: Vec::new(),
        measurements: Vec::new(),
        sideslip: Vec::new(),
        lateral_acceleration: Vec::new(),
    };
    for k in 0..=steps {
        let t = k as f64 * REFERENCE_SAMPLE_TIME;
        let input = DriverInput {
            steering_angle: if t >= STEP_TIME {
                road_wheel_angle
            } else {
                0.0
            },
            ..DriverInput::default()
        };
        let u = input.to_vector();
        if k % ratio == 0 {
            let truth = vehicle.truth(&x, &u);
            run.times.push(t);
            // at the seed's constant speed, free rolling: ax = 0
            run.inputs.push(SVector::<f64, 3>::new(
                input.steering_angle,
                truth.longitudinal_velocity + speed_noise.sample(&mut rng),
                0.0,
            ));
            run.measurements.push(SVector::<f64, 2>::new(
                truth.lateral_acceleration + ay_noise.sample(&mut rng),
                truth.yaw_rate + yaw_rate_noise.sample(&mut rng),
            ));
            run.sideslip.push(truth.sideslip);
            run.lateral_acceleration.push(truth.lateral_acceleration);
        }
        x = vehicle.step(&x, &u, REFERENCE_SAMPLE_TIME, Integrator::RungeKutta4);
    }
    run
}

/// Runs `filter` over `run` (predict with `u(k-1)`, update with `y(k)`, `u(k)`); the sideslip
/// estimates at every sample.
fn sideslip_estimates(filter: &mut impl Estimator<3, 2, 3>, run: &Run) -> Vec<f64> {
    let mut estimates = vec![filter.state()[0]];
    for k in 1..run.times.len() {
        let _ = filter.predict(&run.inputs[k - 1]);
        let _ = filter.update(&run.measurements[k], &run.inputs[k], &[true; 2]);
        assert!(filter.state().iter().all(|v| v.is_finite()));
        estimates.push(filter.state()[0]);
    }
    estimates
}

/// Sideslip RMSE over `from <= t`.
fn sideslip_rmse(run: &Run, estimates: &[f64], from: f64) -> f64 {
    let errors: Vec<f64> = run
        .times
        .iter()
        .zip(run.sideslip.iter().zip(estimates))
        .filter(|(t, _)| **t >= from)
        .map(|(_, (truth, estimate))| (truth - estimate).powi(2))
        .collect();
    (errors.iter().sum::<f64>() / errors.len() as f64).sqrt()
}

fn initial_estimate() -> InitialEstimate<3> {
    InitialEstimate::diagonal(SVector::zeros(), SVector::from([1e-4, 1e-4, 1e-2]))
}

#[test]
fn seed001_ukf_on_the_two_track_model_beats_the_linear_single_track_kf_on_the_step() {
    // Several noise realisations, so the finding does not hang on one lucky draw.
    for seed in 1..=4 {
        step_steer_finding(seed);
    }
}

fn step_steer_finding(seed: u64) {
    let run = reference_run(seed);
    let peak_ay = run
        .lateral_acceleration
        .iter()
        .fold(0.0_f64, |m, a| m.max(a.abs()));
    let peak_sideslip = run.sideslip.iter().fold(0.0_f64, |m, b| m.max(b.abs()));
    // The manoeuvre leaves the linear range of the single-track model (about 4 m/s², 001: §2).
    assert!(peak_ay > 4.5, "peak ay {peak_ay}");

    let model = TwoTrackEstimationModel::seed_001(FILTER_SAMPLE_TIME).unwrap();
    let (operating_state, operating_input) = seed_001_operating_point(SEED_001_SPEED);
    let mut linear = LinearKalmanFilter::new(
        model.clone(),
        &operating_state,
        &operating_input,
        &initial_estimate(),
    )
    .unwrap();
    let mut unscented = UnscentedKalmanFilter::new(
        model,
        SigmaPoints::scaled(0.5, 2.0, 0.0),
        &initial_estimate(),
    )
    .unwrap();
    let linear_rmse = sideslip_rmse(&run, &sideslip_estimates(&mut linear, &run), STEP_TIME);
    let unscented_rmse = sideslip_rmse(&run, &sideslip_estimates(&mut unscented, &run), STEP_TIME);
    eprintln!(
        "seed-001 step, noise seed {seed}: peak ay {peak_ay:.2} m/s², peak sideslip {:.3}°, sideslip RMSE LKF {:.4}° UKF {:.4}°",
        peak_sideslip.to_degrees(),
        linear_rmse.to_degrees(),
        unscented_rmse.to_degrees()
    );
    // The UKF tracks the sideslip to a small fraction of its size …
    assert!(
        unscented_rmse < 0.15 * peak_sideslip,
        "UKF sideslip RMSE {unscented_rmse} vs peak {peak_sideslip}"
    );
    // … and clearly better than the linear filter (seed 001, fig. 5).
    assert!(
        unscented_rmse < 0.5 * linear_rmse,
        "UKF {unscented_rmse} vs LKF {linear_rmse}"
    );
}
