//! The one model interface every estimator runs on.
//!
//! A model is discrete in time: its sample time is part of the model (it is built with one), so
//! `transition` is the seed's discretised step `x(k+1) = f(x(k), u(k))` (000: 6.1-6.5 for model A),
//! and `measurement` is `y(k) = h(x(k), u(k))` (000: 5.63). Inputs are a fixed-size vector so that a
//! linearisation can also be taken with respect to them (the LKF needs `B`, 000: 4.64-4.75).
//!
//! Noise is additive: `x(k+1) = f(x(k), u(k)) + w(k)`, `w ~ N(0, Q)`; `y(k) = h(x(k), u(k)) + v(k)`,
//! `v ~ N(0, R)` (000: 4.99 ff., 003: 2.22-2.23).

use nalgebra::{SMatrix, SVector};

/// A discrete-time nonlinear state-space model with `N` states, `M` measurements and `U` inputs.
///
/// Models A (5 states, 4 measurements, 3 inputs), B in its 3-state form of seed 001 and C
/// implement this; every filter in this crate is generic over it, so no filter is ever copied per
/// model. Implementations must not allocate: filters call these functions inside their step.
pub trait StateSpaceModel<const N: usize, const M: usize, const U: usize> {
    /// Names of the states, in order (for reports and error messages).
    fn state_names(&self) -> [&'static str; N];

    /// Names of the measurements, in order.
    fn measurement_names(&self) -> [&'static str; M];

    /// The discrete state transition `f(x, u)` over one sample time.
    fn transition(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, N>;

    /// `∂f/∂x` at `(x, u)`; analytic where the model has it. Finite differences only as test oracle.
    fn transition_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, N, N>;

    /// `f(x, u)` and `∂f/∂x` at the same `(x, u)`, as the EKF's prediction needs them
    /// (000: 4.105, 4.108). A model whose Jacobian comes from forward-mode automatic
    /// differentiation already holds `f` in the value part of that pass and overrides this, so
    /// the EKF evaluates the model once instead of twice; the result must equal the two separate
    /// calls bit for bit.
    fn transition_and_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        (
            self.transition(state, input),
            self.transition_jacobian(state, input),
        )
    }

    /// `∂f/∂u` at `(x, u)`, needed by linearised (LKF, Luenberger) models.
    fn transition_input_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, N, U>;

    /// The measurement function `h(x, u)` (may depend on the input: direct feed-through, 000: 5.63).
    fn measurement(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, M>;

    /// `∂h/∂x` at `(x, u)`.
    fn measurement_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, M, N>;

    /// `h(x, u)` and `∂h/∂x` at the same `(x, u)` (the EKF's update, 000: 4.109, 4.112); see
    /// [`StateSpaceModel::transition_and_jacobian`] for why a model overrides it.
    fn measurement_and_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> (SVector<f64, M>, SMatrix<f64, M, N>) {
        (
            self.measurement(state, input),
            self.measurement_jacobian(state, input),
        )
    }

    /// `∂h/∂u` at `(x, u)`.
    fn measurement_input_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, M, U>;

    /// States that enter `f` and `h` linearly, or nearly so, given the others, and whose own
    /// transition is linear in themselves alone: a particle filter may keep them as a Kalman
    /// mean and covariance per particle instead of sampling them (the marginalised particle
    /// filter, Schön, Gustafsson and Nordlund, IEEE Trans. Signal Processing 53(7), 2005).
    /// None by default.
    fn conditionally_linear_states(&self) -> &'static [usize] {
        &[]
    }

    /// `f(x, u)` and the columns of `∂f/∂x` at [`Self::conditionally_linear_states`] (the other
    /// columns may hold anything): what the marginalised particle filter needs of every
    /// particle. A model whose Jacobian comes from dual numbers overrides it to seed only those
    /// directions.
    fn transition_and_linear_columns(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        self.transition_and_jacobian(state, input)
    }

    /// Process noise covariance `Q` of the discrete model.
    fn process_noise(&self) -> SMatrix<f64, N, N>;

    /// Measurement noise covariance `R`.
    fn measurement_noise(&self) -> SMatrix<f64, M, M>;
}
