//! Linear Kalman filter on the linearisation about a fixed operating point (000: 4.64-4.75),
//! with the Joseph-form covariance update of seed 004 instead of the seed-000 short form
//! `(I - K H) P⁻` (000: 4.75): both are equal for the optimal gain, the Joseph form stays
//! symmetric positive semi-definite under rounding (SPEC §6 asks for it).

use nalgebra::{SMatrix, SVector};

use super::{
    conclude_update, finish_prediction, linearised_update, validated_noise, InitialEstimate,
    LinearisedModel, MeasurementNoise, SettingsError,
};
use crate::linalg::congruence;
use crate::{Estimator, FilterIssue, MeasurementMask, StateSpaceModel, UpdateReport};

/// The LKF of seed 000 on any [`StateSpaceModel`], linearised once about a fixed operating point.
#[derive(Debug, Clone)]
pub struct LinearKalmanFilter<Model, const N: usize, const M: usize, const U: usize> {
    model: Model,
    linear: LinearisedModel<N, M, U>,
    process_noise: SMatrix<f64, N, N>,
    measurement_noise: MeasurementNoise<M>,
    state: SVector<f64, N>,
    covariance: SMatrix<f64, N, N>,
    last_report: UpdateReport<M>,
}

impl<Model, const N: usize, const M: usize, const U: usize> LinearKalmanFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    /// Linearises `model` about `(operating_state, operating_input)` (000: 5.58-5.62 for model A)
    /// and starts from `initial`.
    pub fn new(
        model: Model,
        operating_state: &SVector<f64, N>,
        operating_input: &SVector<f64, U>,
        initial: &InitialEstimate<N>,
    ) -> Result<Self, SettingsError> {
        initial.validate()?;
        let (process_noise, measurement_noise) = validated_noise(&model)?;
        let linear = LinearisedModel::about(&model, operating_state, operating_input)?;
        Ok(Self {
            model,
            linear,
            process_noise,
            measurement_noise: MeasurementNoise::new(measurement_noise),
            state: initial.state,
            covariance: initial.symmetric_covariance(),
            last_report: UpdateReport::skipped(),
        })
    }

    /// The linear model the filter runs on.
    pub fn linearisation(&self) -> &LinearisedModel<N, M, U> {
        &self.linear
    }

    /// The model the filter was linearised from.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The report of the last measurement update.
    pub fn last_report(&self) -> &UpdateReport<M> {
        &self.last_report
    }
}

impl<Model, const N: usize, const M: usize, const U: usize> Estimator<N, M, U>
    for LinearKalmanFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    fn predict(&mut self, input: &SVector<f64, U>) -> Result<(), FilterIssue> {
        let previous_state = self.state;
        let previous_covariance = self.covariance;
        // x̂⁻ = F x̂⁺ + G u (000: 4.73), P⁻ = F P⁺ Fᵀ + Q (000: 4.71).
        self.state = self.linear.predict(&self.state, input);
        self.covariance =
            congruence(&self.linear.transition, &self.covariance) + self.process_noise;
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
        // K = P⁻Hᵀ(H P⁻ Hᵀ + R)⁻¹ (000: 4.72), x̂⁺ = x̂⁻ + K (y - ŷ) (000: 4.74), Joseph form (004).
        let predicted = self.linear.measure(&self.state, input);
        let outcome = linearised_update(
            &mut self.state,
            &mut self.covariance,
            &predicted,
            &self.linear.output_matrix,
            &self.measurement_noise,
            measurement,
            mask,
        );
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
    crate::running::RunningEstimator<N, M, U> for LinearKalmanFilter<Model, N, M, U>
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
}
