//! The SIR particle filter against the exact Kalman filter on a linear-Gaussian model, the
//! resampling schemes against their defining properties, missing data, resets and determinism.

use estimation::particle::{
    effective_sample_size, filter_run, resample_indices, ParticleFilter, ParticleFilterConfig,
    Proposal, RecordedRun, ResamplingPolicy, ResamplingScheme,
};
use estimation::{Estimator, FilterIssue, StateSpaceModel};
use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// A damped oscillator sampled at 0.1 s with a force input, position measured:
/// `x' = A x + B u + w`, `y = C x + v`.
#[derive(Clone, Copy)]
struct LinearOscillator {
    a: SMatrix<f64, 2, 2>,
    b: SMatrix<f64, 2, 1>,
    c: SMatrix<f64, 1, 2>,
    q: SMatrix<f64, 2, 2>,
    r: SMatrix<f64, 1, 1>,
    /// The states the marginalised proposal keeps as a Gaussian per particle.
    linear: &'static [usize],
}

impl LinearOscillator {
    fn new() -> Self {
        Self {
            a: SMatrix::<f64, 2, 2>::new(0.995, 0.0998, -0.0998, 0.975),
            b: SMatrix::<f64, 2, 1>::new(0.005, 0.1),
            c: SMatrix::<f64, 1, 2>::new(1.0, 0.0),
            q: SMatrix::<f64, 2, 2>::new(0.01, 0.002, 0.002, 0.02),
            r: SMatrix::<f64, 1, 1>::new(0.05),
            linear: &[],
        }
    }
}

impl StateSpaceModel<2, 1, 1> for LinearOscillator {
    fn state_names(&self) -> [&'static str; 2] {
        ["position", "velocity"]
    }
    fn measurement_names(&self) -> [&'static str; 1] {
        ["measured_position"]
    }
    fn transition(&self, state: &SVector<f64, 2>, input: &SVector<f64, 1>) -> SVector<f64, 2> {
        self.a * state + self.b * input
    }
    fn transition_jacobian(&self, _: &SVector<f64, 2>, _: &SVector<f64, 1>) -> SMatrix<f64, 2, 2> {
        self.a
    }
    fn transition_input_jacobian(
        &self,
        _: &SVector<f64, 2>,
        _: &SVector<f64, 1>,
    ) -> SMatrix<f64, 2, 1> {
        self.b
    }
    fn measurement(&self, state: &SVector<f64, 2>, _: &SVector<f64, 1>) -> SVector<f64, 1> {
        self.c * state
    }
    fn measurement_jacobian(&self, _: &SVector<f64, 2>, _: &SVector<f64, 1>) -> SMatrix<f64, 1, 2> {
        self.c
    }
    fn measurement_input_jacobian(
        &self,
        _: &SVector<f64, 2>,
        _: &SVector<f64, 1>,
    ) -> SMatrix<f64, 1, 1> {
        SMatrix::zeros()
    }
    fn conditionally_linear_states(&self) -> &'static [usize] {
        self.linear
    }
    fn process_noise(&self) -> SMatrix<f64, 2, 2> {
        self.q
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        self.r
    }
}

/// Truth and measurements of the oscillator under a sine force.
fn simulate_oscillator(model: &LinearOscillator, steps: usize, seed: u64) -> RecordedRun<1, 1> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let q_root = model.q.cholesky().unwrap().l();
    let mut state = SVector::<f64, 2>::new(1.0, 0.0);
    let mut inputs = Vec::new();
    let mut measurements = Vec::new();
    for k in 0..steps {
        let input = SVector::<f64, 1>::new((0.3 * k as f64).sin());
        let noise: f64 = rng.sample(StandardNormal);
        measurements.push(model.c * state + SVector::<f64, 1>::new(noise * model.r[0].sqrt()));
        inputs.push(input);
        let w = SVector::<f64, 2>::new(rng.sample(StandardNormal), rng.sample(StandardNormal));
        state = model.a * state + model.b * input + q_root * w;
    }
    RecordedRun {
        inputs,
        measurements,
    }
}

/// The exact Kalman filter, written out here as the reference (000: 4.64-4.75).
fn kalman_reference(
    model: &LinearOscillator,
    run: &RecordedRun<1, 1>,
    mean: SVector<f64, 2>,
    covariance: SMatrix<f64, 2, 2>,
) -> Vec<(SVector<f64, 2>, SMatrix<f64, 2, 2>)> {
    let (mut x, mut p) = (mean, covariance);
    let mut out = Vec::new();
    for k in 0..run.len() {
        if k > 0 {
            x = model.a * x + model.b * run.inputs[k - 1];
            p = model.a * p * model.a.transpose() + model.q;
        }
        let s = model.c * p * model.c.transpose() + model.r;
        let gain = p * model.c.transpose() / s[0];
        x += gain * (run.measurements[k] - model.c * x);
        let i_kc = SMatrix::<f64, 2, 2>::identity() - gain * model.c;
        p = i_kc * p * i_kc.transpose() + gain * model.r * gain.transpose();
        out.push((x, p));
    }
    out
}

#[test]
fn particle_filter_agrees_with_the_exact_kalman_filter_within_monte_carlo_error() {
    let model = LinearOscillator::new();
    let run = simulate_oscillator(&model, 40, 7);
    let prior_mean = SVector::<f64, 2>::new(0.8, 0.1);
    let prior_covariance = SMatrix::<f64, 2, 2>::new(0.2, 0.0, 0.0, 0.2);
    let reference = kalman_reference(&model, &run, prior_mean, prior_covariance);
    // Independent filters with different seeds: their spread is the Monte-Carlo error (the
    // error of one SIR filter is correlated in time, so the spread across runs, not the
    // particle spread of one run, is the honest yardstick).
    let runs = 16;
    for scheme in [
        ResamplingScheme::Multinomial,
        ResamplingScheme::Systematic,
        ResamplingScheme::Stratified,
    ] {
        let mut errors = vec![vec![SVector::<f64, 2>::zeros(); reference.len()]; runs];
        let mut variances = vec![SVector::<f64, 2>::zeros(); reference.len()];
        for (r, run_errors) in errors.iter_mut().enumerate() {
            let config = ParticleFilterConfig {
                particle_count: 1000,
                scheme,
                policy: ResamplingPolicy::EveryStep,
                seed: 100 + r as u64,
                proposal: Proposal::Bootstrap,
            };
            let mut filter =
                ParticleFilter::new(model, config, prior_mean, prior_covariance).unwrap();
            for (k, (kf_mean, _)) in reference.iter().enumerate() {
                if k > 0 {
                    filter.predict(&run.inputs[k - 1]).unwrap();
                }
                filter
                    .update(&run.measurements[k], &run.inputs[k], &[true])
                    .unwrap();
                run_errors[k] = filter.state() - kf_mean;
                variances[k] += filter.covariance().diagonal() / runs as f64;
            }
        }
        let mut worst_t: f64 = 0.0;
        for (k, (_, kf_cov)) in reference.iter().enumerate() {
            for i in 0..2 {
                let mean = errors.iter().map(|e| e[k][i]).sum::<f64>() / runs as f64;
                let spread = (errors.iter().map(|e| (e[k][i] - mean).powi(2)).sum::<f64>()
                    / (runs - 1) as f64)
                    .sqrt();
                // The Monte-Carlo error must be small against the posterior itself (the weakly
                // observed velocity keeps resampling noise for many steps, hence not 1/√N) ...
                assert!(
                    spread < 0.3 * kf_cov[(i, i)].sqrt(),
                    "{scheme:?} step {k}: run-to-run spread {spread} too large"
                );
                // ... and the mean error zero within it (no bias).
                worst_t = worst_t.max(mean.abs() / (spread / (runs as f64).sqrt()));
                let relative = (variances[k][i] - kf_cov[(i, i)]).abs() / kf_cov[(i, i)];
                assert!(
                    relative < 0.15,
                    "{scheme:?} step {k}: variance {} vs Kalman {}",
                    variances[k][i],
                    kf_cov[(i, i)]
                );
            }
        }
        assert!(
            worst_t < 5.0,
            "{scheme:?}: mean error {worst_t} standard errors from the Kalman filter"
        );
    }
}

/// Mean ESS before resampling, errors against the Kalman filter, and filter variances of one
/// run of `filter` over `run` (prior as in the Kalman reference).
fn run_against_reference(
    mut filter: ParticleFilter<LinearOscillator, 2, 1, 1>,
    run: &RecordedRun<1, 1>,
    reference: &[(SVector<f64, 2>, SMatrix<f64, 2, 2>)],
) -> (f64, Vec<SVector<f64, 2>>, Vec<SVector<f64, 2>>) {
    let mut ess = 0.0;
    let mut errors = Vec::new();
    let mut variances = Vec::new();
    for (k, (kf_mean, _)) in reference.iter().enumerate() {
        if k > 0 {
            filter.predict(&run.inputs[k - 1]).unwrap();
        }
        filter
            .update(&run.measurements[k], &run.inputs[k], &[true])
            .unwrap();
        ess += filter.effective_sample_size() / reference.len() as f64;
        errors.push(filter.state() - kf_mean);
        variances.push(filter.covariance().diagonal());
    }
    (ess, errors, variances)
}

#[test]
fn particle_filter_with_the_linearised_optimal_proposal_agrees_with_kalman_and_keeps_more_particles(
) {
    // A position measurement far more precise than the process noise: the bootstrap proposal
    // wastes most particles, the optimal one (exact here, the measurement being linear) not.
    let mut model = LinearOscillator::new();
    model.r = SMatrix::<f64, 1, 1>::new(0.0005);
    let run = simulate_oscillator(&model, 40, 11);
    let prior_mean = SVector::<f64, 2>::new(0.8, 0.1);
    let prior_covariance = SMatrix::<f64, 2, 2>::new(0.2, 0.0, 0.0, 0.2);
    let reference = kalman_reference(&model, &run, prior_mean, prior_covariance);
    let runs = 8;
    let (mut bootstrap_ess, mut optimal_ess) = (0.0, 0.0);
    let mut errors = Vec::new();
    let mut variances = vec![SVector::<f64, 2>::zeros(); reference.len()];
    for r in 0..runs {
        let config = ParticleFilterConfig {
            particle_count: 500,
            scheme: ResamplingScheme::Systematic,
            policy: ResamplingPolicy::EveryStep,
            seed: 300 + r as u64,
            proposal: Proposal::Bootstrap,
        };
        let bootstrap = ParticleFilter::new(model, config, prior_mean, prior_covariance).unwrap();
        bootstrap_ess += run_against_reference(bootstrap, &run, &reference).0 / runs as f64;
        // The proposal as a setting (the FMU's way), and set afterwards: the same filter.
        let optimal_config = ParticleFilterConfig {
            proposal: Proposal::LinearisedOptimal,
            ..config
        };
        let optimal =
            ParticleFilter::new(model, optimal_config, prior_mean, prior_covariance).unwrap();
        assert_eq!(optimal.proposal(), Proposal::LinearisedOptimal);
        let switched = ParticleFilter::new(model, config, prior_mean, prior_covariance)
            .unwrap()
            .with_proposal(Proposal::LinearisedOptimal)
            .unwrap();
        assert_eq!(switched.config(), optimal.config());
        let (ess, run_errors, run_variances) = run_against_reference(optimal, &run, &reference);
        optimal_ess += ess / runs as f64;
        for (total, variance) in variances.iter_mut().zip(run_variances) {
            *total += variance / runs as f64;
        }
        errors.push(run_errors);
    }
    assert!(
        optimal_ess > 1.5 * bootstrap_ess,
        "optimal proposal ESS {optimal_ess} not clearly above bootstrap {bootstrap_ess}"
    );
    // Skip the first steps, where the broad prior dominates the weights of either proposal.
    for (k, (_, kf_cov)) in reference.iter().enumerate().skip(2) {
        for i in 0..2 {
            let mean = errors.iter().map(|e| e[k][i]).sum::<f64>() / runs as f64;
            let sigma = kf_cov[(i, i)].sqrt();
            assert!(
                mean.abs() < 0.3 * sigma,
                "step {k}, state {i}: mean error {mean} vs Kalman sigma {sigma}"
            );
            let relative = (variances[k][i] - kf_cov[(i, i)]).abs() / kf_cov[(i, i)];
            assert!(
                relative < 0.25,
                "step {k}, state {i}: variance {} vs Kalman {}",
                variances[k][i],
                kf_cov[(i, i)]
            );
        }
    }
}

fn random_weights(count: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let raw: Vec<f64> = (0..count).map(|_| rng.random::<f64>().powi(3)).collect();
    let total: f64 = raw.iter().sum();
    raw.iter().map(|w| w / total).collect()
}

fn counts(ancestors: &[usize], count: usize) -> Vec<usize> {
    let mut result = vec![0; count];
    for &a in ancestors {
        result[a] += 1;
    }
    result
}

#[test]
fn resampling_schemes_are_unbiased_and_systematic_and_stratified_have_low_variance() {
    let count = 25;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let weights = random_weights(count, &mut rng);
    let repetitions = 4000;
    let mut variances = Vec::new();
    for scheme in [
        ResamplingScheme::Multinomial,
        ResamplingScheme::Systematic,
        ResamplingScheme::Stratified,
    ] {
        let mut cumulative = vec![0.0; count];
        let mut ancestors = vec![0; count];
        let mut sum = vec![0.0; count];
        let mut sum_sq = vec![0.0; count];
        for _ in 0..repetitions {
            resample_indices(scheme, &weights, &mut cumulative, &mut ancestors, &mut rng);
            for (i, &c) in counts(&ancestors, count).iter().enumerate() {
                let expected = count as f64 * weights[i];
                if scheme == ResamplingScheme::Systematic {
                    // Systematic: every count is floor or ceil of N w_i.
                    assert!(
                        (c as f64) >= expected.floor() && (c as f64) <= expected.ceil(),
                        "systematic count {c} for expected {expected}"
                    );
                }
                if scheme == ResamplingScheme::Stratified {
                    assert!(
                        (c as f64) >= expected.floor() - 1.0 && (c as f64) <= expected.ceil() + 1.0,
                        "stratified count {c} for expected {expected}"
                    );
                }
                sum[i] += c as f64;
                sum_sq[i] += (c * c) as f64;
            }
        }
        let mut total_variance = 0.0;
        for i in 0..count {
            let expected = count as f64 * weights[i];
            let mean = sum[i] / repetitions as f64;
            let variance = sum_sq[i] / repetitions as f64 - mean * mean;
            total_variance += variance;
            // Multinomial count variance is N w (1 - w); the mean of `repetitions` draws is
            // within 5 standard errors of N w_i.
            let bound = 5.0 * (expected * (1.0 - weights[i]) / repetitions as f64).sqrt() + 1e-9;
            assert!(
                (mean - expected).abs() < bound,
                "{scheme:?} particle {i}: mean count {mean}, expected {expected}"
            );
            if scheme == ResamplingScheme::Multinomial {
                let theory = expected * (1.0 - weights[i]);
                assert!(
                    (variance - theory).abs() < 0.15 * theory + 0.02,
                    "multinomial variance {variance} vs {theory}"
                );
            }
        }
        variances.push(total_variance);
    }
    assert!(
        variances[1] < 0.5 * variances[0] && variances[2] < 0.5 * variances[0],
        "systematic/stratified must reduce the count variance: {variances:?}"
    );
}

#[test]
fn resampling_degenerate_weights_copies_the_only_particle() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut weights = vec![0.0; 10];
    weights[6] = 1.0;
    for scheme in [
        ResamplingScheme::Multinomial,
        ResamplingScheme::Systematic,
        ResamplingScheme::Stratified,
    ] {
        let mut cumulative = vec![0.0; 10];
        let mut ancestors = vec![0; 10];
        resample_indices(scheme, &weights, &mut cumulative, &mut ancestors, &mut rng);
        assert!(
            ancestors.iter().all(|&a| a == 6),
            "{scheme:?}: {ancestors:?}"
        );
    }
    assert!((effective_sample_size(&weights) - 1.0).abs() < 1e-12);
}

fn run_filter(seed: u64) -> Vec<SVector<f64, 2>> {
    let model = LinearOscillator::new();
    let run = simulate_oscillator(&model, 30, 1);
    let config = ParticleFilterConfig {
        particle_count: 300,
        seed,
        ..Default::default()
    };
    let mut filter = ParticleFilter::new(
        model,
        config,
        SVector::<f64, 2>::new(1.0, 0.0),
        SMatrix::<f64, 2, 2>::identity() * 0.1,
    )
    .unwrap();
    filter_run(&mut filter, &run).estimates
}

#[test]
fn same_seed_gives_bit_identical_results_in_any_thread() {
    let reference = run_filter(42);
    let handles: Vec<_> = (0..4)
        .map(|_| std::thread::spawn(|| run_filter(42)))
        .collect();
    for handle in handles {
        let other = handle.join().unwrap();
        for (a, b) in reference.iter().zip(&other) {
            for (x, y) in a.iter().zip(b.iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
    }
    let different = run_filter(43);
    assert_ne!(
        reference, different,
        "another seed must give another random stream"
    );
}

#[test]
fn missing_measurement_rows_are_skipped_and_never_produce_nan() {
    let model = LinearOscillator::new();
    let config = ParticleFilterConfig {
        particle_count: 200,
        ..Default::default()
    };
    let mut filter = ParticleFilter::new(
        model,
        config,
        SVector::<f64, 2>::zeros(),
        SMatrix::<f64, 2, 2>::identity(),
    )
    .unwrap();
    let input = SVector::<f64, 1>::new(0.0);
    let before = *filter.state();
    let report = filter
        .update(&SVector::<f64, 1>::new(f64::NAN), &input, &[true])
        .unwrap();
    assert_eq!(report.rows_used, 0);
    assert_eq!(
        *filter.state(),
        before,
        "a NaN sample must not move the estimate"
    );
    let report = filter
        .update(&SVector::<f64, 1>::new(0.5), &input, &[false])
        .unwrap();
    assert_eq!(report.rows_used, 0);
    let report = filter
        .update(&SVector::<f64, 1>::new(0.5), &input, &[true])
        .unwrap();
    assert_eq!(report.rows_used, 1);
    assert!(report.nis > 0.0 && report.nis.is_finite());
    assert!((report.innovation[0] - (0.5 - before[0])).abs() < 1e-12);
    assert!(filter.state().iter().all(|v| v.is_finite()));
}

/// A model whose transition blows up to NaN: every particle dies.
#[derive(Clone, Copy)]
struct Exploding;

impl StateSpaceModel<1, 1, 1> for Exploding {
    fn state_names(&self) -> [&'static str; 1] {
        ["x"]
    }
    fn measurement_names(&self) -> [&'static str; 1] {
        ["y"]
    }
    fn transition(&self, state: &SVector<f64, 1>, input: &SVector<f64, 1>) -> SVector<f64, 1> {
        if input[0] > 0.0 {
            SVector::<f64, 1>::new(f64::NAN)
        } else {
            *state
        }
    }
    fn transition_jacobian(&self, _: &SVector<f64, 1>, _: &SVector<f64, 1>) -> SMatrix<f64, 1, 1> {
        SMatrix::identity()
    }
    fn transition_input_jacobian(
        &self,
        _: &SVector<f64, 1>,
        _: &SVector<f64, 1>,
    ) -> SMatrix<f64, 1, 1> {
        SMatrix::zeros()
    }
    fn measurement(&self, state: &SVector<f64, 1>, _: &SVector<f64, 1>) -> SVector<f64, 1> {
        *state
    }
    fn measurement_jacobian(&self, _: &SVector<f64, 1>, _: &SVector<f64, 1>) -> SMatrix<f64, 1, 1> {
        SMatrix::identity()
    }
    fn measurement_input_jacobian(
        &self,
        _: &SVector<f64, 1>,
        _: &SVector<f64, 1>,
    ) -> SMatrix<f64, 1, 1> {
        SMatrix::zeros()
    }
    fn process_noise(&self) -> SMatrix<f64, 1, 1> {
        SMatrix::identity() * 0.01
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        SMatrix::identity() * 0.01
    }
}

#[test]
fn vanishing_weights_reset_the_filter_and_keep_the_estimate_finite() {
    let config = ParticleFilterConfig {
        particle_count: 50,
        ..Default::default()
    };
    let mut filter = ParticleFilter::new(
        Exploding,
        config,
        SVector::<f64, 1>::new(2.0),
        SMatrix::identity() * 0.01,
    )
    .unwrap();
    let issue = filter.predict(&SVector::<f64, 1>::new(1.0));
    assert_eq!(issue, Err(FilterIssue::WeightsReset));
    assert!(filter.state()[0].is_finite());
    assert!(filter.particles().iter().all(|p| p[0].is_finite()));
    // A measurement 10⁶ standard deviations away still gives finite weights (log domain).
    filter.predict(&SVector::<f64, 1>::new(0.0)).unwrap();
    let report = filter
        .update(&SVector::<f64, 1>::new(1.0e5), &SVector::zeros(), &[true])
        .unwrap();
    assert!(report.nis.is_finite());
    assert!(filter.state()[0].is_finite());
    assert!(filter.weights().iter().all(|w| w.is_finite()));
}

#[test]
fn bad_settings_are_rejected_with_a_message() {
    let model = LinearOscillator::new();
    let config = ParticleFilterConfig {
        particle_count: 0,
        ..Default::default()
    };
    let error = ParticleFilter::new(model, config, SVector::zeros(), SMatrix::identity())
        .err()
        .unwrap();
    assert!(error.to_string().contains("particle_count"));
    let config = ParticleFilterConfig::default();
    let error = ParticleFilter::new(
        model,
        config,
        SVector::zeros(),
        SMatrix::<f64, 2, 2>::new(1.0, 0.0, 0.0, -1.0),
    )
    .err()
    .unwrap();
    assert!(error.to_string().contains("initial state covariance"));
}

/// A snapshot taken mid-run (for both proposals, also between predict and update while the
/// optimal proposal's noise is pending) and restored into a fresh filter continues
/// bit-identically; a snapshot of another particle count is refused and changes nothing.
#[test]
fn restored_snapshot_continues_bit_identically() {
    let model = LinearOscillator::new();
    let run = simulate_oscillator(&model, 30, 21);
    let prior_mean = SVector::<f64, 2>::new(0.8, 0.1);
    let prior_covariance = SMatrix::<f64, 2, 2>::new(0.2, 0.0, 0.0, 0.2);
    for proposal in [
        Proposal::Bootstrap,
        Proposal::LinearisedOptimal,
        Proposal::Marginalised,
    ] {
        // The velocity kept per particle as a Gaussian by the marginalised proposal.
        let model = LinearOscillator {
            linear: &[1],
            ..model
        };
        let config = ParticleFilterConfig {
            particle_count: 200,
            scheme: ResamplingScheme::Stratified,
            policy: ResamplingPolicy::EffectiveSampleSizeBelow(0.5),
            seed: 77,
            proposal: Proposal::Bootstrap,
        };
        let build = || {
            ParticleFilter::new(model, config, prior_mean, prior_covariance)
                .unwrap()
                .with_proposal(proposal)
                .unwrap()
        };
        let mut original = build();
        for k in 0..12 {
            original
                .update(&run.measurements[k], &run.inputs[k], &[true])
                .unwrap();
            original.predict(&run.inputs[k]).unwrap();
        }
        // Between predict and update: the optimal proposal's draw is still pending.
        let snapshot = original.snapshot();
        let mut restored = build();
        restored.restore(&snapshot).unwrap();
        assert_eq!(restored.snapshot(), snapshot);
        for k in 12..run.measurements.len() {
            for filter in [&mut original, &mut restored] {
                filter
                    .update(&run.measurements[k], &run.inputs[k], &[true])
                    .unwrap();
                filter.predict(&run.inputs[k]).unwrap();
            }
            assert_eq!(
                original.particles(),
                restored.particles(),
                "{proposal:?} k = {k}"
            );
            assert_eq!(
                original.weights(),
                restored.weights(),
                "{proposal:?} k = {k}"
            );
            assert_eq!(original.state(), restored.state(), "{proposal:?} k = {k}");
            assert_eq!(original.covariance(), restored.covariance());
        }

        let smaller = ParticleFilterConfig {
            particle_count: 100,
            ..config
        };
        let mut other = ParticleFilter::new(model, smaller, prior_mean, prior_covariance).unwrap();
        let before = other.snapshot();
        let error = other.restore(&snapshot).unwrap_err().to_string();
        assert!(
            error.contains("200 particles") || error.contains("holds 200"),
            "{error}"
        );
        assert_eq!(other.snapshot(), before);
    }
}

fn marginalised_config(particle_count: usize, seed: u64) -> ParticleFilterConfig {
    ParticleFilterConfig {
        particle_count,
        scheme: ResamplingScheme::Systematic,
        policy: ResamplingPolicy::EveryStep,
        seed,
        proposal: Proposal::Marginalised,
    }
}

/// With every state conditionally linear nothing is sampled: each particle is the Kalman
/// filter, so the marginalised filter is the exact Kalman filter (mean and covariance to
/// rounding), whatever the particle count and seed; a missing sample is a pure prediction.
#[test]
fn the_marginalised_filter_of_a_fully_linear_model_is_the_kalman_filter() {
    let model = LinearOscillator {
        linear: &[0, 1],
        ..LinearOscillator::new()
    };
    let run = simulate_oscillator(&model, 40, 5);
    let prior_mean = SVector::<f64, 2>::new(0.8, 0.1);
    let prior_covariance = SMatrix::<f64, 2, 2>::new(0.2, 0.05, 0.05, 0.3);
    let reference = kalman_reference(&model, &run, prior_mean, prior_covariance);
    for (count, seed) in [(1, 1), (7, 2)] {
        let mut filter = ParticleFilter::new(
            model,
            marginalised_config(count, seed),
            prior_mean,
            prior_covariance,
        )
        .unwrap();
        for (k, (kf_mean, kf_covariance)) in reference.iter().enumerate() {
            if k > 0 {
                filter.predict(&run.inputs[k - 1]).unwrap();
            }
            filter
                .update(&run.measurements[k], &run.inputs[k], &[true])
                .unwrap();
            assert!(
                (filter.state() - kf_mean).amax() < 1e-9,
                "{count} particles, step {k}: {} against Kalman {kf_mean}",
                filter.state()
            );
            assert!(
                (filter.covariance() - kf_covariance).amax() < 1e-9,
                "{count} particles, step {k}: {} against Kalman {kf_covariance}",
                filter.covariance()
            );
        }
    }
    // A sample without measurement: the prediction, as the Kalman filter's.
    let mut filter = ParticleFilter::new(
        model,
        marginalised_config(3, 9),
        prior_mean,
        prior_covariance,
    )
    .unwrap();
    filter.predict(&run.inputs[0]).unwrap();
    filter
        .update(&run.measurements[1], &run.inputs[1], &[false])
        .unwrap();
    filter.predict(&run.inputs[1]).unwrap();
    let mut mean = prior_mean;
    let mut covariance = prior_covariance;
    for k in 0..2 {
        mean = model.a * mean + model.b * run.inputs[k];
        covariance = model.a * covariance * model.a.transpose() + model.q;
    }
    assert!((filter.state() - mean).amax() < 1e-9);
    assert!((filter.covariance() - covariance).amax() < 1e-9);
}

/// With the velocity marginalised and the position sampled, the filter agrees with the exact
/// Kalman filter within Monte Carlo error, and it is closer to it than the linearised optimal
/// proposal with the same particles (the Rao-Blackwell variance reduction, Schön et al. 2005,
/// section V).
#[test]
fn marginalising_a_linear_state_brings_a_small_particle_set_closer_to_the_kalman_filter() {
    let model = LinearOscillator {
        linear: &[1],
        ..LinearOscillator::new()
    };
    let run = simulate_oscillator(&model, 40, 17);
    let prior_mean = SVector::<f64, 2>::new(0.8, 0.1);
    let prior_covariance = SMatrix::<f64, 2, 2>::new(0.2, 0.0, 0.0, 0.2);
    let reference = kalman_reference(&model, &run, prior_mean, prior_covariance);
    let runs = 20;
    let squared_error = |proposal: Proposal| -> (f64, f64) {
        let (mut total, mut variance_error) = (0.0, 0.0);
        for r in 0..runs {
            let config = ParticleFilterConfig {
                proposal,
                ..marginalised_config(20, 500 + r)
            };
            let filter = ParticleFilter::new(model, config, prior_mean, prior_covariance).unwrap();
            let (_, errors, variances) = run_against_reference(filter, &run, &reference);
            for ((error, variance), (_, kf_covariance)) in
                errors.iter().zip(&variances).zip(&reference).skip(2)
            {
                total += error[1] * error[1] / kf_covariance[(1, 1)];
                variance_error += (variance[1] / kf_covariance[(1, 1)] - 1.0).abs();
            }
        }
        let samples = (runs as usize * (reference.len() - 2)) as f64;
        (total / samples, variance_error / samples)
    };
    let (marginalised, marginalised_variance) = squared_error(Proposal::Marginalised);
    let (optimal, optimal_variance) = squared_error(Proposal::LinearisedOptimal);
    // Mean squared distance from the Kalman mean, in Kalman variances.
    assert!(
        marginalised < 0.05,
        "marginalised: mean squared error {marginalised} Kalman variances"
    );
    assert!(
        marginalised < 0.5 * optimal,
        "marginalised {marginalised} not clearly below the linearised optimal {optimal}"
    );
    assert!(
        marginalised_variance < 0.1 && marginalised_variance < optimal_variance,
        "velocity variance off by {marginalised_variance} (linearised optimal {optimal_variance})"
    );
}
