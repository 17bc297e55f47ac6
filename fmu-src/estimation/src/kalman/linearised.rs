//! The linearisation of a [`StateSpaceModel`] about one operating point, as used by the LKF
//! (000: 4.64-4.75, operating point 000: 5.58-5.62) and the Luenberger observer (002: §4), and
//! the measure of its error by which both are gain-scheduled (re-linearised about their current
//! estimate when it has moved too far, Rugh & Shamma, "Research on gain scheduling",
//! Automatica 36, 2000).

use nalgebra::{SMatrix, SVector};

use super::SettingsError;
use crate::linalg::all_finite;
use crate::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};
use crate::StateSpaceModel;

/// `x(k+1) ≈ f(x₀, u₀) + A (x - x₀) + B (u - u₀)`, `y ≈ h(x₀, u₀) + C (x - x₀) + D (u - u₀)`.
///
/// The seed writes the linear model as `x(k) = F x(k-1) + G u(k-1)` (000: 4.64); keeping the
/// offsets `f(x₀, u₀)` and `h(x₀, u₀)` makes that exact at the operating point even when the
/// operating point is not an equilibrium, and reduces to the seed's form when it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearisedModel<const N: usize, const M: usize, const U: usize> {
    /// Operating-point state `x₀`.
    pub state: SVector<f64, N>,
    /// Operating-point input `u₀`.
    pub input: SVector<f64, U>,
    /// `f(x₀, u₀)`.
    pub next_state: SVector<f64, N>,
    /// `h(x₀, u₀)`.
    pub output: SVector<f64, M>,
    /// `A = ∂f/∂x (x₀, u₀)` (the seed's `F`).
    pub transition: SMatrix<f64, N, N>,
    /// `B = ∂f/∂u (x₀, u₀)` (the seed's `G`).
    pub input_gain: SMatrix<f64, N, U>,
    /// `C = ∂h/∂x (x₀, u₀)` (the seed's `H`).
    pub output_matrix: SMatrix<f64, M, N>,
    /// `D = ∂h/∂u (x₀, u₀)`: direct feed-through (000: 5.63, `ay` depends on the steering angle).
    pub feedthrough: SMatrix<f64, M, U>,
}

impl<const N: usize, const M: usize, const U: usize> LinearisedModel<N, M, U> {
    /// Linearises `model` about `(state, input)`.
    pub fn about<Model: StateSpaceModel<N, M, U>>(
        model: &Model,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> Result<Self, SettingsError> {
        if !all_finite(state) || !all_finite(input) {
            return Err(SettingsError(format!(
                "the operating point must be finite, got state {} and input {}",
                state.transpose(),
                input.transpose()
            )));
        }
        let linear = Self {
            state: *state,
            input: *input,
            next_state: model.transition(state, input),
            output: model.measurement(state, input),
            transition: model.transition_jacobian(state, input),
            input_gain: model.transition_input_jacobian(state, input),
            output_matrix: model.measurement_jacobian(state, input),
            feedthrough: model.measurement_input_jacobian(state, input),
        };
        let finite = all_finite(&linear.next_state)
            && all_finite(&linear.output)
            && all_finite(&linear.transition)
            && all_finite(&linear.input_gain)
            && all_finite(&linear.output_matrix)
            && all_finite(&linear.feedthrough);
        if !finite {
            return Err(SettingsError(format!(
                "the model is not finite at the operating point state {} input {}",
                state.transpose(),
                input.transpose()
            )));
        }
        Ok(linear)
    }

    /// The linear state transition (000: 4.73).
    pub fn predict(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, N> {
        self.next_state
            + self.transition * (state - self.state)
            + self.input_gain * (input - self.input)
    }

    /// The largest error of this linearisation at `(state, input)` against the model it was
    /// taken from: each state of the one-step prediction in units of its process-noise standard
    /// deviation `sqrt(Q_ii)`, each output in units of `sqrt(R_jj)`. Below 1 the linear model
    /// errs by less than the model error the filter already allows for in `Q` and `R`; the
    /// gain-scheduled linear estimators re-linearise when it exceeds their threshold (see
    /// [`crate::running::RunningEstimator::reschedule`]). Costs one evaluation of `f` and of `h`;
    /// 0 where the model is not finite there (re-linearising would not be possible either).
    pub fn normalised_error<Model: StateSpaceModel<N, M, U>>(
        &self,
        model: &Model,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
        process_noise: &SMatrix<f64, N, N>,
        measurement_noise: &SMatrix<f64, M, M>,
    ) -> f64 {
        let transition = model.transition(state, input) - self.predict(state, input);
        let output = model.measurement(state, input) - self.measure(state, input);
        let scaled = |error: f64, variance: f64| (error * error / variance).sqrt();
        let states = (0..N).map(|i| scaled(transition[i], process_noise[(i, i)]));
        let outputs = (0..M).map(|j| scaled(output[j], measurement_noise[(j, j)]));
        let largest = states.chain(outputs).fold(0.0, f64::max);
        if largest.is_finite() {
            largest
        } else {
            0.0
        }
    }

    /// The linear measurement (000: 4.65, plus feed-through).
    pub fn measure(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, M> {
        self.output
            + self.output_matrix * (state - self.state)
            + self.feedthrough * (input - self.input)
    }
}

/// Stores the operating point a linear estimator runs at (gain scheduling moves it), after its
/// Gaussian.
pub(crate) fn save_operating_point<const N: usize, const M: usize, const U: usize>(
    sink: &mut dyn SnapshotSink,
    linear: &LinearisedModel<N, M, U>,
) {
    sink.f64s(linear.state.as_slice());
    sink.f64s(linear.input.as_slice());
}

/// Reads what [`save_operating_point`] wrote: `current` when the stored operating point is the
/// one it was built at, else the linearisation about the stored one (the same numbers as when it
/// was scheduled there, so the estimator continues bit-identically).
pub(crate) fn restored_linearisation<Model, const N: usize, const M: usize, const U: usize>(
    model: &Model,
    current: &LinearisedModel<N, M, U>,
    source: &mut dyn SnapshotSource,
) -> Result<LinearisedModel<N, M, U>, SnapshotError>
where
    Model: StateSpaceModel<N, M, U>,
{
    let mut state = SVector::<f64, N>::zeros();
    source.f64s_into(state.as_mut_slice(), "operating state")?;
    let mut input = SVector::<f64, U>::zeros();
    source.f64s_into(input.as_mut_slice(), "operating input")?;
    if state == current.state && input == current.input {
        return Ok(*current);
    }
    LinearisedModel::about(model, &state, &input).map_err(|error| SnapshotError(error.0))
}
