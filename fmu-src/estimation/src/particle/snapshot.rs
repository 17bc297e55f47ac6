//! The particle filter's running state as a value ([`ParticleFilterSnapshot`]) and in the
//! registry's byte stream (an FMU state), so that a restored filter continues bit-identically.

use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{ParticleFilter, ParticleFilterError};
use crate::estimator::UpdateReport;
use crate::model::StateSpaceModel;
use crate::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};

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

impl<Model, const N: usize, const M: usize, const U: usize> ParticleFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
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
}

/// Layout of a particle filter's stored state; a state written with another layout is refused
/// by name instead of being misread.
/// Layout 2 holds the marginalised proposal's linear-state covariances.
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
