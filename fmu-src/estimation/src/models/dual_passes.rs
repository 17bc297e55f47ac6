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

/// `(f(x, u), ∂f/∂x)` with only the `K` state directions `columns` seeded: the Jacobian's other
/// columns are zero. Cheaper than [`state_pass`] by the directions left out.
pub fn columns_pass<const N: usize, const U: usize, const R: usize, const K: usize>(
    state: &SVector<f64, N>,
    input: &SVector<f64, U>,
    columns: [usize; K],
    f: impl Fn(&[Dual<f64, K>; N], &[Dual<f64, K>; U]) -> [Dual<f64, K>; R],
) -> (SVector<f64, R>, SMatrix<f64, R, N>) {
    let xs = core::array::from_fn(|i| match columns.iter().position(|&c| c == i) {
        Some(direction) => Dual::variable(state[i], direction),
        None => Dual::from_value(state[i]),
    });
    let us = core::array::from_fn(|j| Dual::from_value(input[j]));
    let out = f(&xs, &us);
    let mut jacobian = SMatrix::<f64, R, N>::zeros();
    for (direction, &column) in columns.iter().enumerate() {
        for (row, value) in out.iter().enumerate() {
            jacobian[(row, column)] = value.gradient[direction];
        }
    }
    (SVector::from_fn(|i, _| out[i].value), jacobian)
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
