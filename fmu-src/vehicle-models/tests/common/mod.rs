//! Test oracles shared by the integration tests.
#![allow(dead_code)]

use nalgebra::{SMatrix, SVector};

/// Central finite-difference Jacobian of `f` at `x`, step `1e-6 · max(|x_j|, 1)`.
pub fn central_difference<const R: usize, const C: usize>(
    x: &SVector<f64, C>,
    f: impl Fn(&SVector<f64, C>) -> SVector<f64, R>,
) -> SMatrix<f64, R, C> {
    let mut jacobian = SMatrix::<f64, R, C>::zeros();
    for j in 0..C {
        let h = 1e-6 * x[j].abs().max(1.0);
        let mut plus = *x;
        let mut minus = *x;
        plus[j] += h;
        minus[j] -= h;
        let column = (f(&plus) - f(&minus)) / (2.0 * h);
        jacobian.set_column(j, &column);
    }
    jacobian
}

/// Asserts `|exact − finite difference| ≤ 1e-6 · max(|exact|, 1)` element-wise.
pub fn assert_jacobian_close<const R: usize, const C: usize>(
    what: &str,
    exact: &SMatrix<f64, R, C>,
    finite_difference: &SMatrix<f64, R, C>,
) {
    for i in 0..R {
        for j in 0..C {
            let (a, b) = (exact[(i, j)], finite_difference[(i, j)]);
            assert!(a.is_finite(), "{what}[{i},{j}] is not finite: {a}");
            let tolerance = 1e-6 * a.abs().max(1.0);
            assert!(
                (a - b).abs() <= tolerance,
                "{what}[{i},{j}]: exact {a:.12e} vs central difference {b:.12e}"
            );
        }
    }
}
