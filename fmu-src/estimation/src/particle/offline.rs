//! The filter over a recorded run, offline: the run's inputs and measurements, and every
//! sample's weighted particle set as the smoother and the identification need them.

use nalgebra::SVector;

use super::ParticleFilter;
use crate::model::StateSpaceModel;

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
