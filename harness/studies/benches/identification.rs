//! The seed-003 identification's cost on the seed's set-up (model C, N = 50, T = 500):
//!
//! `cargo bench -p harness --bench identification`
//!
//! - one E-step (filter + reweighting smoother with pair moments), bootstrap and linearised
//!   optimal proposal;
//! - the whole seed-003 identification of one simulated data set (target < 20 s).

use divan::Bencher;
use estimation::identification::expectation_step;
use estimation::models::rear_axle::{diagonal_covariance, RearAxleModel};
use estimation::particle::Proposal;
use estimation::smoother::SmootherWorkspace;
use harness::seed003::{identify_seed003, simulate, Seed003Config};

fn main() {
    divan::main();
}

#[divan::bench(args = ["bootstrap", "linearised_optimal"])]
fn e_step_model_c_n50_t500(bencher: Bencher, proposal: &str) {
    let proposal = if proposal == "bootstrap" {
        Proposal::Bootstrap
    } else {
        Proposal::LinearisedOptimal
    };
    let mut config = Seed003Config::default();
    config.filter.proposal = proposal;
    let simulated = simulate(&config, 1).unwrap();
    let theta = diagonal_covariance(&config.measurement_noise_std);
    let model = RearAxleModel::seed_vehicle(config.sample_time).unwrap();
    let mut workspace = SmootherWorkspace::new();
    bencher.bench_local(|| {
        expectation_step(
            &model,
            &simulated.run,
            config.filter,
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
