//! The measurement noise learned from the innovations and from each sensor's own samples
//! (`learn_measurement_noise`, `estimation::measurement_noise`): each row's variance observed
//! before the gate, at the predicted estimate, and added to the tuned `R` where it exceeds it.

use estimation::measurement_noise::NoiseMatching;
use estimation::registry::EstimatorChoice;

use super::EstimationModel;
use super::Runner;
use crate::estimation_model::Sample;
use crate::model_description::Variables;
use crate::sensors::Sensors;

/// The time constant `τ` of the learned noise's moving average, s: long enough that the clipped
/// squares of some hundred samples at 10 ms average out (the estimate's relative std is about
/// `sqrt(T / τ)`, 7 %), short enough to follow a road whose roughness changes within a lap.
const NOISE_LEARNING_TIME: f64 = 2.0;

/// The memory `τ_memory` of a sensor's own noise, s (`estimation::measurement_noise`, what the
/// sensor showed lately): longer than a corner and the straight before it, so a corner taken
/// slower, and shaking the accelerometer less, keeps the straight's noise. Measured on the MBDS
/// recording's laps 2-6 (grip EKF, sideslip RMSE): without the memory 0.534°; with 10 / 30 / 60 /
/// 120 s 0.494 / 0.487 / 0.489 / 0.490°. The campaigns' sensors, whose noise is stationary, are
/// unchanged.
const NOISE_MEMORY_TIME: f64 = 30.0;

/// The learner of `model`'s rows, starting at its tuned variances, or `None` when
/// `learn_measurement_noise` is false.
pub(super) fn learner<const N: usize, const M: usize, const U: usize>(
    v: &Variables,
    model: &impl EstimationModel<N, M, U>,
    sample_time: f64,
    choice: EstimatorChoice,
) -> Option<NoiseMatching<M>> {
    let tuned = model.measurement_noise();
    // The Luenberger observer's gain is placed by its poles, not computed from `R`: a learned
    // `R` would only widen its gate (measured: started at 3 m/s its speed went 50 % off).
    let learns = v.learn_measurement_noise && choice != EstimatorChoice::Luenberger;
    learns.then(|| {
        NoiseMatching::new(
            std::array::from_fn(|row| tuned[(row, row)]),
            sample_time / NOISE_LEARNING_TIME,
        )
        .remembering(sample_time / NOISE_MEMORY_TIME)
    })
}

impl<Model, const N: usize, const M: usize, const U: usize> Runner<Model, N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    /// Each row's noise standard deviation as the filter uses it: the learned one where the
    /// learner runs, else the tuned one.
    pub(crate) fn measurement_std(&self) -> [f64; M] {
        std::array::from_fn(|row| self.measurement_variance(row).sqrt())
    }

    /// Row `row`'s noise variance as the filter uses it (see [`Self::measurement_std`]).
    pub(crate) fn measurement_variance(&self, row: usize) -> f64 {
        match &self.noise {
            Some(learner) => learner.variance(row),
            None => self.model.measurement_noise()[(row, row)],
        }
    }

    /// Gives the learner this sample's innovations of the finite, offered, plausible rows at
    /// the predicted estimate, with their predicted variance `H P Hᵀ` plus the model's own
    /// extra noise of the row (what the model says it cannot predict is not the sensor's).
    pub(super) fn learn_noise(&mut self, sensors: &Sensors, sample: &Sample<M, U>) {
        if self.noise.is_none() {
            return;
        }
        let state = *self.filter.state();
        let covariance = *self.filter.covariance();
        let std = self.measurement_std();
        let plausible = self.model.plausible(sensors, &state, self.min_speed, &std);
        let (predicted, jacobian) = self.model.measurement_and_jacobian(&state, &sample.input);
        let model_extra = self.model_measurement_noise(&sample.input);
        let Some(learner) = self.noise.as_mut() else {
            return;
        };
        for row in 0..M {
            let value = sample.measurement[row];
            let measured = value.is_finite() && sample.offered[row] && plausible[row];
            let innovation = measured.then(|| {
                let h = jacobian.row(row);
                let extra = model_extra.map_or(0.0, |extra| extra[(row, row)]);
                let predicted_variance = (h * covariance * h.transpose())[(0, 0)] + extra;
                (value - predicted[row], predicted_variance)
            });
            learner.observe(row, innovation);
            learner.observe_signal(row, measured.then_some(value));
        }
    }
}
