//! One forward-mode pass of dual numbers over a model function written once, generic over the
//! scalar: its value and Jacobian with respect to the state, or its Jacobian with respect to
//! the input (for the models of this crate whose Jacobians are not the vehicle-models crate's
//! own: the grip model).

use nalgebra::{SMatrix, SVector};
use vehicle_models::Dual;

/// `(f(x, u), ∂f/∂x)`, the `N` state directions seeded.
pub fn state_pass<const N: usize, const U: usize, const R: usize>(
    state: &SVector<f64, N>,
    input: &SVector<f64, U>,
    f: impl Fn(&[Dual<f64, N>; N], &[Dual<f64, N>; U]) -> [Dual<f64, N>; R],
) -> (SVector<f64, R>, SMatrix<f64, R, N>) {
    let xs = core::array::from_fn(|i| Dual::variable(state[i], i));
    let us = core::array::from_fn(|j| Dual::from_value(input[j]));
    let out = f(&xs, &us);
    (
        SVector::from_fn(|i, _| out[i].value),
        SMatrix::from_fn(|i, j| out[i].gradient[j]),
    )
}

/// `∂f/∂u`, the `U` input directions seeded but for `held` (a switch with no derivative).
pub fn input_pass<const N: usize, const U: usize, const R: usize>(
    state: &SVector<f64, N>,
    input: &SVector<f64, U>,
    held: Option<usize>,
    f: impl Fn(&[Dual<f64, U>; N], &[Dual<f64, U>; U]) -> [Dual<f64, U>; R],
) -> SMatrix<f64, R, U> {
    let xs = core::array::from_fn(|i| Dual::from_value(state[i]));
    let us = core::array::from_fn(|j| {
        if Some(j) == held {
            Dual::from_value(input[j])
        } else {
            Dual::variable(input[j], j)
        }
    });
    let out = f(&xs, &us);
    SMatrix::from_fn(|i, j| out[i].gradient[j])
}
