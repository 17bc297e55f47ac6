//! Small dense-matrix helpers shared by the Kalman-type filters: keeping a covariance symmetric
//! positive definite (SPEC §6) and factorising it without ever panicking.
//!
//! Everything works on nalgebra's fixed-size types, so nothing here allocates.

use nalgebra::{Cholesky, Const, SMatrix, SVector};

/// Replaces `P` by `(P + Pᵀ) / 2`. Rounding in `F P Fᵀ` or `P - K S Kᵀ` leaves tiny asymmetries
/// that would otherwise grow over thousands of steps.
pub fn symmetrize<const N: usize>(matrix: &mut SMatrix<f64, N, N>) {
    for row in 0..N {
        for col in (row + 1)..N {
            let mean = 0.5 * (matrix[(row, col)] + matrix[(col, row)]);
            matrix[(row, col)] = mean;
            matrix[(col, row)] = mean;
        }
    }
}

/// Whether every entry is finite.
pub fn all_finite<const R: usize, const C: usize>(matrix: &SMatrix<f64, R, C>) -> bool {
    matrix.iter().all(|value| value.is_finite())
}

/// The smallest eigenvalue a repaired covariance keeps, relative to its largest one. Large enough
/// that the Cholesky factor of the repaired matrix exists in double precision.
const RELATIVE_EIGENVALUE_FLOOR: f64 = 1e-12;

/// An absolute floor for a covariance whose eigenvalues are all zero or negative.
const ABSOLUTE_EIGENVALUE_FLOOR: f64 = 1e-300;

/// Makes a symmetric matrix positive definite by clamping its eigenvalues from below.
///
/// The symmetric eigendecomposition `P = V Λ Vᵀ` is recomposed with
/// `λᵢ ← max(λᵢ, 1e-12 · max|λ|)`: the nearest (in the Frobenius norm) matrix with that eigenvalue
/// floor, so a repair changes the covariance as little as possible. Returns `None` when the
/// matrix has non-finite entries (nothing sensible can be recovered from those).
pub fn repair_positive_definite<const N: usize>(
    matrix: &SMatrix<f64, N, N>,
) -> Option<SMatrix<f64, N, N>> {
    if !all_finite(matrix) {
        return None;
    }
    let mut symmetric = *matrix;
    symmetrize(&mut symmetric);
    let (eigenvalues, eigenvectors) = symmetric_eigen_jacobi(&symmetric);
    let largest = eigenvalues.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let floor = (largest * RELATIVE_EIGENVALUE_FLOOR).max(ABSOLUTE_EIGENVALUE_FLOOR);
    let clamped = eigenvalues.map(|value| value.max(floor));
    let mut repaired =
        eigenvectors * SMatrix::<f64, N, N>::from_diagonal(&clamped) * eigenvectors.transpose();
    symmetrize(&mut repaired);
    all_finite(&repaired).then_some(repaired)
}

/// Eigenvalues and eigenvectors (as columns) of a symmetric matrix by cyclic Jacobi rotations.
///
/// nalgebra's `symmetric_eigen` is not available for a generic `const N` (it needs type-level
/// dimension arithmetic), and the repair path is rare, so a plain Jacobi iteration — robust and
/// allocation-free for the small matrices here — does the job.
pub fn symmetric_eigen_jacobi<const N: usize>(
    matrix: &SMatrix<f64, N, N>,
) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
    let mut a = *matrix;
    let mut vectors = SMatrix::<f64, N, N>::identity();
    for _sweep in 0..64 {
        let off_diagonal: f64 = (0..N)
            .flat_map(|i| ((i + 1)..N).map(move |j| (i, j)))
            .map(|(i, j)| a[(i, j)] * a[(i, j)])
            .sum();
        let diagonal: f64 = (0..N).map(|i| a[(i, i)] * a[(i, i)]).sum();
        if off_diagonal <= f64::EPSILON * f64::EPSILON * diagonal || off_diagonal == 0.0 {
            break;
        }
        for p in 0..N {
            for q in (p + 1)..N {
                let apq = a[(p, q)];
                if apq == 0.0 {
                    continue;
                }
                // Rotation angle that zeroes a[p][q] (Golub & Van Loan, symmetric Schur).
                let theta = (a[(q, q)] - a[(p, p)]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..N {
                    let akp = a[(k, p)];
                    let akq = a[(k, q)];
                    a[(k, p)] = c * akp - s * akq;
                    a[(k, q)] = s * akp + c * akq;
                }
                for k in 0..N {
                    let apk = a[(p, k)];
                    let aqk = a[(q, k)];
                    a[(p, k)] = c * apk - s * aqk;
                    a[(q, k)] = s * apk + c * aqk;
                }
                for k in 0..N {
                    let vkp = vectors[(k, p)];
                    let vkq = vectors[(k, q)];
                    vectors[(k, p)] = c * vkp - s * vkq;
                    vectors[(k, q)] = s * vkp + c * vkq;
                }
            }
        }
    }
    (a.diagonal(), vectors)
}

/// A Cholesky factorisation that succeeded, possibly after repairing the matrix.
#[derive(Debug, Clone)]
pub struct RepairedCholesky<const N: usize> {
    /// The factorisation of `matrix`.
    pub cholesky: Cholesky<f64, Const<N>>,
    /// The matrix that was factorised: the input, or its repaired version.
    pub matrix: SMatrix<f64, N, N>,
    /// Whether the input had to be repaired first.
    pub repaired: bool,
}

/// Cholesky factorisation of a symmetric matrix with a repair fallback: when the plain
/// factorisation fails (the matrix is not numerically positive definite), the matrix is repaired
/// with [`repair_positive_definite`] and factorised again. `None` only for non-finite input.
pub fn cholesky_with_repair<const N: usize>(
    matrix: &SMatrix<f64, N, N>,
) -> Option<RepairedCholesky<N>> {
    if !all_finite(matrix) {
        return None;
    }
    if let Some(cholesky) = Cholesky::new(*matrix) {
        return Some(RepairedCholesky {
            cholesky,
            matrix: *matrix,
            repaired: false,
        });
    }
    let repaired = repair_positive_definite(matrix)?;
    let cholesky = Cholesky::new(repaired)?;
    Some(RepairedCholesky {
        cholesky,
        matrix: repaired,
        repaired: true,
    })
}

/// Checks that a user-supplied covariance is finite, symmetric (to a relative `1e-9`) and
/// positive definite; returns a message naming what is wrong otherwise.
pub fn check_covariance<const N: usize>(
    name: &str,
    matrix: &SMatrix<f64, N, N>,
) -> Result<(), String> {
    if !all_finite(matrix) {
        return Err(format!("{name} must have finite entries, got {matrix}"));
    }
    let scale = matrix.amax().max(f64::MIN_POSITIVE);
    let asymmetry = (matrix - matrix.transpose()).amax();
    if asymmetry > 1e-9 * scale {
        return Err(format!("{name} must be symmetric, got {matrix}"));
    }
    if Cholesky::new(*matrix).is_none() {
        return Err(format!("{name} must be positive definite, got {matrix}"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    #[test]
    fn symmetrize_averages_off_diagonal_pairs() {
        let mut m = Matrix3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0);
        symmetrize(&mut m);
        assert_eq!(m, Matrix3::new(1.0, 3.0, 5.0, 3.0, 5.0, 7.0, 5.0, 7.0, 9.0));
    }

    #[test]
    fn positive_definite_matrix_is_factorised_unchanged() {
        let m = Matrix3::new(4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0);
        let factor = cholesky_with_repair(&m).unwrap();
        assert!(!factor.repaired);
        assert_eq!(factor.matrix, m);
        let l = factor.cholesky.l();
        assert!((l * l.transpose() - m).amax() < 1e-14);
    }

    #[test]
    fn indefinite_matrix_is_repaired_to_positive_definite() {
        // Eigenvalues 3, -1 and 1: not a covariance.
        let m = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        let factor = cholesky_with_repair(&m).unwrap();
        assert!(factor.repaired);
        let (eigenvalues, _) = symmetric_eigen_jacobi(&factor.matrix);
        assert!(eigenvalues.iter().all(|&v| v > 0.0));
        // The positive eigen-directions are kept.
        assert!((eigenvalues.max() - 3.0).abs() < 1e-12);
    }

    #[test]
    fn jacobi_eigen_decomposition_reconstructs_the_matrix() {
        let m = Matrix3::new(4.0, 1.0, -2.0, 1.0, 3.0, 0.5, -2.0, 0.5, -1.0);
        let (values, vectors) = symmetric_eigen_jacobi(&m);
        let rebuilt = vectors * Matrix3::from_diagonal(&values) * vectors.transpose();
        assert!((rebuilt - m).amax() < 1e-13);
        assert!((vectors.transpose() * vectors - Matrix3::identity()).amax() < 1e-13);
        let mut sorted: Vec<f64> = values.iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        let mut expected: Vec<f64> = m.symmetric_eigen().eigenvalues.iter().copied().collect();
        expected.sort_by(f64::total_cmp);
        for (a, b) in sorted.iter().zip(&expected) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    #[test]
    fn non_finite_matrix_is_refused() {
        let mut m = Matrix3::identity();
        m[(1, 2)] = f64::NAN;
        assert!(cholesky_with_repair(&m).is_none());
        assert!(repair_positive_definite(&m).is_none());
    }

    #[test]
    fn covariance_check_names_the_problem() {
        let err =
            check_covariance("initial covariance", &(-Matrix3::<f64>::identity())).unwrap_err();
        assert!(err.contains("initial covariance") && err.contains("positive definite"));
        let mut asym = Matrix3::identity();
        asym[(0, 1)] = 0.5;
        assert!(check_covariance("Q", &asym)
            .unwrap_err()
            .contains("symmetric"));
    }
}
