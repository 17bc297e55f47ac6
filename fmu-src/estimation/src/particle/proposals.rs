//! Where the next sample's particles are drawn from: the deferred noise draw of the linearised
//! optimal proposal (003: 2.63-2.66) and the marginalised proposal's conditioned draws, with
//! the pending prediction they share.

use nalgebra::{SMatrix, SVector};

use super::gaussian::{log_likelihood, masked_covariance, standard_normal_vector};
use super::marginalised::{condition_on_measurement, MarginalisedStates};
use super::resampling::normalise_log_weights;
use super::{ParticleFilter, Proposal};
use crate::estimator::MeasurementMask;
use crate::kalman::MeasurementNoise;
use crate::model::StateSpaceModel;

impl<Model, const N: usize, const M: usize, const U: usize> ParticleFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    /// [`Self::pending_linear_spread`] for the current weights and stored Jacobian columns.
    pub(super) fn refresh_pending_linear_spread(&mut self) {
        if self.marginal.is_active() {
            self.pending_linear_spread = self.marginal.weighted_linear_spread(&self.weights);
        }
    }

    /// The covariance the pending draw adds to the spread of the predicted means: `Q`, and with
    /// the marginalised proposal the linear states' uncertainty carried through `F`.
    pub(super) fn pending_spread(&self) -> SMatrix<f64, N, N> {
        if self.marginal.is_active() {
            self.pending_linear_spread + self.pending_process_noise()
        } else {
            self.process_noise
        }
    }

    /// `Q` of the pending prediction, with what the host added ([`Self::inflate_pending`]).
    pub(super) fn pending_process_noise(&self) -> SMatrix<f64, N, N> {
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
    pub(super) fn draw_pending_noise_from_prior(&mut self) {
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
    pub(super) fn draw_from_optimal_proposal(
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
    pub(super) fn draw_marginalised(
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
    pub(super) fn pending_prediction(
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
    pub(super) fn draw_particle(
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
}

/// Storage for the marginalised proposal's linear states, where `proposal` asks for it and the
/// model has such states; none otherwise.
pub(super) fn marginal_storage<Model, const N: usize, const M: usize, const U: usize>(
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
