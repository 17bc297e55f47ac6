//! The marginalised particle filter's part (Schön, Gustafsson and Nordlund, "Marginalized
//! particle filters for mixed linear/nonlinear state-space models", IEEE Trans. Signal
//! Processing 53(7), 2005): the model's conditionally linear states
//! ([`StateSpaceModel::conditionally_linear_states`]) are kept per particle as a Gaussian, their
//! mean in the particle's own entries and their covariance here; only the other states are
//! sampled.
//!
//! One step of one particle, with the transition and the measurement function linearised at the
//! particle (the locally linearised optimal proposal of Doucet, Godsill and Andrieu 2000, here
//! on the joint Gaussian of all states):
//!
//! 1. prediction `x̄ = f(x, u)`, `P = F E Fᵀ + Q`, where `E` is the particle's covariance of the
//!    linear states embedded in an N×N zero matrix (the sampled states are exact for the
//!    particle), so `F E Fᵀ` carries the linear states' uncertainty into every state they drive;
//! 2. conditioning on `y`: `S = H P Hᵀ + R`, `K = P Hᵀ S⁻¹`, `μ = x̄ + K (y − h(x̄))`,
//!    `Σ = P − K H P`; the particle's weight is multiplied by the predictive likelihood
//!    `N(y; h(x̄), S)` (the weight of the fully adapted filter);
//! 3. the sampled states are drawn from their marginal of `N(μ, Σ)`, and the linear states take
//!    their conditional mean and covariance given that draw: the Kalman filter's measurement
//!    update with the sampled states' transition as the measurement (Schön et al., eq. 25a-d),
//!    here as one Gaussian conditioning.
//!
//! For a linear-Gaussian model with every state declared linear, every particle is the exact
//! Kalman filter. Storage for the covariances is allocated once, when the filter is built.

use nalgebra::{SMatrix, SVector};
use rand::Rng;

use super::{covariance_square_root, standard_normal_vector};
use crate::estimator::MeasurementMask;
use crate::kalman::{linearised_update, MeasurementNoise};
use crate::model::StateSpaceModel;

/// The covariances of the conditionally linear states of every particle, and what the pending
/// draw of the linearised optimal proposal needs of the last prediction.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MarginalisedStates<const N: usize> {
    /// The conditionally linear states; empty when nothing is marginalised.
    indices: &'static [usize],
    /// Per particle the L×L covariance of the linear states (column-major), L = `indices.len()`.
    covariances: Vec<f64>,
    /// Resampling scratch of the same size.
    resampled: Vec<f64>,
    /// Per particle the columns of `F` at the linear states (N×L, column-major) of the last
    /// prediction; read while the draw waits for the measurement.
    columns: Vec<f64>,
}

impl<const N: usize> MarginalisedStates<N> {
    /// Nothing marginalised.
    pub(crate) fn none() -> Self {
        Self {
            indices: &[],
            covariances: Vec::new(),
            resampled: Vec::new(),
            columns: Vec::new(),
        }
    }

    /// Storage for `count` particles with zero covariance (every particle exact).
    pub(crate) fn new(indices: &'static [usize], count: usize) -> Self {
        let linear = indices.len();
        Self {
            indices,
            covariances: vec![0.0; count * linear * linear],
            resampled: vec![0.0; count * linear * linear],
            columns: vec![0.0; count * N * linear],
        }
    }

    /// Whether any state is marginalised.
    pub(crate) fn is_active(&self) -> bool {
        !self.indices.is_empty()
    }

    /// How many entries the covariances and the pending columns take per particle.
    pub(crate) fn sizes_per_particle(&self) -> (usize, usize) {
        let linear = self.indices.len();
        (linear * linear, N * linear)
    }

    pub(crate) fn covariances(&self) -> &[f64] {
        &self.covariances
    }

    pub(crate) fn columns(&self) -> &[f64] {
        &self.columns
    }

    /// Overwrites the stored covariances and columns (lengths checked by the caller).
    pub(crate) fn restore(&mut self, covariances: &[f64], columns: &[f64]) {
        self.covariances.copy_from_slice(covariances);
        self.columns.copy_from_slice(columns);
    }

    /// The linear states' covariance of particle `i`, embedded in an N×N zero matrix.
    pub(crate) fn embedded(&self, i: usize) -> SMatrix<f64, N, N> {
        let linear = self.indices.len();
        let block = &self.covariances[i * linear * linear..(i + 1) * linear * linear];
        let mut embedded = SMatrix::<f64, N, N>::zeros();
        for (column, &state_column) in self.indices.iter().enumerate() {
            for (row, &state_row) in self.indices.iter().enumerate() {
                embedded[(state_row, state_column)] = block[column * linear + row];
            }
        }
        embedded
    }

    /// Stores the linear states' block of `covariance` as particle `i`'s covariance.
    pub(crate) fn set(&mut self, i: usize, covariance: &SMatrix<f64, N, N>) {
        let linear = self.indices.len();
        let block = &mut self.covariances[i * linear * linear..(i + 1) * linear * linear];
        for (column, &state_column) in self.indices.iter().enumerate() {
            for (row, &state_row) in self.indices.iter().enumerate() {
                block[column * linear + row] = covariance[(state_row, state_column)];
            }
        }
    }

    /// Keeps the columns of the transition Jacobian at the linear states of particle `i`.
    pub(crate) fn store_columns(&mut self, i: usize, jacobian: &SMatrix<f64, N, N>) {
        let linear = self.indices.len();
        let columns = &mut self.columns[i * N * linear..(i + 1) * N * linear];
        for (column, &state) in self.indices.iter().enumerate() {
            columns[column * N..(column + 1) * N]
                .copy_from_slice(jacobian.column(state).as_slice());
        }
    }

    /// Particle `i`'s predicted covariance `F E Fᵀ + Q` (step 1), from the stored columns of `F`.
    pub(crate) fn predicted_covariance(
        &self,
        i: usize,
        process_noise: &SMatrix<f64, N, N>,
    ) -> SMatrix<f64, N, N> {
        let linear = self.indices.len();
        let columns = &self.columns[i * N * linear..(i + 1) * N * linear];
        let block = &self.covariances[i * linear * linear..(i + 1) * linear * linear];
        // F E Fᵀ = Σ_ab E_ab f_a f_bᵀ over the linear states' columns f_a of F: L² rank-one
        // updates instead of two N×N products with a mostly zero E.
        let mut predicted = *process_noise;
        for a in 0..linear {
            let column_a = SVector::<f64, N>::from_column_slice(&columns[a * N..(a + 1) * N]);
            for b in 0..linear {
                let column_b = SVector::<f64, N>::from_column_slice(&columns[b * N..(b + 1) * N]);
                predicted.ger(block[b * linear + a], &column_a, &column_b, 1.0);
            }
        }
        (predicted + predicted.transpose()) * 0.5
    }

    /// `Σ wᵢ Eᵢ`: what the linear states' own uncertainty adds to the particle spread.
    pub(crate) fn weighted_covariance(&self, weights: &[f64]) -> SMatrix<f64, N, N> {
        let mut total = SMatrix::<f64, N, N>::zeros();
        for (i, &weight) in weights.iter().enumerate() {
            if weight > 0.0 {
                total += self.embedded(i) * weight;
            }
        }
        total
    }

    /// `Σ wᵢ Fᵢ Eᵢ Fᵢᵀ` of the pending prediction: what the linear states' uncertainty adds to
    /// the process noise, on average over the particles.
    pub(crate) fn weighted_linear_spread(&self, weights: &[f64]) -> SMatrix<f64, N, N> {
        let zero = SMatrix::<f64, N, N>::zeros();
        let mut total = zero;
        for (i, &weight) in weights.iter().enumerate() {
            if weight > 0.0 {
                total += self.predicted_covariance(i, &zero) * weight;
            }
        }
        total
    }

    /// Every particle takes its ancestor's covariance.
    pub(crate) fn resample(&mut self, ancestors: &[usize]) {
        let size = self.indices.len() * self.indices.len();
        for (i, &ancestor) in ancestors.iter().enumerate() {
            self.resampled[i * size..(i + 1) * size]
                .copy_from_slice(&self.covariances[ancestor * size..(ancestor + 1) * size]);
        }
        std::mem::swap(&mut self.covariances, &mut self.resampled);
    }

    /// Step 3: a draw of the sampled states from `N(mean, covariance)`, with the linear states
    /// at their conditional mean given the draw; returns the particle and the linear states'
    /// conditional covariance (embedded). `None` when `covariance` is not positive
    /// semi-definite. Takes N standard normal draws from `rng`.
    pub(crate) fn conditional_draw<R: Rng + ?Sized>(
        &self,
        mean: &SVector<f64, N>,
        covariance: &SMatrix<f64, N, N>,
        rng: &mut R,
    ) -> Option<(SVector<f64, N>, SMatrix<f64, N, N>)> {
        // The sampled states first, then the linear ones: in the lower Cholesky factor
        // `[L₁₁ 0; L₂₁ L₂₂]` of the reordered covariance, a draw `x₁ = μ₁ + L₁₁ z₁` leaves
        // `x₂ | x₁ ~ N(μ₂ + L₂₁ z₁, L₂₂ L₂₂ᵀ)`.
        let sampled = N - self.indices.len();
        let mut order = [0_usize; N];
        let sampled_states = (0..N).filter(|state| !self.indices.contains(state));
        for (slot, state) in order
            .iter_mut()
            .zip(sampled_states.chain(self.indices.iter().copied()))
        {
            *slot = state;
        }
        let reordered = SMatrix::<f64, N, N>::from_fn(|a, b| covariance[(order[a], order[b])]);
        let root = covariance_square_root(&reordered, "marginalised proposal").ok()?;
        let mut standard = standard_normal_vector::<N, R>(rng);
        for entry in standard.iter_mut().skip(sampled) {
            *entry = 0.0;
        }
        let offset = root * standard;
        let mut particle = *mean;
        for (a, &state) in order.iter().enumerate() {
            particle[state] += offset[a];
        }
        let mut conditional = SMatrix::<f64, N, N>::zeros();
        for a in sampled..N {
            for b in sampled..N {
                let value: f64 = (sampled..N).map(|k| root[(a, k)] * root[(b, k)]).sum();
                conditional[(order[a], order[b])] = value;
            }
        }
        Some((particle, conditional))
    }
}

/// Step 2: the Gaussian `N(mean, covariance)` conditioned on the used rows of `measurement`, the
/// measurement function linearised at `mean`: the Kalman update the LKF and EKF make
/// ([`linearised_update`]: gain, Joseph form, covariance kept positive definite, as
/// the draw needs). Returns the conditioned mean and covariance and `ln N(y; h(mean), S) =
/// -½ (NIS + ln det S)` up to the constant shared by all particles; `None` where the update
/// failed (`S` not positive definite, a non-finite result).
pub(crate) fn condition_on_measurement<Model, const N: usize, const M: usize, const U: usize>(
    model: &Model,
    prediction: (&SVector<f64, N>, &SMatrix<f64, N, N>),
    measurement: &SVector<f64, M>,
    input: &SVector<f64, U>,
    used: &MeasurementMask<M>,
    measurement_noise: &MeasurementNoise<M>,
) -> Option<(SVector<f64, N>, SMatrix<f64, N, N>, f64)>
where
    Model: StateSpaceModel<N, M, U>,
{
    let (mut mean, mut covariance) = (*prediction.0, *prediction.1);
    let (predicted, jacobian) = model.measurement_and_jacobian(&mean, input);
    let (report, _, log_det) = linearised_update(
        &mut mean,
        &mut covariance,
        &predicted,
        &jacobian,
        measurement_noise,
        measurement,
        used,
    )
    .ok()?;
    Some((mean, covariance, -0.5 * (report.nis + log_det)))
}
