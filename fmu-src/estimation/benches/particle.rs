//! Particle filter benchmarks.
//!
//! `cargo bench -p estimation --features offline --bench particle`
//!
//! - one SIR step (predict + update + resampling) on model A with 1000 particles (target ≤ 250 µs),
//!   with the bootstrap and the linearised optimal proposal, and on model C (offline feature:
//!   model C is there for the identification).
//!
//! The E-step and the whole seed-003 identification are timed on the seed's set-up in the
//! studies crate: `cargo bench -p harness --bench identification`.

use divan::Bencher;
use estimation::models::rear_axle::RearAxleModel;
use estimation::models::single_track::{seed_operating_point, SingleTrackEstimationModel};
use estimation::particle::{ParticleFilter, ParticleFilterConfig, Proposal, ResamplingScheme};
use estimation::{Estimator, StateSpaceModel};
use nalgebra::SVector;

fn main() {
    divan::main();
}

/// Model A (5 states, 4 measurements) at 1 ms, the seed-000 set-up, 1000 particles.
#[divan::bench(args = [ResamplingSchemeArg::Systematic, ResamplingSchemeArg::Stratified, ResamplingSchemeArg::Multinomial])]
fn model_a_pf_step_1000_particles(bencher: Bencher, scheme: ResamplingSchemeArg) {
    model_a_step(
        bencher,
        ParticleFilterConfig {
            particle_count: 1000,
            scheme: scheme.into(),
            ..Default::default()
        },
    );
}

/// The same step with the linearised optimal proposal (the FMU's default), systematic
/// resampling as the FMU's default.
#[divan::bench]
fn model_a_pf_step_1000_particles_linearised_optimal(bencher: Bencher) {
    model_a_step(
        bencher,
        ParticleFilterConfig {
            particle_count: 1000,
            scheme: ResamplingScheme::Systematic,
            proposal: Proposal::LinearisedOptimal,
            ..Default::default()
        },
    );
}

/// One predict and update of a filter with `config` on model A.
fn model_a_step(bencher: Bencher, config: ParticleFilterConfig) {
    let model = SingleTrackEstimationModel::seed_000(0.001).unwrap();
    let (state, _) = seed_operating_point();
    let input = SVector::<f64, 3>::new(0.02, 50.0, 0.0);
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
