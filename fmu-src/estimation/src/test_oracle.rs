//! Test oracle shared by the unit tests of the model adapters: central finite differences, against
//! which the exact (automatic-differentiation) Jacobians are checked. Never used by a filter.

use nalgebra::{SMatrix, SVector};

/// Central-difference Jacobian of `f` at `at`, with a step relative to each coordinate's size.
pub(crate) fn central_difference<const R: usize, const K: usize>(
    f: impl Fn(&SVector<f64, K>) -> SVector<f64, R>,
    at: &SVector<f64, K>,
) -> SMatrix<f64, R, K> {
    let mut jacobian = SMatrix::<f64, R, K>::zeros();
    for j in 0..K {
        let h = 1e-6 * at[j].abs().max(1e-2);
        let mut plus = *at;
        let mut minus = *at;
        plus[j] += h;
        minus[j] -= h;
        jacobian.set_column(j, &((f(&plus) - f(&minus)) / (2.0 * h)));
    }
    jacobian
}
