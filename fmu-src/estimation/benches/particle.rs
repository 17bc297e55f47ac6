//! Particle filter, smoother and EM benchmarks.
//!
//! `cargo bench -p estimation --bench particle`
//!
//! - one SIR step (predict + update + resampling) on model A with 1000 particles (target ≤ 250 µs);
//! - one E-step (filter + reweighting smoother with pair moments) on model C, N = 50, T = 500;
//! - the whole seed-003 identification of one simulated data set (target < 20 s).

use divan::Bencher;
use estimation::identification::expectation_step;
use estimation::identification::seed003::{identify_seed003, simulate, Seed003Config};
use estimation::models::rear_axle::{diagonal_covariance, RearAxleModel};
use estimation::models::single_track::{seed_operating_point, SingleTrackEstimationModel};
use estimation::particle::{ParticleFilter, ParticleFilterConfig, Proposal};
use estimation::smoother::SmootherWorkspace;
use estimation::{Estimator, StateSpaceModel};
use nalgebra::SVector;

fn main() {
    divan::main();
}

/// Model A (5 states, 4 measurements) at 1 ms, the seed-000 set-up, 1000 particles.
#[divan::bench(args = [ResamplingSchemeArg::Systematic, ResamplingSchemeArg::Stratified, ResamplingSchemeArg::Multinomial])]
fn model_a_pf_step_1000_particles(bencher: Bencher, scheme: ResamplingSchemeArg) {
    let model = SingleTrackEstimationModel::seed_000(0.001).unwrap();
    let (state, _) = seed_operating_point();
    let input = SVector::<f64, 3>::new(0.02, 50.0, 0.0);
    let config = ParticleFilterConfig {
        particle_count: 1000,
        scheme: scheme.into(),
        ..Default::default()
    };
    let mut filter =
        ParticleFilter::new(model.clone(), config, state, model.process_noise() * 100.0).unwrap();
    let measurement = model.measurement(&model.transition(&state, &input), &input);
    bencher.bench_local(|| {
        filter.predict(divan::black_box(&input)).unwrap();
        filter
            .update(divan::black_box(&measurement), &input, &[true; 4])
            .unwrap();
    });
}

#[divan::bench(args = [ResamplingSchemeArg::Systematic, ResamplingSchemeArg::Stratified, ResamplingSchemeArg::Multinomial])]
fn model_c_pf_step_1000_particles(bencher: Bencher, scheme: ResamplingSchemeArg) {
    let model = RearAxleModel::seed_vehicle(0.01).unwrap();
    let config = ParticleFilterConfig {
        particle_count: 1000,
        scheme: scheme.into(),
        ..Default::default()
    };
    let initial = SVector::<f64, 3>::new(0.2285, -0.4463, 0.1199);
    let mut filter =
        ParticleFilter::new(model.clone(), config, initial, model.measurement_noise()).unwrap();
    let input = SVector::<f64, 3>::new(0.5, -0.05, 14.0);
    let measurement = model.transition(&initial, &input);
    bencher.bench_local(|| {
        filter.predict(divan::black_box(&input)).unwrap();
        filter
            .update(divan::black_box(&measurement), &input, &[true; 3])
            .unwrap();
    });
}

#[derive(Debug, Clone, Copy)]
enum ResamplingSchemeArg {
    Multinomial,
    Systematic,
    Stratified,
}

impl From<ResamplingSchemeArg> for estimation::particle::ResamplingScheme {
    fn from(value: ResamplingSchemeArg) -> Self {
        match value {
            ResamplingSchemeArg::Multinomial => Self::Multinomial,
            ResamplingSchemeArg::Systematic => Self::Systematic,
            ResamplingSchemeArg::Stratified => Self::Stratified,
        }
    }
}

impl std::fmt::Display for ResamplingSchemeArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{self:?}")
    }
}

#[divan::bench(args = ["bootstrap", "linearised_optimal"])]
fn e_step_model_c_n50_t500(bencher: Bencher, proposal: &str) {
    let proposal = if proposal == "bootstrap" {
        Proposal::Bootstrap
    } else {
        Proposal::LinearisedOptimal
    };
    let config = Seed003Config::default();
    let simulated = simulate(&config, 1).unwrap();
    let theta = diagonal_covariance(&config.measurement_noise_std);
    let model = RearAxleModel::seed_vehicle(config.sample_time).unwrap();
    let mut workspace = SmootherWorkspace::new();
    bencher.bench_local(|| {
        expectation_step(
            &model,
            &simulated.run,
            config.filter,
            proposal,
            simulated.run.measurements[0],
            theta,
            &mut workspace,
        )
        .unwrap()
    });
}

#[divan::bench(sample_count = 3, sample_size = 1)]
fn seed003_identification(bencher: Bencher) {
    let config = Seed003Config::default();
    let simulated = simulate(&config, 1).unwrap();
    bencher.bench_local(|| identify_seed003(&config, &simulated).unwrap());
}
