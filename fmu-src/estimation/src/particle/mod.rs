//! SIR particle filter (003: §2.2.4) with multinomial, systematic and stratified resampling
//! (003: A.4), generic over [`StateSpaceModel`].
//!
//! One step is the seed's loop body (003: §2.2.4, "Prozess"): every particle is moved through the
//! transition plus a process-noise draw, weighted by the measurement likelihood
//! `w = N(y; h(x, u), R)` (003: 2.58-2.61), the weights are normalised (003: 2.62) and the set is
//! resampled. Weights are kept as logarithms so that the product of many small likelihoods never
//! underflows to zero; the estimate is the weighted particle mean and the covariance the weighted
//! sample covariance (taken before resampling, which removes the resampling noise from the
//! estimate; the seed takes the plain mean after resampling, which has the same expectation).
//!
//! All particle storage is allocated once, when the filter is built with its run-time particle
//! count; `predict` and `update` never allocate. The random stream is a ChaCha generator seeded
//! by the caller, so one seed gives bit-identical results in any thread.

mod config;
mod gaussian;
mod marginalised;
mod offline;
mod proposals;
mod resampling;
mod snapshot;

use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::estimator::{Estimator, FilterIssue, MeasurementMask, UpdateReport};
use crate::model::StateSpaceModel;

pub use config::{
    ParticleFilterConfig, ParticleFilterError, Proposal, ResamplingPolicy, ResamplingScheme,
};
pub use gaussian::{covariance_square_root, weighted_moments};
pub(crate) use gaussian::{masked_covariance, used_rows};
pub use offline::{filter_run, ParticleHistory, RecordedRun};
pub use resampling::{effective_sample_size, resample_indices};
pub use snapshot::{ParticleFilterSnapshot, SNAPSHOT_LAYOUT};

use config::check_proposal;
use gaussian::{log_likelihood, standard_normal_vector};
use marginalised::MarginalisedStates;
use proposals::marginal_storage;
use resampling::normalise_log_weights;

/// The SIR particle filter of 003: §2.2.4 on any [`StateSpaceModel`].
#[derive(Debug, Clone)]
pub struct ParticleFilter<Model, const N: usize, const M: usize, const U: usize> {
    model: Model,
    config: ParticleFilterConfig,
    rng: ChaCha8Rng,
    particles: Vec<SVector<f64, N>>,
    resampled: Vec<SVector<f64, N>>,
    log_weights: Vec<f64>,
    weights: Vec<f64>,
    cumulative: Vec<f64>,
    ancestors: Vec<usize>,
    predicted_measurements: Vec<SVector<f64, M>>,
    /// `f(x_{t-1}^i, u)` while the noise draw waits for the measurement (optimal proposal).
    predicted_means: Vec<SVector<f64, N>>,
    noise_pending: bool,
    /// The marginalised proposal's per-particle Gaussians of the linear states.
    marginal: MarginalisedStates<N>,
    /// Process noise added to the pending prediction by the host ([`Self::inflate_pending`]).
    pending_extra: SMatrix<f64, N, N>,
    /// `Σ wᵢ Fᵢ Eᵢ Fᵢᵀ` of the pending prediction (marginalised proposal), computed once per
    /// prediction; derived again from the particles on restore.
    pending_linear_spread: SMatrix<f64, N, N>,
    process_noise: SMatrix<f64, N, N>,
    process_noise_root: SMatrix<f64, N, N>,
    measurement_noise: SMatrix<f64, M, M>,
    estimate: SVector<f64, N>,
    covariance: SMatrix<f64, N, N>,
    effective_sample_size: f64,
    resampled_in_last_update: bool,
}

impl<Model, const N: usize, const M: usize, const U: usize> ParticleFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    /// Builds the filter and draws the initial particles from `N(initial_state,
    /// initial_covariance)` with equal weights `1/N` (003: §2.2.4, "Initialisierung"). All
    /// storage for `config.particle_count` particles is allocated here, once.
    pub fn new(
        model: Model,
        config: ParticleFilterConfig,
        initial_state: SVector<f64, N>,
        initial_covariance: SMatrix<f64, N, N>,
    ) -> Result<Self, ParticleFilterError> {
        if config.particle_count == 0 {
            return Err(ParticleFilterError::NoParticles(0));
        }
        if let ResamplingPolicy::EffectiveSampleSizeBelow(fraction) = config.policy {
            if !(fraction > 0.0 && fraction <= 1.0) {
                return Err(ParticleFilterError::BadResamplingThreshold(fraction));
            }
        }
        if initial_state.iter().any(|value| !value.is_finite()) {
            return Err(ParticleFilterError::NonFiniteInitialState(
                initial_state.iter().copied().collect(),
            ));
        }
        let initial_root = covariance_square_root(&initial_covariance, "initial state")?;
        let process_noise_root = covariance_square_root(&model.process_noise(), "process noise")?;
        let measurement_noise = model.measurement_noise();
        let process_noise = model.process_noise();
        let marginal = marginal_storage(&model, config.proposal, config.particle_count);
        check_proposal(config.proposal, &process_noise, marginal.is_active())?;
        let count = config.particle_count;
        let mut filter = Self {
            model,
            config,
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            particles: vec![initial_state; count],
            resampled: vec![initial_state; count],
            log_weights: vec![-(count as f64).ln(); count],
            weights: vec![1.0 / count as f64; count],
            cumulative: vec![0.0; count],
            ancestors: vec![0; count],
            predicted_measurements: vec![SVector::zeros(); count],
            predicted_means: vec![initial_state; count],
            noise_pending: false,
            marginal,
            pending_extra: SMatrix::zeros(),
            pending_linear_spread: SMatrix::zeros(),
            process_noise,
            process_noise_root,
            measurement_noise,
            estimate: initial_state,
            covariance: initial_covariance,
            effective_sample_size: count as f64,
            resampled_in_last_update: false,
        };
        for (i, particle) in filter.particles.iter_mut().enumerate() {
            if filter.marginal.is_active() {
                // The sampled states drawn, the linear ones conditioned on them.
                let (drawn, linear_covariance) = filter
                    .marginal
                    .conditional_draw(&initial_state, &initial_covariance, &mut filter.rng)
                    .ok_or(ParticleFilterError::NotPositiveSemiDefinite(
                        "initial state",
                        f64::NAN,
                    ))?;
                *particle = drawn;
                filter.marginal.set(i, &linear_covariance);
            } else {
                *particle = initial_state + initial_root * standard_normal_vector(&mut filter.rng);
            }
        }
        filter.refresh_estimate();
        Ok(filter)
    }

    /// The model the filter runs on.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The settings the filter was built with.
    pub fn config(&self) -> &ParticleFilterConfig {
        &self.config
    }

    /// The current particles (after the last resampling, if any).
    pub fn particles(&self) -> &[SVector<f64, N>] {
        &self.particles
    }

    /// The current normalised weights of [`Self::particles`].
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The effective sample size `1/Σw²` after the last update, before resampling.
    pub fn effective_sample_size(&self) -> f64 {
        self.effective_sample_size
    }

    /// Whether the last update resampled the set.
    pub fn resampled_in_last_update(&self) -> bool {
        self.resampled_in_last_update
    }

    /// Chooses the proposal (default: the seed's bootstrap). The linearised optimal proposal
    /// needs a positive definite process noise. Switching to the marginalised proposal keeps the
    /// particles as they are, each with a zero covariance of its linear states.
    pub fn with_proposal(mut self, proposal: Proposal) -> Result<Self, ParticleFilterError> {
        let marginal = marginal_storage(&self.model, proposal, self.config.particle_count);
        check_proposal(proposal, &self.process_noise, marginal.is_active())?;
        if marginal.is_active() != self.marginal.is_active() {
            self.marginal = marginal;
        }
        self.config.proposal = proposal;
        Ok(self)
    }

    /// The proposal in use.
    pub fn proposal(&self) -> Proposal {
        self.config.proposal
    }

    /// Time update: `x_i ← f(x_i, u) + w_i`, `w_i ~ N(0, Q)` (003: §2.2.4, "Prädiktion").
    /// A particle that becomes non-finite gets weight zero; if every particle does, the set is
    /// redrawn around the last estimate and [`FilterIssue::WeightsReset`] is reported.
    /// With the linearised optimal proposal the noise is drawn in the next update, when the
    /// measurement is known; meanwhile the estimate is the mean of `f(x_i, u)` and the
    /// covariance their spread plus `Q`.
    pub fn propagate(&mut self, input: &SVector<f64, U>) -> Result<(), FilterIssue> {
        self.draw_pending_noise_from_prior();
        match self.config.proposal {
            Proposal::Bootstrap => {
                for (particle, log_weight) in
                    self.particles.iter_mut().zip(self.log_weights.iter_mut())
                {
                    let noise =
                        self.process_noise_root * standard_normal_vector::<N, _>(&mut self.rng);
                    *particle = self.model.transition(particle, input) + noise;
                    if particle.iter().any(|value| !value.is_finite()) {
                        *log_weight = f64::NEG_INFINITY;
                    }
                }
            }
            Proposal::LinearisedOptimal | Proposal::Marginalised => {
                for (i, ((particle, mean), log_weight)) in self
                    .particles
                    .iter_mut()
                    .zip(self.predicted_means.iter_mut())
                    .zip(self.log_weights.iter_mut())
                    .enumerate()
                {
                    *mean = if self.marginal.is_active() {
                        let (mean, jacobian) =
                            self.model.transition_and_linear_columns(particle, input);
                        self.marginal.store_columns(i, &jacobian);
                        mean
                    } else {
                        self.model.transition(particle, input)
                    };
                    *particle = *mean;
                    if mean.iter().any(|value| !value.is_finite()) {
                        *log_weight = f64::NEG_INFINITY;
                    }
                }
                self.noise_pending = true;
            }
        }
        if normalise_log_weights(&mut self.log_weights, &mut self.weights).is_none() {
            self.noise_pending = false;
            self.reset_around_estimate();
            return Err(FilterIssue::WeightsReset);
        }
        self.refresh_estimate();
        if self.noise_pending {
            self.refresh_pending_linear_spread();
            self.covariance += self.pending_spread();
        }
        Ok(())
    }

    /// `log w_i += log N(y; h(x_i, u), R)` over the used rows, up to a constant shared by all
    /// particles (003: 2.60). `recompute`: the particles moved since `predicted_measurements`
    /// was filled.
    fn weigh_by_likelihood(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        used: &MeasurementMask<M>,
        noise_cholesky: &nalgebra::Cholesky<f64, nalgebra::Const<M>>,
        recompute: bool,
    ) {
        if recompute {
            for (particle, predicted) in self
                .particles
                .iter()
                .zip(self.predicted_measurements.iter_mut())
            {
                *predicted = self.model.measurement(particle, input);
            }
        }
        // log N(y; h(x_i), R) up to a constant shared by all particles (003: 2.60).
        for (predicted, log_weight) in self
            .predicted_measurements
            .iter()
            .zip(self.log_weights.iter_mut())
        {
            let log_likelihood = log_likelihood(measurement, predicted, used, noise_cholesky);
            *log_weight += if log_likelihood.is_nan() {
                f64::NEG_INFINITY
            } else {
                log_likelihood
            };
        }
    }

    /// Measurement weighting without resampling: `log w_i += log N(y; h(x_i, u), R)` over the
    /// used rows (003: 2.58-2.61), then normalisation (003: 2.62). Reports the innovation against
    /// the predicted-particle measurement mean and the NIS with `S` = predicted-particle
    /// measurement spread + `R`.
    pub fn reweight(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &MeasurementMask<M>,
    ) -> Result<UpdateReport<M>, FilterIssue> {
        self.resampled_in_last_update = false;
        let used = used_rows(measurement, mask);
        let rows_used = used.iter().filter(|&&flag| flag).count();
        if rows_used == 0 {
            self.draw_pending_noise_from_prior();
            return Ok(UpdateReport::skipped());
        }
        let Some(noise_cholesky) = masked_covariance(&self.measurement_noise, &used).cholesky()
        else {
            self.draw_pending_noise_from_prior();
            return Err(FilterIssue::UpdateSkipped);
        };

        // Predicted measurement mean and spread with the prior weights.
        let mut predicted_mean = SVector::<f64, M>::zeros();
        for ((particle, predicted), &weight) in self
            .particles
            .iter()
            .zip(self.predicted_measurements.iter_mut())
            .zip(&self.weights)
        {
            *predicted = self.model.measurement(particle, input);
            if weight > 0.0 {
                predicted_mean += *predicted * weight;
            }
        }
        let mut innovation_covariance = self.measurement_noise;
        for (predicted, &weight) in self.predicted_measurements.iter().zip(&self.weights) {
            if weight > 0.0 {
                let deviation = predicted - predicted_mean;
                innovation_covariance.ger(weight, &deviation, &deviation, 1.0);
            }
        }
        if self.noise_pending {
            // The particles are still the noise-free predictions: add the process noise seen
            // through the measurement.
            let jacobian = self.model.measurement_jacobian(&self.estimate, input);
            innovation_covariance += jacobian * self.pending_spread() * jacobian.transpose();
        }
        let mut innovation = measurement - predicted_mean;
        for (row, &flag) in used.iter().enumerate() {
            if !flag {
                innovation[row] = 0.0;
            }
        }
        let nis = masked_covariance(&innovation_covariance, &used)
            .cholesky()
            .map(|cholesky| {
                crate::kalman::masked_dot(&innovation, &cholesky.solve(&innovation), &used)
            })
            .filter(|value| value.is_finite())
            .unwrap_or(0.0);

        if self.marginal.is_active() {
            self.draw_marginalised(measurement, input, &used);
        } else if self.noise_pending {
            self.draw_from_optimal_proposal(measurement, input, &used, &noise_cholesky);
        } else {
            self.weigh_by_likelihood(measurement, input, &used, &noise_cholesky, false);
        }
        if normalise_log_weights(&mut self.log_weights, &mut self.weights).is_none() {
            self.reset_around_estimate();
            return Err(FilterIssue::WeightsReset);
        }
        self.effective_sample_size = effective_sample_size(&self.weights);
        self.refresh_estimate();
        Ok(UpdateReport {
            innovation,
            nis,
            rows_used,
            used,
        })
    }

    /// The weighted mean and spread of the particles; with the marginalised proposal (and no
    /// draw pending) plus the linear states' own covariances `Σ wᵢ Eᵢ`.
    fn refresh_estimate(&mut self) {
        let (mean, mut covariance) = weighted_moments(&self.particles, &self.weights);
        if self.marginal.is_active() && !self.noise_pending {
            covariance += self.marginal.weighted_covariance(&self.weights);
        }
        if mean.iter().all(|value| value.is_finite())
            && covariance.iter().all(|value| value.is_finite())
        {
            self.estimate = mean;
            self.covariance = (covariance + covariance.transpose()) * 0.5;
        }
    }

    /// Every weight vanished: keep the finite particles, redraw the others around the last
    /// (finite) estimate with the process noise, and make all weights equal.
    fn reset_around_estimate(&mut self) {
        for (i, particle) in self.particles.iter_mut().enumerate() {
            if particle.iter().any(|value| !value.is_finite()) {
                let noise = self.process_noise_root * standard_normal_vector::<N, _>(&mut self.rng);
                *particle = self.estimate + noise;
                if self.marginal.is_active() {
                    self.marginal.set(i, &self.covariance);
                }
            }
        }
        let count = self.config.particle_count as f64;
        self.weights.fill(1.0 / count);
        self.log_weights.fill(-count.ln());
        self.effective_sample_size = count;
        self.refresh_estimate();
    }
}

impl<Model, const N: usize, const M: usize, const U: usize> Estimator<N, M, U>
    for ParticleFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    fn predict(&mut self, input: &SVector<f64, U>) -> Result<(), FilterIssue> {
        self.propagate(input)
    }

    fn update(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &MeasurementMask<M>,
    ) -> Result<UpdateReport<M>, FilterIssue> {
        let report = self.reweight(measurement, input, mask)?;
        if report.rows_used > 0 {
            self.resample_if_due();
        }
        Ok(report)
    }

    fn state(&self) -> &SVector<f64, N> {
        &self.estimate
    }

    fn covariance(&self) -> &SMatrix<f64, N, N> {
        &self.covariance
    }
}
