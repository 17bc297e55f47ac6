//! Seed-000 experiments at library level (SPEC §7): the truth is model A at `T_ref = 1 ms` with
//! process noise std `w = [1e-3, 1e-4, 1e-4, 1e-3, 1e-3]` per step and measurement noise std
//! `1e-4` on all four outputs, from `vx = 18 m/s, ωF = ωR = 60 rad/s`; the filters sample it
//! every `T / T_ref` reference steps with `Q = diag(w²)`, `R = diag(v²)`.
#![allow(dead_code)]

use estimation::models::single_track::{
    SingleTrackEstimationModel, SEED_MEASUREMENT_NOISE_STD, SEED_PROCESS_NOISE_STD,
};
use estimation::{Estimator, StateSpaceModel};
use nalgebra::SVector;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use vehicle_models::manoeuvre::{
    SeedManoeuvre, SEED_INITIAL_SPEED, SEED_INITIAL_WHEEL_SPEED, SEED_MANOEUVRE_DURATION,
};

/// Reference sample time, s (000: ch. 7).
pub const REFERENCE_SAMPLE_TIME: f64 = 1e-3;

/// One noisy reference run, sampled at the filter's sample time.
pub struct Reference {
    /// Filter sample time, s.
    pub sample_time: f64,
    pub times: Vec<f64>,
    pub inputs: Vec<SVector<f64, 3>>,
    pub states: Vec<SVector<f64, 5>>,
    pub measurements: Vec<SVector<f64, 4>>,
}

/// Runs the reference of `manoeuvre` and samples it every `filter_sample_time` (a multiple of
/// 1 ms). Deterministic for `seed`.
pub fn reference_run(manoeuvre: SeedManoeuvre, filter_sample_time: f64, seed: u64) -> Reference {
    let truth = SingleTrackEstimationModel::seed_000(REFERENCE_SAMPLE_TIME).unwrap();
    let ratio = (filter_sample_time / REFERENCE_SAMPLE_TIME).round() as usize;
    assert!(ratio >= 1);
    let steps = (SEED_MANOEUVRE_DURATION / REFERENCE_SAMPLE_TIME).round() as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let process: Vec<Normal<f64>> = SEED_PROCESS_NOISE_STD
        .iter()
        .map(|&w| Normal::new(0.0, w).unwrap())
        .collect();
    let sensor = Normal::new(0.0, SEED_MEASUREMENT_NOISE_STD).unwrap();
    let mut x = SVector::<f64, 5>::from([
        SEED_INITIAL_SPEED,
        0.0,
        0.0,
        SEED_INITIAL_WHEEL_SPEED,
        SEED_INITIAL_WHEEL_SPEED,
    ]);
    let mut run = Reference {
        sample_time: ratio as f64 * REFERENCE_SAMPLE_TIME,
        times: Vec::new(),
        inputs: Vec::new(),
        states: Vec::new(),
        measurements: Vec::new(),
    };
    for k in 0..=steps {
        let t = k as f64 * REFERENCE_SAMPLE_TIME;
        let u = manoeuvre.input_at(t).to_vector();
        if k % ratio == 0 {
            let noise = SVector::<f64, 4>::from_fn(|_, _| sensor.sample(&mut rng));
            run.times.push(t);
            run.inputs.push(u);
            run.states.push(x);
            run.measurements.push(truth.measurement(&x, &u) + noise);
        }
        let w = SVector::<f64, 5>::from_fn(|i, _| process[i].sample(&mut rng));
        x = truth.transition(&x, &u) + w;
    }
    run
}

/// The initial estimate of the seed runs: the true start, with a small covariance.
pub fn seed_initial_estimate() -> estimation::kalman::InitialEstimate<5> {
    estimation::kalman::InitialEstimate::diagonal(
        SVector::<f64, 5>::from([
            SEED_INITIAL_SPEED,
            0.0,
            0.0,
            SEED_INITIAL_WHEEL_SPEED,
            SEED_INITIAL_WHEEL_SPEED,
        ]),
        SVector::<f64, 5>::from([1e-2, 1e-4, 1e-4, 1e-2, 1e-2]),
    )
}

/// Runs `filter` over `reference` (predict with `u(k-1)`, update with `y(k)`, `u(k)`) and returns
/// the estimates at every sample (the first is the initial estimate).
pub fn run_filter(
    filter: &mut impl Estimator<5, 4, 3>,
    reference: &Reference,
) -> Vec<SVector<f64, 5>> {
    let mut estimates = vec![*filter.state()];
    for k in 1..reference.times.len() {
        let _ = filter.predict(&reference.inputs[k - 1]);
        let _ = filter.update(&reference.measurements[k], &reference.inputs[k], &[true; 4]);
        estimates.push(*filter.state());
    }
    estimates
}

/// Root-mean-square error of state `index` over the samples with `from <= t < to`.
pub fn rmse(
    reference: &Reference,
    estimates: &[SVector<f64, 5>],
    index: usize,
    from: f64,
    to: f64,
) -> f64 {
    let errors: Vec<f64> = reference
        .times
        .iter()
        .zip(&reference.states)
        .zip(estimates)
        .filter(|((t, _), _)| **t >= from && **t < to)
        .map(|((_, x), e)| (x[index] - e[index]).powi(2))
        .collect();
    (errors.iter().sum::<f64>() / errors.len() as f64).sqrt()
}
