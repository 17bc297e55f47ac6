//! Extended Kalman filter (000: 4.99-4.113) with the model's analytic Jacobians.
//!
//! The seed's noise enters additively (`L = I`, `M = I` in 000: 4.106, 4.110, since model A's
//! noise is additive, SPEC §7). The covariance update is the Joseph form (004) rather than the
//! short form `(I - K H) P⁻` of 000: 4.113: equal for the optimal gain, but it keeps `P`
//! positive semi-definite under rounding. filterpy's `ExtendedKalmanFilter.update` uses the same
//! Joseph form, which the filterpy comparison test relies on.

use nalgebra::{SMatrix, SVector};

use super::{
    conclude_update, finish_prediction, linearised_update, validated_noise, InitialEstimate,
    MeasurementNoise, SettingsError,
};
use crate::linalg::congruence;
use crate::{Estimator, FilterIssue, MeasurementMask, StateSpaceModel, UpdateReport};

/// The EKF of seed 000 on any [`StateSpaceModel`].
#[derive(Debug, Clone)]
pub struct ExtendedKalmanFilter<Model, const N: usize, const M: usize, const U: usize> {
    model: Model,
    process_noise: SMatrix<f64, N, N>,
    measurement_noise: MeasurementNoise<M>,
    state: SVector<f64, N>,
    covariance: SMatrix<f64, N, N>,
    last_report: UpdateReport<M>,
}

impl<Model, const N: usize, const M: usize, const U: usize> ExtendedKalmanFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    /// An EKF on `model` starting from `initial`.
    pub fn new(model: Model, initial: &InitialEstimate<N>) -> Result<Self, SettingsError> {
        initial.validate()?;
        let (process_noise, measurement_noise) = validated_noise(&model)?;
        Ok(Self {
            model,
            process_noise,
            measurement_noise: MeasurementNoise::new(measurement_noise),
            state: initial.state,
            covariance: initial.symmetric_covariance(),
            last_report: UpdateReport::skipped(),
        })
    }

    /// The model the filter runs on.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The report of the last measurement update.
    pub fn last_report(&self) -> &UpdateReport<M> {
        &self.last_report
    }
}

impl<Model, const N: usize, const M: usize, const U: usize> Estimator<N, M, U>
    for ExtendedKalmanFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    fn predict(&mut self, input: &SVector<f64, U>) -> Result<(), FilterIssue> {
        let previous_state = self.state;
        let previous_covariance = self.covariance;
        // F = ∂f/∂x at x̂⁺ (000: 4.105), P⁻ = F P⁺ Fᵀ + Q (000: 4.107), x̂⁻ = f(x̂⁺, u) (000: 4.108).
        let (next_state, jacobian) = self.model.transition_and_jacobian(&self.state, input);
        self.covariance = congruence(&jacobian, &self.covariance) + self.process_noise;
        self.state = next_state;
        finish_prediction(
            &mut self.state,
            &mut self.covariance,
            previous_state,
            previous_covariance,
            &self.process_noise,
        )
    }

    fn update(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &MeasurementMask<M>,
    ) -> Result<UpdateReport<M>, FilterIssue> {
        // H = ∂h/∂x at x̂⁻ (000: 4.109), K (000: 4.111), x̂⁺ = x̂⁻ + K [y - h(x̂⁻)] (000: 4.112).
        let (predicted, output_matrix) = self.model.measurement_and_jacobian(&self.state, input);
        let outcome = linearised_update(
            &mut self.state,
            &mut self.covariance,
            &predicted,
            &output_matrix,
            &self.measurement_noise,
            measurement,
            mask,
        );
        let outcome = outcome.map(|(report, repaired, _)| (report, repaired));
        conclude_update(&mut self.last_report, outcome)
    }

    fn state(&self) -> &SVector<f64, N> {
        &self.state
    }

    fn covariance(&self) -> &SMatrix<f64, N, N> {
        &self.covariance
    }
}

/// In the registry: fully described by `(x̂, P)` and its settings (the default snapshot).
impl<Model, const N: usize, const M: usize, const U: usize>
    crate::running::RunningEstimator<N, M, U> for ExtendedKalmanFilter<Model, N, M, U>
where
    Model: crate::running::RegistryModel<N, M, U>,
{
    fn last_report(&self) -> UpdateReport<M> {
        self.last_report
    }

    /// `P` is this filter's own Gaussian: adding to it is a larger `Q` in the last prediction.
    fn inflate_covariance(&mut self, extra: &nalgebra::SMatrix<f64, N, N>) -> bool {
        self.covariance += extra;
        true
    }

    // `R + extra` for one update: the EKF's gain and Joseph form (004) with that `R`.
    super::update_with_r_plus_extra!();

    super::condition_on_own_gaussian!();
}
