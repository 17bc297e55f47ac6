//! The particle filter's settings: resampling scheme and policy, proposal, particle count and
//! seed, and the errors of bad settings.

use nalgebra::SMatrix;

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
pub(super) fn check_proposal<const N: usize>(
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
