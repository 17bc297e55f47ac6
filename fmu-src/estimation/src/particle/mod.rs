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

use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::estimator::{Estimator, FilterIssue, MeasurementMask, UpdateReport};
use crate::kalman::MeasurementNoise;
use crate::model::StateSpaceModel;
use crate::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};

mod marginalised;

use marginalised::{condition_on_measurement, MarginalisedStates};

/// How a weighted particle set is turned into an equally weighted one (003: A.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ResamplingScheme {
    /// `N` independent uniforms, each picks the particle whose cumulative-weight interval holds it.
    Multinomial,
    /// One uniform `u ∈ [0, 1/N)`, then `u_i = u + (i-1)/N`.
    Systematic,
    /// One uniform per stratum: `u_i = ((i-1) + ũ_i)/N`. The seed's choice (003: §3.1).
    #[default]
    Stratified,
}

/// When to resample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ResamplingPolicy {
    /// After every update, as the seed does (003: §2.2.4, "Resampling" in every step).
    #[default]
    EveryStep,
    /// Only when the effective sample size `1/Σw²` falls below this fraction of the particle count.
    EffectiveSampleSizeBelow(f64),
}

/// Where the particles of the next sample are drawn from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Proposal {
    /// From the transition density `p(x_t | x_{t-1})`, weight `p(y_t | x_t)` — the seed's SIR
    /// (003: 2.57-2.61).
    #[default]
    Bootstrap,
    /// From the Gaussian that conditions the transition density on `y_t` with the measurement
    /// function linearised at `f(x_{t-1})` (Doucet et al. 2000's locally linearised optimal
    /// importance density; exact for a linear measurement such as model C's `y = x`), weight
    /// `p(y|x) p(x|x_{t-1}) / q(x|x_{t-1}, y)` (003: 2.56-2.57 with this `π`). Needs a positive
    /// definite process noise. Much larger effective sample size when the measurement is far
    /// more precise than the process noise; not in the seed.
    LinearisedOptimal,
    /// The linearised optimal proposal with the model's conditionally linear states
    /// ([`StateSpaceModel::conditionally_linear_states`]) kept per particle as a Kalman mean and
    /// covariance instead of being sampled: the marginalised (Rao-Blackwellised) particle filter
    /// of Schön, Gustafsson and Nordlund (2005), with the weight `N(y; h(f), H P Hᵀ + R)` of
    /// each particle's joint prediction (module `marginalised`). On a model without such
    /// states it is [`Proposal::LinearisedOptimal`]. Not in the seed.
    Marginalised,
}

/// Settings of a particle filter. The particle count is a run-time value (the FMU sets it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleFilterConfig {
    pub particle_count: usize,
    pub scheme: ResamplingScheme,
    pub policy: ResamplingPolicy,
    /// Seed of the ChaCha random stream (initial draw, process noise, resampling).
    pub seed: u64,
    /// Where the particles are drawn from ([`Proposal`]; the seed's bootstrap by default).
    pub proposal: Proposal,
}

impl Default for ParticleFilterConfig {
    fn default() -> Self {
        Self {
            particle_count: 1000,
            scheme: ResamplingScheme::Stratified,
            policy: ResamplingPolicy::EveryStep,
            seed: 0,
            proposal: Proposal::Bootstrap,
        }
    }
}

/// Bad settings given to a particle filter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParticleFilterError {
    #[error("particle_count must be at least 1, got {0}")]
    NoParticles(usize),
    #[error("the resampling threshold must be a fraction in (0, 1], got {0}")]
    BadResamplingThreshold(f64),
    #[error("the initial state must be finite, got {0:?}")]
    NonFiniteInitialState(Vec<f64>),
    #[error(
        "the {0} covariance must be finite, symmetric and positive semi-definite (smallest eigenvalue {1})"
    )]
    NotPositiveSemiDefinite(&'static str, f64),
    #[error("the snapshot holds {found} {what}, the filter has {expected} particles")]
    SnapshotSize {
        what: &'static str,
        found: usize,
        expected: usize,
    },
    #[error("the snapshot's ancestor index {0} is not a particle index")]
    SnapshotAncestor(usize),
}

/// The linearised optimal proposal conditions each particle's Gaussian prediction, whose
/// covariance is the process noise, on the measurement; it takes that covariance's Cholesky
/// factor, so the process noise must be positive definite. The marginalised proposal draws
/// with a semi-definite square root and needs no more than the other settings.
fn check_proposal<const N: usize>(
    proposal: Proposal,
    process_noise: &SMatrix<f64, N, N>,
    marginalises: bool,
) -> Result<(), ParticleFilterError> {
    let plain_optimal = proposal == Proposal::LinearisedOptimal
        || (proposal == Proposal::Marginalised && !marginalises);
    if plain_optimal && process_noise.cholesky().is_none() {
        return Err(ParticleFilterError::NotPositiveSemiDefinite(
            "process noise (must be positive definite for the linearised optimal proposal)",
            0.0,
        ));
    }
    Ok(())
}

/// Everything of a [`ParticleFilter`] that changes while it runs: with the same model, settings
/// and proposal, [`ParticleFilter::restore`] of a snapshot continues bit-identically to the
/// filter it was taken from (an FMU's fmi2SerializeFMUstate needs this). The scratch buffers
/// (resampling, predicted measurements) are rewritten before every use and are not part of it.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleFilterSnapshot<const N: usize> {
    /// The ChaCha8 generator: its seed, stream and position in the stream (in 32-bit words).
    pub rng_seed: [u8; 32],
    pub rng_stream: u64,
    pub rng_word_pos: u128,
    pub particles: Vec<SVector<f64, N>>,
    pub log_weights: Vec<f64>,
    pub weights: Vec<f64>,
    pub ancestors: Vec<usize>,
    /// `f(x_i, u)` of the last prediction; only meaningful while `noise_pending`.
    pub predicted_means: Vec<SVector<f64, N>>,
    /// The linearised optimal proposal predicted and waits for the measurement to draw noise.
    pub noise_pending: bool,
    /// The marginalised proposal's covariances of the conditionally linear states, L×L per
    /// particle (column-major); empty when nothing is marginalised.
    pub linear_covariances: Vec<f64>,
    /// The columns of each particle's transition Jacobian at the linear states (N×L); only
    /// meaningful while `noise_pending`.
    pub linear_columns: Vec<f64>,
    /// Process noise the host added to the pending prediction; only meaningful while
    /// `noise_pending`.
    pub pending_extra: SMatrix<f64, N, N>,
    pub estimate: SVector<f64, N>,
    pub covariance: SMatrix<f64, N, N>,
    pub effective_sample_size: f64,
    pub resampled_in_last_update: bool,
}

/// A lower-triangular square root `S` with `S Sᵀ = P` of a symmetric positive semi-definite
/// matrix: the Cholesky factor, computed so that a singular `P` (e.g. a state without process
/// noise, or an exactly known initial state) is legitimate: a pivot that is zero up to rounding
/// gives a zero column instead of a failure. A clearly negative pivot is an error.
pub fn covariance_square_root<const N: usize>(
    covariance: &SMatrix<f64, N, N>,
    what: &'static str,
) -> Result<SMatrix<f64, N, N>, ParticleFilterError> {
    if covariance.iter().any(|value| !value.is_finite()) {
        return Err(ParticleFilterError::NotPositiveSemiDefinite(what, f64::NAN));
    }
    let symmetric = (covariance + covariance.transpose()) * 0.5;
    let tolerance = 1e-12 * symmetric.amax().max(f64::MIN_POSITIVE);
    let mut root = SMatrix::<f64, N, N>::zeros();
    for column in 0..N {
        let mut pivot = symmetric[(column, column)];
        for k in 0..column {
            pivot -= root[(column, k)] * root[(column, k)];
        }
        if pivot < -tolerance {
            return Err(ParticleFilterError::NotPositiveSemiDefinite(what, pivot));
        }
        if pivot <= tolerance {
            continue;
        }
        let diagonal = pivot.sqrt();
        root[(column, column)] = diagonal;
        for row in column + 1..N {
            let mut value = symmetric[(row, column)];
            for k in 0..column {
                value -= root[(row, k)] * root[(column, k)];
            }
            root[(row, column)] = value / diagonal;
        }
    }
    Ok(root)
}

/// Effective sample size `1 / Σ w_i²` of normalised weights.
pub fn effective_sample_size(weights: &[f64]) -> f64 {
    let sum_of_squares: f64 = weights.iter().map(|w| w * w).sum();
    if sum_of_squares > 0.0 {
        1.0 / sum_of_squares
    } else {
        0.0
    }
}

/// Draws `ancestors.len()` indices from `weights` (non-negative, not necessarily normalised,
/// positive sum) with the given scheme (003: A.4). `cumulative` is scratch of the same length as
/// `weights`; nothing is allocated.
pub fn resample_indices<R: Rng + ?Sized>(
    scheme: ResamplingScheme,
    weights: &[f64],
    cumulative: &mut [f64],
    ancestors: &mut [usize],
    rng: &mut R,
) {
    assert_eq!(weights.len(), cumulative.len(), "cumulative scratch length");
    assert!(!weights.is_empty(), "resampling needs at least one weight");
    // s_i = Σ_{j≤i} w_j (003: A.4, multinomial).
    let mut running = 0.0;
    for (sum, weight) in cumulative.iter_mut().zip(weights) {
        running += weight;
        *sum = running;
    }
    let total = running;
    let last = weights.len() - 1;
    let count = ancestors.len();
    match scheme {
        ResamplingScheme::Multinomial => {
            for ancestor in ancestors.iter_mut() {
                let u = rng.random::<f64>() * total;
                // The first i with u < s_i, i.e. u ∈ [s_{i-1}, s_i).
                let index = cumulative.partition_point(|&sum| sum <= u);
                *ancestor = index.min(last);
            }
        }
        ResamplingScheme::Systematic | ResamplingScheme::Stratified => {
            let stride = total / count as f64;
            let offset = rng.random::<f64>();
            let mut index = 0;
            for (k, ancestor) in ancestors.iter_mut().enumerate() {
                let fraction = match scheme {
                    ResamplingScheme::Systematic => offset,
                    _ if k == 0 => offset,
                    _ => rng.random::<f64>(),
                };
                let u = (k as f64 + fraction) * stride;
                while index < last && cumulative[index] <= u {
                    index += 1;
                }
                *ancestor = index;
            }
        }
    }
}

/// Weighted mean and weighted sample covariance `Σ w_i (x_i - x̄)(x_i - x̄)ᵀ` of normalised weights.
pub fn weighted_moments<const N: usize>(
    particles: &[SVector<f64, N>],
    weights: &[f64],
) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
    let mut mean = SVector::<f64, N>::zeros();
    for (particle, &weight) in particles.iter().zip(weights) {
        if weight > 0.0 {
            mean += particle * weight;
        }
    }
    let mut covariance = SMatrix::<f64, N, N>::zeros();
    for (particle, &weight) in particles.iter().zip(weights) {
        if weight > 0.0 {
            let deviation = particle - mean;
            covariance.ger(weight, &deviation, &deviation, 1.0);
        }
    }
    (mean, covariance)
}

/// Normalises log-weights in place (max-shift, so the largest weight is exp(0) before
/// normalising) and writes the linear normalised weights. Returns `None` when no weight is
/// positive and finite (every particle impossible or non-finite).
fn normalise_log_weights(log_weights: &mut [f64], weights: &mut [f64]) -> Option<()> {
    let largest = log_weights
        .iter()
        .copied()
        .filter(|value| !value.is_nan())
        .fold(f64::NEG_INFINITY, f64::max);
    if !largest.is_finite() {
        return None;
    }
    let mut total = 0.0;
    for (weight, log_weight) in weights.iter_mut().zip(log_weights.iter()) {
        *weight = if log_weight.is_nan() {
            0.0
        } else {
            (log_weight - largest).exp()
        };
        total += *weight;
    }
    let log_total = total.ln();
    for (weight, log_weight) in weights.iter_mut().zip(log_weights.iter_mut()) {
        *weight /= total;
        *log_weight = if *weight > 0.0 {
            *log_weight - largest - log_total
        } else {
            f64::NEG_INFINITY
        };
    }
    Some(())
}

/// The measurement rows used in one update: masked in and finite.
pub(crate) fn used_rows<const M: usize>(
    measurement: &SVector<f64, M>,
    mask: &MeasurementMask<M>,
) -> MeasurementMask<M> {
    let mut used = [false; M];
    for (row, flag) in used.iter_mut().enumerate() {
        *flag = mask[row] && measurement[row].is_finite();
    }
    used
}

/// `R` restricted to the used rows, padded to full size: unused rows and columns become those of
/// the identity, so a Cholesky of the padded matrix is the Cholesky of the used block, and a
/// residual that is zero in unused rows gives the used-rows quadratic form. No allocation.
pub(crate) fn masked_covariance<const M: usize>(
    covariance: &SMatrix<f64, M, M>,
    used: &MeasurementMask<M>,
) -> SMatrix<f64, M, M> {
    let mut masked = *covariance;
    for row in 0..M {
        for column in 0..M {
            if !used[row] || !used[column] {
                masked[(row, column)] = if row == column { 1.0 } else { 0.0 };
            }
        }
    }
    masked
}

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

    /// [`Self::pending_linear_spread`] for the current weights and stored Jacobian columns.
    fn refresh_pending_linear_spread(&mut self) {
        if self.marginal.is_active() {
            self.pending_linear_spread = self.marginal.weighted_linear_spread(&self.weights);
        }
    }

    /// The covariance the pending draw adds to the spread of the predicted means: `Q`, and with
    /// the marginalised proposal the linear states' uncertainty carried through `F`.
    fn pending_spread(&self) -> SMatrix<f64, N, N> {
        if self.marginal.is_active() {
            self.pending_linear_spread + self.pending_process_noise()
        } else {
            self.process_noise
        }
    }

    /// `Q` of the pending prediction, with what the host added ([`Self::inflate_pending`]).
    fn pending_process_noise(&self) -> SMatrix<f64, N, N> {
        self.process_noise + self.pending_extra
    }

    /// Adds `extra` (symmetric positive semi-definite) to the process noise of the prediction
    /// whose draw is pending, as a state-dependent process noise the host sizes from the
    /// estimate. Only the marginalised proposal takes it (each particle's prediction is a
    /// Gaussian it conditions anyway); the other proposals draw with the fixed `Q` and return
    /// `false`, changing nothing.
    pub fn inflate_pending(&mut self, extra: &SMatrix<f64, N, N>) -> bool {
        if !(self.marginal.is_active() && self.noise_pending) {
            return false;
        }
        self.pending_extra += extra;
        self.covariance += extra;
        true
    }

    /// A predict without a following update (no measurement row present): the deferred noise
    /// of the optimal proposal is drawn from the prior, i.e. a bootstrap step.
    fn draw_pending_noise_from_prior(&mut self) {
        if !self.noise_pending {
            return;
        }
        if self.marginal.is_active() {
            let process_noise = self.pending_process_noise();
            for i in 0..self.particles.len() {
                let prediction = self.pending_prediction(i, &process_noise);
                self.draw_particle(i, prediction, 0.0);
            }
            self.noise_pending = false;
            self.pending_extra = SMatrix::zeros();
            if normalise_log_weights(&mut self.log_weights, &mut self.weights).is_none() {
                self.reset_around_estimate();
            }
            self.refresh_estimate();
            return;
        }
        for (particle, mean) in self.particles.iter_mut().zip(&self.predicted_means) {
            *particle =
                mean + self.process_noise_root * standard_normal_vector::<N, _>(&mut self.rng);
        }
        self.noise_pending = false;
        self.refresh_estimate();
    }

    /// The optimal-proposal draw and weight of every particle: `x ~ N(m, Σ)` with
    /// `S = H Q Hᵀ + R`, `K = Q Hᵀ S⁻¹`, `m = f + K (y - h(f))`, `Σ = Q - K H Q` over the used
    /// rows, and `log w += log p(y|x) + log p(x|f) - log q(x)`.
    fn draw_from_optimal_proposal(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        used: &MeasurementMask<M>,
        noise_cholesky: &nalgebra::Cholesky<f64, nalgebra::Const<M>>,
    ) {
        // Positive definite by `check_proposal`; should that ever fail, fall back to
        // the bootstrap draw and weight rather than panic inside a step.
        let Some(process_cholesky) = self.process_noise.cholesky() else {
            self.draw_pending_noise_from_prior();
            self.weigh_by_likelihood(measurement, input, used, noise_cholesky, true);
            return;
        };
        for ((particle, mean), log_weight) in self
            .particles
            .iter_mut()
            .zip(&self.predicted_means)
            .zip(self.log_weights.iter_mut())
        {
            if !log_weight.is_finite() {
                continue;
            }
            let mut jacobian = self.model.measurement_jacobian(mean, input);
            let mut innovation = measurement - self.model.measurement(mean, input);
            for (row, &flag) in used.iter().enumerate() {
                if !flag {
                    jacobian.row_mut(row).fill(0.0);
                    innovation[row] = 0.0;
                }
            }
            let q_ht = self.process_noise * jacobian.transpose();
            let innovation_covariance =
                masked_covariance(&(jacobian * q_ht + self.measurement_noise), used);
            let Some(s_cholesky) = innovation_covariance.cholesky() else {
                *log_weight = f64::NEG_INFINITY;
                continue;
            };
            let gain = q_ht * s_cholesky.inverse();
            let proposal_mean = mean + gain * innovation;
            let proposal_covariance = self.process_noise - gain * jacobian * self.process_noise;
            let proposal_covariance = (proposal_covariance + proposal_covariance.transpose()) * 0.5;
            let Some(proposal_cholesky) = proposal_covariance.cholesky() else {
                *log_weight = f64::NEG_INFINITY;
                continue;
            };
            let standard = standard_normal_vector::<N, _>(&mut self.rng);
            let proposal_factor = proposal_cholesky.l();
            *particle = proposal_mean + proposal_factor * standard;
            // log q(x) = -½|z|² - Σ log L_ii (constants shared by all particles dropped).
            let log_proposal = -0.5 * standard.norm_squared()
                - proposal_factor
                    .diagonal()
                    .iter()
                    .map(|d| d.ln())
                    .sum::<f64>();
            let deviation = *particle - mean;
            let log_transition = -0.5 * deviation.dot(&process_cholesky.solve(&deviation));
            let predicted = self.model.measurement(particle, input);
            let log_likelihood = log_likelihood(measurement, &predicted, used, noise_cholesky);
            let increment = log_likelihood + log_transition - log_proposal;
            *log_weight += if increment.is_nan() || particle.iter().any(|v| !v.is_finite()) {
                f64::NEG_INFINITY
            } else {
                increment
            };
        }
        self.noise_pending = false;
    }

    /// The marginalised proposal's draw and weight of every particle (module `marginalised`):
    /// its joint prediction `N(f, F E Fᵀ + Q)` conditioned on the used rows of `y`, the weight
    /// times `N(y; h(f), S)`, the sampled states drawn and the linear ones conditioned on them.
    /// Without a pending prediction (an update that follows an update, such as the first) only
    /// the linear states are uncertain: each particle's Kalman update of them, nothing drawn.
    fn draw_marginalised(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        used: &MeasurementMask<M>,
    ) {
        let measurement_noise = MeasurementNoise::new(self.measurement_noise);
        let process_noise = self.pending_process_noise();
        for i in 0..self.particles.len() {
            if !self.log_weights[i].is_finite() {
                continue;
            }
            let (mean, prediction) = if self.noise_pending {
                self.pending_prediction(i, &process_noise)
            } else {
                (self.particles[i], self.marginal.embedded(i))
            };
            let conditioned = condition_on_measurement(
                &self.model,
                (&mean, &prediction),
                measurement,
                input,
                used,
                &measurement_noise,
            );
            match conditioned {
                Some((conditioned_mean, conditioned, log_likelihood)) if self.noise_pending => {
                    self.draw_particle(i, (conditioned_mean, conditioned), log_likelihood);
                }
                Some((conditioned_mean, conditioned, log_likelihood))
                    if log_likelihood.is_finite()
                        && conditioned_mean.iter().all(|v| v.is_finite()) =>
                {
                    self.particles[i] = conditioned_mean;
                    self.marginal.set(i, &conditioned);
                    self.log_weights[i] += log_likelihood;
                }
                _ => self.log_weights[i] = f64::NEG_INFINITY,
            }
        }
        self.noise_pending = false;
        self.pending_extra = SMatrix::zeros();
    }

    /// Particle `i`'s pending joint prediction `(f, F E Fᵀ + Q)` (marginalised proposal);
    /// `process_noise` is [`Self::pending_process_noise`], formed once per update by the caller.
    fn pending_prediction(
        &self,
        i: usize,
        process_noise: &SMatrix<f64, N, N>,
    ) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        (
            self.predicted_means[i],
            self.marginal.predicted_covariance(i, process_noise),
        )
    }

    /// Particle `i` drawn from `gaussian` (its sampled states, the linear ones conditioned on
    /// them), its log weight raised by `log_likelihood`. A failed or non-finite draw (only
    /// through a non-finite Jacobian or measurement) keeps the Gaussian's mean and loses the
    /// particle's weight.
    fn draw_particle(
        &mut self,
        i: usize,
        gaussian: (SVector<f64, N>, SMatrix<f64, N, N>),
        log_likelihood: f64,
    ) {
        let (mean, covariance) = gaussian;
        match self
            .marginal
            .conditional_draw(&mean, &covariance, &mut self.rng)
        {
            Some((particle, linear_covariance))
                if log_likelihood.is_finite() && particle.iter().all(|v| v.is_finite()) =>
            {
                self.particles[i] = particle;
                self.marginal.set(i, &linear_covariance);
                self.log_weights[i] += log_likelihood;
            }
            _ => {
                self.particles[i] = mean;
                self.marginal.set(i, &SMatrix::zeros());
                self.log_weights[i] = f64::NEG_INFINITY;
            }
        }
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

    /// Resamples when the policy asks for it (003: A.4); afterwards all weights are `1/N`.
    pub fn resample_if_due(&mut self) {
        let due = match self.config.policy {
            ResamplingPolicy::EveryStep => true,
            ResamplingPolicy::EffectiveSampleSizeBelow(fraction) => {
                self.effective_sample_size < fraction * self.config.particle_count as f64
            }
        };
        if due {
            self.resample();
        }
    }

    /// Resamples now with the configured scheme.
    pub fn resample(&mut self) {
        resample_indices(
            self.config.scheme,
            &self.weights,
            &mut self.cumulative,
            &mut self.ancestors,
            &mut self.rng,
        );
        for (target, &ancestor) in self.resampled.iter_mut().zip(&self.ancestors) {
            *target = self.particles[ancestor];
        }
        std::mem::swap(&mut self.particles, &mut self.resampled);
        if self.marginal.is_active() {
            self.marginal.resample(&self.ancestors);
        }
        let count = self.config.particle_count as f64;
        self.weights.fill(1.0 / count);
        self.log_weights.fill(-count.ln());
        self.resampled_in_last_update = true;
    }

    /// The ancestor of every particle in the last resampling (identity if none happened yet).
    pub fn ancestors(&self) -> &[usize] {
        &self.ancestors
    }

    /// The filter's running state (allocates; not meant for the step loop).
    pub fn snapshot(&self) -> ParticleFilterSnapshot<N> {
        ParticleFilterSnapshot {
            rng_seed: self.rng.get_seed(),
            rng_stream: self.rng.get_stream(),
            rng_word_pos: self.rng.get_word_pos(),
            particles: self.particles.clone(),
            log_weights: self.log_weights.clone(),
            weights: self.weights.clone(),
            ancestors: self.ancestors.clone(),
            predicted_means: self.predicted_means.clone(),
            noise_pending: self.noise_pending,
            linear_covariances: self.marginal.covariances().to_vec(),
            linear_columns: self.marginal.columns().to_vec(),
            pending_extra: self.pending_extra,
            estimate: self.estimate,
            covariance: self.covariance,
            effective_sample_size: self.effective_sample_size,
            resampled_in_last_update: self.resampled_in_last_update,
        }
    }

    /// Continues from `snapshot`, taken from a filter with the same particle count (checked);
    /// the model, settings and proposal are this filter's. On an error nothing is changed.
    pub fn restore(
        &mut self,
        snapshot: &ParticleFilterSnapshot<N>,
    ) -> Result<(), ParticleFilterError> {
        let expected = self.config.particle_count;
        for (what, found) in [
            ("particles", snapshot.particles.len()),
            ("log weights", snapshot.log_weights.len()),
            ("weights", snapshot.weights.len()),
            ("ancestors", snapshot.ancestors.len()),
            ("predicted means", snapshot.predicted_means.len()),
        ] {
            if found != expected {
                return Err(ParticleFilterError::SnapshotSize {
                    what,
                    found,
                    expected,
                });
            }
        }
        let (covariance_size, column_size) = self.marginal.sizes_per_particle();
        for (what, found, size) in [
            (
                "linear-state covariances",
                snapshot.linear_covariances.len(),
                covariance_size,
            ),
            (
                "linear-state Jacobian columns",
                snapshot.linear_columns.len(),
                column_size,
            ),
        ] {
            if found != expected * size {
                return Err(ParticleFilterError::SnapshotSize {
                    what,
                    found: found / size.max(1),
                    expected,
                });
            }
        }
        if let Some(&bad) = snapshot.ancestors.iter().find(|&&a| a >= expected) {
            return Err(ParticleFilterError::SnapshotAncestor(bad));
        }
        let mut rng = ChaCha8Rng::from_seed(snapshot.rng_seed);
        rng.set_stream(snapshot.rng_stream);
        rng.set_word_pos(snapshot.rng_word_pos);
        self.rng = rng;
        self.particles.copy_from_slice(&snapshot.particles);
        self.log_weights.copy_from_slice(&snapshot.log_weights);
        self.weights.copy_from_slice(&snapshot.weights);
        self.ancestors.copy_from_slice(&snapshot.ancestors);
        self.predicted_means
            .copy_from_slice(&snapshot.predicted_means);
        self.noise_pending = snapshot.noise_pending;
        self.marginal
            .restore(&snapshot.linear_covariances, &snapshot.linear_columns);
        self.pending_extra = snapshot.pending_extra;
        if self.noise_pending {
            self.refresh_pending_linear_spread();
        }
        self.estimate = snapshot.estimate;
        self.covariance = snapshot.covariance;
        self.effective_sample_size = snapshot.effective_sample_size;
        self.resampled_in_last_update = snapshot.resampled_in_last_update;
        Ok(())
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

/// `log N(y; ŷ, R)` over the used rows, up to a constant shared by all particles (003: 2.60);
/// `noise_cholesky` is that of `R` restricted to them ([`masked_covariance`]).
fn log_likelihood<const M: usize>(
    measurement: &SVector<f64, M>,
    predicted: &SVector<f64, M>,
    used: &MeasurementMask<M>,
    noise_cholesky: &nalgebra::Cholesky<f64, nalgebra::Const<M>>,
) -> f64 {
    let mut residual = measurement - predicted;
    for (row, &flag) in used.iter().enumerate() {
        if !flag {
            residual[row] = 0.0;
        }
    }
    let whitened = noise_cholesky
        .l_dirty()
        .solve_lower_triangular(&residual)
        .unwrap_or_else(|| SVector::repeat(f64::INFINITY));
    -0.5 * whitened.norm_squared()
}

/// Storage for the marginalised proposal's linear states, where `proposal` asks for it and the
/// model has such states; none otherwise.
fn marginal_storage<Model, const N: usize, const M: usize, const U: usize>(
    model: &Model,
    proposal: Proposal,
    count: usize,
) -> MarginalisedStates<N>
where
    Model: StateSpaceModel<N, M, U>,
{
    let indices = model.conditionally_linear_states();
    if proposal == Proposal::Marginalised && !indices.is_empty() {
        MarginalisedStates::new(indices, count)
    } else {
        MarginalisedStates::none()
    }
}

/// A vector of independent standard normal draws.
fn standard_normal_vector<const N: usize, R: Rng + ?Sized>(rng: &mut R) -> SVector<f64, N> {
    SVector::from_fn(|_, _| rng.sample(StandardNormal))
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

/// A recorded run: the input `u(k)` and the measurement `y(k)` of every sample `k = 0..T-1`.
/// A non-finite measurement entry is a missing sample and is skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedRun<const M: usize, const U: usize> {
    pub inputs: Vec<SVector<f64, U>>,
    pub measurements: Vec<SVector<f64, M>>,
}

impl<const M: usize, const U: usize> RecordedRun<M, U> {
    /// Number of samples `T`.
    pub fn len(&self) -> usize {
        self.measurements.len().min(self.inputs.len())
    }

    /// Whether there is no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// A run from plain rows, checked: as many input as measurement rows, every input finite
    /// (`input_meaning` names the row's entries in the message), measurements finite or NaN
    /// (missing). Also returns the index of the first complete measurement row, if any (an
    /// identification typically starts its state there).
    pub fn from_checked_rows(
        inputs: &[[f64; U]],
        measurements: &[[f64; M]],
        input_meaning: &str,
    ) -> Result<(Self, Option<usize>), String> {
        if inputs.len() != measurements.len() {
            return Err(format!(
                "inputs has {} rows but measurements has {}; expected one input row per measurement row",
                inputs.len(),
                measurements.len()
            ));
        }
        if let Some(k) = inputs
            .iter()
            .position(|row| row.iter().any(|v| !v.is_finite()))
        {
            return Err(format!(
                "input row {k} is {:?}; expected finite {input_meaning}",
                inputs[k]
            ));
        }
        if let Some(k) = measurements
            .iter()
            .position(|row| row.iter().any(|v| v.is_infinite()))
        {
            return Err(format!(
                "measurement row {k} is {:?}; expected finite values or NaN for missing",
                measurements[k]
            ));
        }
        let first_complete = measurements
            .iter()
            .position(|row| row.iter().all(|v| v.is_finite()));
        let run = Self {
            inputs: inputs.iter().map(|row| SVector::from(*row)).collect(),
            measurements: measurements.iter().map(|row| SVector::from(*row)).collect(),
        };
        Ok((run, first_complete))
    }
}

/// The filter's weighted particle sets of a whole run, as the smoother needs them: for each
/// sample `t`, the particles after the update with `y(t)` and before resampling, with their
/// normalised filter weights `w̃_t` (003: 2.68). Flat storage, sample-major.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleHistory<const N: usize> {
    pub particle_count: usize,
    pub particles: Vec<SVector<f64, N>>,
    pub weights: Vec<f64>,
    /// The filter estimate (weighted mean) of each sample.
    pub estimates: Vec<SVector<f64, N>>,
    /// How many updates ended in [`FilterIssue::WeightsReset`] or were skipped.
    pub issues: usize,
}

impl<const N: usize> ParticleHistory<N> {
    /// Number of samples `T`.
    pub fn len(&self) -> usize {
        self.estimates.len()
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.estimates.is_empty()
    }

    /// The particles of sample `t`.
    pub fn particles_at(&self, t: usize) -> &[SVector<f64, N>] {
        &self.particles[t * self.particle_count..(t + 1) * self.particle_count]
    }

    /// The normalised filter weights of sample `t`.
    pub fn weights_at(&self, t: usize) -> &[f64] {
        &self.weights[t * self.particle_count..(t + 1) * self.particle_count]
    }
}

/// Runs the filter over a recorded run and keeps every weighted particle set: update with
/// `y(0)` first, then for `k ≥ 1` predict with `u(k-1)` and update with `y(k)`, `u(k)` (the
/// timing of [`Estimator`]).
pub fn filter_run<Model, const N: usize, const M: usize, const U: usize>(
    filter: &mut ParticleFilter<Model, N, M, U>,
    run: &RecordedRun<M, U>,
) -> ParticleHistory<N>
where
    Model: StateSpaceModel<N, M, U>,
{
    let steps = run.len();
    let count = filter.config.particle_count;
    let mut history = ParticleHistory {
        particle_count: count,
        particles: Vec::with_capacity(steps * count),
        weights: Vec::with_capacity(steps * count),
        estimates: Vec::with_capacity(steps),
        issues: 0,
    };
    let all_rows = [true; M];
    for k in 0..steps {
        if k > 0 && filter.propagate(&run.inputs[k - 1]).is_err() {
            history.issues += 1;
        }
        match filter.reweight(&run.measurements[k], &run.inputs[k], &all_rows) {
            Ok(_) => {}
            Err(_) => history.issues += 1,
        }
        history.particles.extend_from_slice(&filter.particles);
        history.weights.extend_from_slice(&filter.weights);
        history.estimates.push(filter.estimate);
        if k + 1 < steps {
            filter.resample_if_due();
        }
    }
    history
}

/// Layout of a particle filter's stored state; a state written with another layout is refused
/// by name instead of being misread.
/// Layout 2 (2026-12-05) added the marginalised proposal's linear-state covariances.
pub const SNAPSHOT_LAYOUT: u8 = 2;

/// In the registry: the particle filter stores its whole running state ([`ParticleFilterSnapshot`],
/// random generator position included), compactly: ancestors as u32 (an FMU allows at most
/// 100000 particles), the propagated means only while the optimal proposal's noise draw is
/// pending (otherwise the filter never reads them before overwriting them).
impl<Model, const N: usize, const M: usize, const U: usize>
    crate::running::RunningEstimator<N, M, U> for ParticleFilter<Model, N, M, U>
where
    Model: crate::running::RegistryModel<N, M, U>,
{
    fn last_report(&self) -> UpdateReport<M> {
        UpdateReport::skipped()
    }

    // `R + extra` for one update, in the likelihood `N(y; h(x_i, u), R)` (003: 2.60), the
    // optimal proposal and the reported innovation covariance; the same for every particle (the
    // host sizes it from the estimate).
    crate::kalman::update_with_r_plus_extra!();

    /// The marginalised proposal takes a state-dependent process noise into its pending draw
    /// ([`ParticleFilter::inflate_pending`]); the others do not.
    fn inflate_covariance(&mut self, extra: &SMatrix<f64, N, N>) -> bool {
        self.inflate_pending(extra)
    }

    fn save(&self, sink: &mut dyn SnapshotSink) {
        let snapshot = self.snapshot();
        sink.u8(SNAPSHOT_LAYOUT);
        sink.bytes(&snapshot.rng_seed);
        sink.u64(snapshot.rng_stream);
        sink.u64(snapshot.rng_word_pos as u64);
        sink.u64((snapshot.rng_word_pos >> 64) as u64);
        let flat = |vectors: &[SVector<f64, N>]| -> Vec<f64> {
            vectors.iter().flat_map(|v| v.iter().copied()).collect()
        };
        sink.f64s(&flat(&snapshot.particles));
        sink.f64s(&snapshot.log_weights);
        sink.f64s(&snapshot.weights);
        sink.u64(snapshot.ancestors.len() as u64);
        for &ancestor in &snapshot.ancestors {
            sink.u32(ancestor as u32);
        }
        sink.bool(snapshot.noise_pending);
        if snapshot.noise_pending {
            sink.f64s(&flat(&snapshot.predicted_means));
        }
        sink.f64s(&snapshot.linear_covariances);
        if snapshot.noise_pending {
            sink.f64s(&snapshot.linear_columns);
            sink.f64s(snapshot.pending_extra.as_slice());
        }
        sink.f64s(snapshot.estimate.as_slice());
        sink.f64s(snapshot.covariance.as_slice());
        sink.f64(snapshot.effective_sample_size);
        sink.bool(snapshot.resampled_in_last_update);
    }

    /// Sizes are checked against this filter's particle count before anything is allocated.
    fn restore(
        &mut self,
        source: &mut dyn SnapshotSource,
    ) -> Result<crate::running::Restored<N>, SnapshotError> {
        let snapshot = read_snapshot(self, source)?;
        self.restore(&snapshot)
            .map_err(|e| SnapshotError(format!("particle filter state: {e}")))?;
        Ok(crate::running::Restored::InPlace)
    }
}

/// Reads what `RunningEstimator::save` wrote for `filter`'s particle count.
fn read_snapshot<Model, const N: usize, const M: usize, const U: usize>(
    filter: &ParticleFilter<Model, N, M, U>,
    source: &mut dyn SnapshotSource,
) -> Result<ParticleFilterSnapshot<N>, SnapshotError>
where
    Model: StateSpaceModel<N, M, U>,
{
    let layout = source.u8("particle state layout")?;
    if layout != SNAPSHOT_LAYOUT {
        return Err(SnapshotError(format!(
            "particle filter state layout {layout}; expected {SNAPSHOT_LAYOUT}"
        )));
    }
    let count = filter.config().particle_count;
    let rng_seed: [u8; 32] = source
        .bytes("particle filter random seed")?
        .try_into()
        .map_err(|_| SnapshotError("'particle filter random seed' must be 32 bytes".into()))?;
    let rng_stream = source.u64("particle filter random stream")?;
    let word_low = source.u64("particle filter random position")?;
    let word_high = source.u64("particle filter random position")?;
    let vectors = |values: Vec<f64>| -> Vec<SVector<f64, N>> {
        values
            .chunks_exact(N)
            .map(SVector::from_column_slice)
            .collect()
    };
    let particles = vectors(source.f64s("particles", count * N)?);
    let log_weights = source.f64s("particle log weights", count)?;
    let weights = source.f64s("particle weights", count)?;
    let ancestor_count = source.u64("particle ancestors")?;
    if ancestor_count != count as u64 {
        return Err(SnapshotError(format!(
            "'particle ancestors' has {ancestor_count} entries; expected {count} (particle_count)"
        )));
    }
    let ancestors = (0..count)
        .map(|_| source.u32("particle ancestors").map(|a| a as usize))
        .collect::<Result<Vec<_>, _>>()?;
    let noise_pending = source.bool("particle noise pending")?;
    let predicted_means = if noise_pending {
        vectors(source.f64s("particle predictions", count * N)?)
    } else {
        // Not read before the next propagation overwrites them: keep the filter's own.
        filter.predicted_means.clone()
    };
    let (covariance_size, column_size) = filter.marginal.sizes_per_particle();
    let linear_covariances =
        source.f64s("particle linear-state covariances", count * covariance_size)?;
    let linear_columns = if noise_pending {
        source.f64s(
            "particle linear-state Jacobian columns",
            count * column_size,
        )?
    } else {
        filter.marginal.columns().to_vec()
    };
    let mut pending_extra = SMatrix::<f64, N, N>::zeros();
    if noise_pending {
        source.f64s_into(
            pending_extra.as_mut_slice(),
            "particle pending process noise",
        )?;
    }
    let mut estimate = SVector::<f64, N>::zeros();
    source.f64s_into(estimate.as_mut_slice(), "particle estimate")?;
    let mut covariance = SMatrix::<f64, N, N>::zeros();
    source.f64s_into(covariance.as_mut_slice(), "particle covariance")?;
    Ok(ParticleFilterSnapshot {
        rng_seed,
        rng_stream,
        rng_word_pos: u128::from(word_low) | (u128::from(word_high) << 64),
        particles,
        log_weights,
        weights,
        ancestors,
        predicted_means,
        noise_pending,
        linear_covariances,
        linear_columns,
        pending_extra,
        estimate,
        covariance,
        effective_sample_size: source.f64("particle effective sample size")?,
        resampled_in_last_update: source.bool("particle resampled flag")?,
    })
}
