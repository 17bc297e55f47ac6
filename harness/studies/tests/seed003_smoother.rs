//! The reweighting smoother on model C (003: table 3.1 setting) and its determinism.

use estimation::models::rear_axle::{diagonal_covariance, RearAxleModel};
use estimation::particle::{filter_run, ParticleFilter, Proposal};
use estimation::smoother::{smooth, SmootherWorkspace};
use harness::seed003::{filter_and_smoother_rmse, simulate, Seed003Config};

fn short_config() -> Seed003Config {
    Seed003Config {
        samples: 150,
        noise_seeds: vec![1],
        ..Seed003Config::default()
    }
}

#[test]
fn smoother_beats_the_filter_on_model_c() {
    let config = short_config();
    let mut better = 0;
    for noise_seed in [1, 2] {
        let simulated = simulate(&config, noise_seed).unwrap();
        let (filter, smoother) = filter_and_smoother_rmse(&config, &simulated).unwrap();
        for i in 0..3 {
            assert!(filter[i].is_finite() && smoother[i].is_finite());
            if smoother[i] < filter[i] {
                better += 1;
            }
        }
        // Lateral velocity and yaw rate: the smoother uses the future samples as well.
        assert!(
            smoother[0] < filter[0] && smoother[1] < filter[1],
            "seed {noise_seed}: smoother {smoother:?} vs filter {filter:?}"
        );
    }
    assert!(better >= 5, "smoother better in only {better} of 6 cases");
}

#[test]
fn smoothed_weights_are_normalised_and_pair_moments_carry_unit_mass() {
    let config = short_config();
    let simulated = simulate(&config, 3).unwrap();
    let theta = diagonal_covariance(&config.measurement_noise_std);
    let model = RearAxleModel::seed_vehicle(config.sample_time).unwrap();
    for proposal in [Proposal::Bootstrap, Proposal::LinearisedOptimal] {
        let mut filter = ParticleFilter::new(
            model.clone(),
            config.filter,
            simulated.run.measurements[0],
            theta,
        )
        .unwrap()
        .with_proposal(proposal)
        .unwrap();
        let history = filter_run(&mut filter, &simulated.run);
        let smoothed = smooth(
            &model,
            &history,
            &simulated.run,
            true,
            &mut SmootherWorkspace::new(),
        )
        .unwrap();
        for t in 0..history.len() {
            let sum: f64 = smoothed.weights_at(t).iter().sum();
            assert!((sum - 1.0).abs() < 1e-9, "{proposal:?} t={t}: Σw = {sum}");
            if t + 1 < history.len() {
                let mass: f64 = smoothed.pair_moments_at(t).iter().map(|m| m.mass).sum();
                assert!(
                    (mass - 1.0).abs() < 1e-9,
                    "{proposal:?} t={t}: pair mass {mass}"
                );
                // The marginal of the pair distribution over the source is the smoothed weight.
                for (moment, w) in smoothed
                    .pair_moments_at(t)
                    .iter()
                    .zip(smoothed.weights_at(t))
                {
                    assert!((moment.mass - w).abs() < 1e-9);
                }
            }
        }
        // The final smoothed weights are the filter's (003: 2.74 starts from w_{T|T} = w̃_T).
        let last = history.len() - 1;
        for (a, b) in smoothed
            .weights_at(last)
            .iter()
            .zip(history.weights_at(last))
        {
            assert!((a - b).abs() < 1e-12);
        }
    }
}

#[test]
fn smoother_is_bit_identical_in_any_thread() {
    let run_once = || {
        let config = short_config();
        let simulated = simulate(&config, 4).unwrap();
        let theta = diagonal_covariance(&config.measurement_noise_std);
        let model = RearAxleModel::seed_vehicle(config.sample_time).unwrap();
        let mut filter = ParticleFilter::new(
            model.clone(),
            config.filter,
            simulated.run.measurements[0],
            theta,
        )
        .unwrap();
        let history = filter_run(&mut filter, &simulated.run);
        smooth(
            &model,
            &history,
            &simulated.run,
            true,
            &mut SmootherWorkspace::new(),
        )
        .unwrap()
        .estimates
    };
    let reference = run_once();
    let handles: Vec<_> = (0..3).map(|_| std::thread::spawn(run_once)).collect();
    for handle in handles {
        let other = handle.join().unwrap();
        for (a, b) in reference.iter().zip(&other) {
            for (x, y) in a.iter().zip(b.iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
    }
}
