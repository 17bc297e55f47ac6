//! Reweighting (marginal) particle smoother (003: 2.63-2.75, 3.1-3.2; Särkkä's forward-filtering
//! backward-smoothing), O(N²T).
//!
//! The smoother keeps the filter's particles and changes only their weights, backwards in time:
//!
//! ```text
//! w_{T|T} = w̃_T,
//! w_{t|T}^l = Σ_i w_{t+1|T}^i · w̃_t^l p(x_{t+1}^i | x_t^l) / Σ_j w̃_t^j p(x_{t+1}^i | x_t^j)   (003: 2.74)
//! ```
//!
//! followed by the normalisation 003: 2.75. The particles at `t` are the filter's weighted set
//! after the update with `y(t)` and before resampling (003: 2.68); with resampling in every step
//! and the resampled (equally weighted) set on the right-hand side this is the seed's form 3.1.
//! The weighted form is used here because it needs no ancestor book-keeping and is the same
//! approximation without the resampling noise.
//!
//! Speed: the backward kernel `K_t[i][l] = w̃_t^l p(x_{t+1}^i|x_t^l) / Σ_j w̃_t^j p(x_{t+1}^i|x_t^j)`
//! does not depend on the smoothed weights, so all `T-1` kernels are computed in parallel over
//! time (rayon; every kernel is computed by one thread in a fixed order, so the result is
//! bit-identical whatever the thread count); only the cheap `O(N²)` products run backwards in
//! sequence. Densities are evaluated with whitened particles (`L⁻¹x`, `Ξ = L Lᵀ`), so one pair
//! costs one squared distance and one `exp`; each kernel row is shifted by its largest exponent
//! so that nothing underflows to `0/0`. All buffers live in a [`SmootherWorkspace`] that is
//! reused across calls; nothing is allocated inside the loops.

use nalgebra::{SMatrix, SVector};
use rayon::prelude::*;

use crate::model::StateSpaceModel;
use crate::particle::{ParticleHistory, RecordedRun};

/// Why the smoother cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SmootherError {
    #[error("the smoother needs a positive definite process noise covariance (the transition density p(x_t+1|x_t) is degenerate otherwise)")]
    SingularProcessNoise,
    #[error("the particle history has {history} samples but the recorded run has {run}")]
    LengthMismatch { history: usize, run: usize },
    #[error("the particle history is empty")]
    Empty,
}

/// Sums of the smoothed pair weights `c_t^{il} = w_{t+1|T}^i K_t[i][l]` (the joint smoothing
/// distribution of `(x_t^l, x_{t+1}^i)`, 003: 2.77) per source particle `l` at `t`: everything
/// the EM's `I_2(θ, θ_m)` needs. They are taken over the whitened residuals
/// `ζ^{il} = L⁻¹(x_{t+1}^i - f_{θm}(x_t^l, u_t))` (`Ξ = L Lᵀ` of the smoothing model) about the
/// anchor `f_{θm}(x_t^l, u_t)`, so that for other parameters `θ`, with
/// `δ = L⁻¹(f_θ(x_t^l, u_t) - anchor)`, `Σ_i c |ζ - δ|² = tr S - 2 bᵀδ + s |δ|²` without the
/// cancellation of large raw second moments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairMoments<const N: usize> {
    /// `s = Σ_i c^{il}`.
    pub mass: f64,
    /// `b = Σ_i c^{il} ζ^{il}`.
    pub first: SVector<f64, N>,
    /// `S = Σ_i c^{il} ζ^{il} ζ^{ilᵀ}`.
    pub second: SMatrix<f64, N, N>,
    /// `f_{θm}(x_t^l, u_t)`.
    pub anchor: SVector<f64, N>,
}

impl<const N: usize> PairMoments<N> {
    fn zero() -> Self {
        Self {
            mass: 0.0,
            first: SVector::zeros(),
            second: SMatrix::zeros(),
            anchor: SVector::zeros(),
        }
    }
}

/// What the smoother returns: smoothed weights on the filter's particles, the smoothed estimates
/// and, if asked for, the pair moments for the EM.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothedRun<const N: usize> {
    pub particle_count: usize,
    /// `w̃_{t|T}` for every sample (sample-major, same layout as [`ParticleHistory::weights`]).
    pub weights: Vec<f64>,
    /// `x̂_{t|T} = Σ_l w̃_{t|T}^l x_t^l`.
    pub estimates: Vec<SVector<f64, N>>,
    /// Smoothed covariance `Σ_l w̃_{t|T}^l (x_t^l - x̂)(x_t^l - x̂)ᵀ`.
    pub covariances: Vec<SMatrix<f64, N, N>>,
    /// Pair moments for `t = 0..T-2`, source-particle-major within a sample (empty unless asked).
    pub pair_moments: Vec<PairMoments<N>>,
    /// Cholesky factor `L` of the process noise `Ξ = L Lᵀ` the smoother used (whitening of the
    /// pair moments).
    pub process_noise_factor: SMatrix<f64, N, N>,
}

impl<const N: usize> SmoothedRun<N> {
    /// The smoothed weights of sample `t`.
    pub fn weights_at(&self, t: usize) -> &[f64] {
        &self.weights[t * self.particle_count..(t + 1) * self.particle_count]
    }

    /// The pair moments of the transition `t -> t+1`, one per source particle.
    pub fn pair_moments_at(&self, t: usize) -> &[PairMoments<N>] {
        &self.pair_moments[t * self.particle_count..(t + 1) * self.particle_count]
    }
}

/// Reusable buffers of the smoother (grown on demand, never shrunk).
#[derive(Debug, Clone, Default)]
pub struct SmootherWorkspace<const N: usize> {
    kernels: Vec<f64>,
    whitened_particles: Vec<SVector<f64, N>>,
    whitened_means: Vec<SVector<f64, N>>,
}

impl<const N: usize> SmootherWorkspace<N> {
    pub fn new() -> Self {
        Self {
            kernels: Vec::new(),
            whitened_particles: Vec::new(),
            whitened_means: Vec::new(),
        }
    }
}

/// Runs the reweighting smoother over a filter history (see the module text).
/// `run` must be the recorded run the history was filtered on (its inputs drive `f`), and
/// `model` the model the filter used. Set `with_pair_moments` for the EM's E-step.
pub fn smooth<Model, const N: usize, const M: usize, const U: usize>(
    model: &Model,
    history: &ParticleHistory<N>,
    run: &RecordedRun<M, U>,
    with_pair_moments: bool,
    workspace: &mut SmootherWorkspace<N>,
) -> Result<SmoothedRun<N>, SmootherError>
where
    Model: StateSpaceModel<N, M, U> + Sync,
{
    let steps = history.len();
    if steps == 0 {
        return Err(SmootherError::Empty);
    }
    if run.len() < steps {
        return Err(SmootherError::LengthMismatch {
            history: steps,
            run: run.len(),
        });
    }
    let count = history.particle_count;
    let cholesky = model
        .process_noise()
        .cholesky()
        .ok_or(SmootherError::SingularProcessNoise)?;
    let factor = cholesky.l();
    let whiten = |vector: &SVector<f64, N>| -> SVector<f64, N> {
        factor
            .solve_lower_triangular(vector)
            .unwrap_or_else(|| SVector::repeat(f64::NAN))
    };

    // Whitened particles L⁻¹x_t^i and whitened transition means L⁻¹f(x_t^l, u_t).
    let total = steps * count;
    workspace.whitened_particles.resize(total, SVector::zeros());
    workspace.whitened_means.resize(total, SVector::zeros());
    workspace
        .whitened_particles
        .par_chunks_mut(count)
        .zip(workspace.whitened_means.par_chunks_mut(count))
        .enumerate()
        .for_each(|(t, (particles_out, means_out))| {
            let particles = history.particles_at(t);
            let input = &run.inputs[t];
            for ((particle, particle_out), mean_out) in
                particles.iter().zip(particles_out).zip(means_out)
            {
                *particle_out = whiten(particle);
                *mean_out = whiten(&model.transition(particle, input));
            }
        });

    // Backward kernels K_t[i][l] in parallel over t, a block of samples at a time (the block is
    // the whole run for the seed's N = 50; large N get smaller blocks so memory stays bounded),
    // then the backward recursion (003: 2.74, 2.75), sequential in t, and the pair moments.
    let kernel_size = count * count;
    let transitions = steps - 1;
    let block = (KERNEL_BUDGET / kernel_size).clamp(1, transitions.max(1));
    workspace.kernels.resize(block * kernel_size, 0.0);
    let whitened_particles = &workspace.whitened_particles;
    let whitened_means = &workspace.whitened_means;
    let kernels = &mut workspace.kernels;
    let mut weights = vec![0.0; total];
    weights[(steps - 1) * count..].copy_from_slice(history.weights_at(steps - 1));
    let mut pair_moments = Vec::new();
    if with_pair_moments {
        pair_moments = vec![PairMoments::zero(); transitions * count];
    }
    let mut block_end = transitions;
    while block_end > 0 {
        let block_start = block_end.saturating_sub(block);
        let block_kernels = &mut kernels[..(block_end - block_start) * kernel_size];
        block_kernels
            .par_chunks_mut(kernel_size)
            .enumerate()
            .for_each(|(offset, kernel)| {
                let t = block_start + offset;
                let filter_weights = history.weights_at(t);
                let targets = &whitened_particles[(t + 1) * count..(t + 2) * count];
                let means = &whitened_means[t * count..(t + 1) * count];
                for (target, row) in targets.iter().zip(kernel.chunks_exact_mut(count)) {
                    backward_kernel_row(target, means, filter_weights, row);
                }
            });
        for t in (block_start..block_end).rev() {
            let (head, tail) = weights.split_at_mut((t + 1) * count);
            let current = &mut head[t * count..];
            let next = &tail[..count];
            current.fill(0.0);
            let kernel = &block_kernels[(t - block_start) * kernel_size..][..kernel_size];
            for (&next_weight, row) in next.iter().zip(kernel.chunks_exact(count)) {
                if next_weight == 0.0 {
                    continue;
                }
                for (weight, &k) in current.iter_mut().zip(row) {
                    *weight += next_weight * k;
                }
            }
            let sum: f64 = current.iter().sum();
            if sum > 0.0 && sum.is_finite() {
                current.iter_mut().for_each(|weight| *weight /= sum);
            } else {
                current.copy_from_slice(history.weights_at(t));
            }
        }
        if with_pair_moments {
            let smoothed = &weights;
            let block_kernels = &*block_kernels;
            pair_moments[block_start * count..block_end * count]
                .par_chunks_mut(count)
                .enumerate()
                .for_each(|(offset, moments)| {
                    let t = block_start + offset;
                    let kernel = &block_kernels[offset * kernel_size..][..kernel_size];
                    let next_weights = &smoothed[(t + 1) * count..(t + 2) * count];
                    accumulate_pair_moments(
                        kernel,
                        next_weights,
                        &whitened_particles[(t + 1) * count..(t + 2) * count],
                        &whitened_means[t * count..(t + 1) * count],
                        moments,
                    );
                    for (moment, particle) in moments.iter_mut().zip(history.particles_at(t)) {
                        moment.anchor = model.transition(particle, &run.inputs[t]);
                    }
                });
        }
        block_end = block_start;
    }

    let mut estimates = vec![SVector::zeros(); steps];
    let mut covariances = vec![SMatrix::zeros(); steps];
    estimates
        .par_iter_mut()
        .zip(covariances.par_iter_mut())
        .enumerate()
        .for_each(|(t, (estimate, covariance))| {
            let (mean, spread) = crate::particle::weighted_moments(
                history.particles_at(t),
                &weights[t * count..(t + 1) * count],
            );
            *estimate = mean;
            *covariance = spread;
        });

    Ok(SmoothedRun {
        particle_count: count,
        weights,
        estimates,
        covariances,
        pair_moments,
        process_noise_factor: factor,
    })
}

/// Floats of kernel storage per block (32 MB).
const KERNEL_BUDGET: usize = 4 << 20;

/// Pair moments of one transition from its kernel and the smoothed weights at `t+1`.
fn accumulate_pair_moments<const N: usize>(
    kernel: &[f64],
    next_weights: &[f64],
    whitened_targets: &[SVector<f64, N>],
    whitened_means: &[SVector<f64, N>],
    moments: &mut [PairMoments<N>],
) {
    let count = next_weights.len();
    for moment in moments.iter_mut() {
        *moment = PairMoments::zero();
    }
    for ((row, &next_weight), target) in kernel
        .chunks_exact(count)
        .zip(next_weights)
        .zip(whitened_targets)
    {
        if next_weight == 0.0 {
            continue;
        }
        for ((moment, &k), mean) in moments.iter_mut().zip(row).zip(whitened_means) {
            let pair = next_weight * k;
            if pair > 0.0 {
                let residual = target - mean;
                moment.mass += pair;
                moment.first += residual * pair;
                moment.second.ger(pair, &residual, &residual, 1.0);
            }
        }
    }
}

/// One row of the backward kernel: `K[l] ∝ w̃^l exp(-½|z - m_l|²)`, normalised over `l`, with
/// the largest exponent shifted to zero.
fn backward_kernel_row<const N: usize>(
    target: &SVector<f64, N>,
    means: &[SVector<f64, N>],
    filter_weights: &[f64],
    row: &mut [f64],
) {
    let mut largest = f64::NEG_INFINITY;
    for ((value, mean), &weight) in row.iter_mut().zip(means).zip(filter_weights) {
        *value = if weight > 0.0 {
            weight.ln() - 0.5 * (target - mean).norm_squared()
        } else {
            f64::NEG_INFINITY
        };
        if *value > largest {
            largest = *value;
        }
    }
    if !largest.is_finite() {
        // Non-finite particle or no source with weight: fall back to the filter weights.
        row.copy_from_slice(filter_weights);
        return;
    }
    let mut sum = 0.0;
    for value in row.iter_mut() {
        *value = if value.is_nan() {
            0.0
        } else {
            (*value - largest).exp()
        };
        sum += *value;
    }
    row.iter_mut().for_each(|value| *value /= sum);
}
