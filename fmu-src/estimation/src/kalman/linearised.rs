//! The linearisation of a [`StateSpaceModel`] about one fixed operating point, as used by the LKF
//! (000: 4.64-4.75, operating point 000: 5.58-5.62) and the Luenberger observer (002: §4).

use nalgebra::{SMatrix, SVector};

use super::SettingsError;
use crate::linalg::all_finite;
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

    /// The linear measurement (000: 4.65, plus feed-through).
    pub fn measure(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, M> {
        self.output
            + self.output_matrix * (state - self.state)
            + self.feedthrough * (input - self.input)
    }
}
