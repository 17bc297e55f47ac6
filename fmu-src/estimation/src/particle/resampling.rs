//! Resampling (003: A.4): normalised weights from log-weights, the effective sample size, the
//! ancestor draw of the three schemes, and the filter's resampling step.

use rand::Rng;

use super::{ParticleFilter, ResamplingPolicy, ResamplingScheme};
use crate::model::StateSpaceModel;

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

/// Normalises log-weights in place (max-shift, so the largest weight is exp(0) before
/// normalising) and writes the linear normalised weights. Returns `None` when no weight is
/// positive and finite (every particle impossible or non-finite).
pub(super) fn normalise_log_weights(log_weights: &mut [f64], weights: &mut [f64]) -> Option<()> {
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

impl<Model, const N: usize, const M: usize, const U: usize> ParticleFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
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
}
