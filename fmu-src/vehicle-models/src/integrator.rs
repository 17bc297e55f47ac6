//! Discretisation schemes shared by the models.

use serde::{Deserialize, Serialize};

use crate::scalar::Scalar;

/// How a model's continuous equations are turned into one discrete step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Integrator {
    /// The seed-000 scheme (000: 6.1-6.5): explicit Euler for the body states, semi-implicit
    /// Euler `ω(k+1) = ω(k) + T ω̇(k) / (1 − T ∂ω̇/∂ω)` for the stiff wheel speeds. For models
    /// without wheel speeds (B in its 3-state form, C) this is plain explicit Euler.
    ///
    /// Stable at the seed's filter sample times (10 ms, 50 ms) for steering manoeuvres. Under
    /// hard braking a sliding tyre gives the wheel little damping (`∂ω̇/∂ω → 0`), so at 50 ms the
    /// wheel speeds overshoot; the seed only brakes at 1 ms (000: 7.2.1-7.2.2).
    #[default]
    SemiImplicitEuler,
    /// Classical 4-stage Runge-Kutta (003: A.25-A.32), inputs held over the step.
    ///
    /// Explicit, so for model A's and model B's stiff wheel speeds (eigenvalue
    /// `≈ −2 r_w² Cs / (I vx)`, about −370 1/s for the rear wheels at 18 m/s) it needs
    /// `T ≲ 5 ms` at 18 m/s and less at lower speed; at filter sample times of 10-50 ms use the
    /// seed scheme, which stays stable there (tests/model_a.rs). For models without wheel
    /// speeds (model C, model B's 3-state form) RK4 is the accurate choice.
    RungeKutta4,
}

/// One classical Runge-Kutta step (003: A.28-A.32) of `ẋ = f(x)` with step `dt`.
#[inline(always)]
pub fn runge_kutta4<S: Scalar, const N: usize>(
    state: &[S; N],
    dt: f64,
    mut derivative: impl FnMut(&[S; N]) -> [S; N],
) -> [S; N] {
    let offset = |base: &[S; N], slope: &[S; N], h: f64| -> [S; N] {
        core::array::from_fn(|i| base[i] + slope[i] * h)
    };
    // (003: A.28-A.31)
    let k1 = derivative(state);
    let k2 = derivative(&offset(state, &k1, 0.5 * dt));
    let k3 = derivative(&offset(state, &k2, 0.5 * dt));
    let k4 = derivative(&offset(state, &k3, dt));
    // (003: A.32)
    core::array::from_fn(|i| state[i] + (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * (dt / 6.0))
}

/// One explicit Euler step `x + T f(x)` (000: 3.5 as used in 6.3-6.5; 001: eq 14).
#[inline(always)]
pub fn explicit_euler<S: Scalar, const N: usize>(
    state: &[S; N],
    dt: f64,
    derivative: &[S; N],
) -> [S; N] {
    core::array::from_fn(|i| state[i] + derivative[i] * dt)
}

/// The semi-implicit Euler update of one stiff state (000: 6.1-6.2):
/// `x(k+1) = x(k) + T ẋ / (1 − T ∂ẋ/∂x)`.
///
/// The seed's factor damps because `∂ẋ/∂x < 0` for a wheel on the rising part of the tyre curve.
/// On a falling friction curve (sliding, 000: 5.69) the derivative can turn positive and the
/// factor would blow up near `T ∂ẋ/∂x = 1`; a positive derivative is therefore taken as zero
/// (plain explicit Euler for that step). This limit is the project's addition to the seed.
#[inline(always)]
pub fn semi_implicit_update<S: Scalar>(value: S, rate: S, rate_derivative: S, dt: f64) -> S {
    let damping = if rate_derivative.value() < 0.0 {
        rate_derivative
    } else {
        S::constant(0.0)
    };
    value + rate * dt / (-(damping * dt) + 1.0)
}
