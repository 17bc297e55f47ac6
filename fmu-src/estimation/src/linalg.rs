//! Small dense-matrix helpers shared by the Kalman-type filters: keeping a covariance symmetric
//! positive definite (SPEC §6) and factorising it without ever panicking.
//!
//! Everything works on nalgebra's fixed-size types, so nothing here allocates.

use nalgebra::{Cholesky, SMatrix, SVector};

/// `for $j in 0..$n $body`, written out as straight-line code for `$n ≤ 8` (a plain loop beyond).
///
/// The compiler unrolls the kernels below completely for 4×4 matrices but keeps the outer loop
/// for 5×5 ones, and then every intermediate goes through memory: the 5×5 Cholesky
/// factorisation took twice as long as written out. Each copy of the body sees a constant `$j`,
/// so its inner loops have constant bounds and unroll on their own.
macro_rules! unrolled_for {
    ($j:ident in 0..$n:expr => $body:block) => {
        if $n <= 8 {
            unrolled_for!(@copies $j, $n, $body, 0 1 2 3 4 5 6 7);
        } else {
            for $j in 0..$n $body
        }
    };
    (@copies $j:ident, $n:expr, $body:block, $($index:literal)*) => {
        $( { let $j: usize = $index; if $j < $n $body } )*
    };
}

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

/// Whether every entry is finite. Evaluates every entry (no early exit) so that the check
/// vectorises: on the finite matrices of a normal filter step that is the cheaper way.
pub fn all_finite<const R: usize, const C: usize>(matrix: &SMatrix<f64, R, C>) -> bool {
    matrix
        .iter()
        .fold(true, |finite, value| finite & value.is_finite())
}

/// Sets every entry of the upper triangle to `entry(row, col, current value)` and copies it
/// onto the lower triangle: the result is exactly symmetric whatever the rounding in `entry`,
/// at a little more than half the work of the full matrix.
#[inline(always)]
pub(crate) fn update_symmetric<const N: usize>(
    matrix: &mut SMatrix<f64, N, N>,
    entry: impl Fn(usize, usize, f64) -> f64,
) {
    unrolled_for!(col in 0..N => {
        for row in 0..=col {
            matrix[(row, col)] = entry(row, col, matrix[(row, col)]);
        }
    });
    unrolled_for!(col in 0..N => {
        for row in (col + 1)..N {
            matrix[(row, col)] = matrix[(col, row)];
        }
    });
}

// The products below are plain loops over the fixed sizes, which the compiler unrolls and
// vectorises along the columns: for the 4- and 5-dimensional matrices of a filter step that is
// much faster than nalgebra's general product. They skip the zero entries of their second
// operand (measurement matrices are mostly unit rows, the LKF's transition matrix is block
// diagonal at straight driving, noise covariances are diagonal); a skipped `0 · x` term is
// exactly zero for the finite matrices of a filter step, so the result is the same.

/// `Σₖ Aᵢₖ b(k, j)`, accumulated in the order `k = 0, 1, …`, skipping zero `b(k, j)`.
#[inline(always)]
fn product_with<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: impl Fn(usize, usize) -> f64,
) -> SMatrix<f64, R, C> {
    let mut out = SMatrix::<f64, R, C>::zeros();
    unrolled_for!(col in 0..C => {
        for k in 0..K {
            let factor = b(k, col);
            if factor != 0.0 {
                for row in 0..R {
                    out[(row, col)] += a[(row, k)] * factor;
                }
            }
        }
    });
    out
}

/// `A B`, skipping zero entries of `B`.
#[inline]
pub fn product<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, K, C>,
) -> SMatrix<f64, R, C> {
    product_with(a, |k, col| b[(k, col)])
}

/// `A Bᵀ` without forming `Bᵀ`, skipping zero entries of `B`.
#[inline]
pub fn product_transpose<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, C, K>,
) -> SMatrix<f64, R, C> {
    product_with(a, |k, col| b[(col, k)])
}

/// `A B` for a product known to be symmetric (such as `H (P Hᵀ)`), exactly symmetric.
#[inline]
pub fn symmetric_product<const R: usize, const K: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, K, R>,
) -> SMatrix<f64, R, R> {
    let mut out = SMatrix::<f64, R, R>::zeros();
    update_symmetric(&mut out, |row, col, _| {
        let mut sum = 0.0;
        for k in 0..K {
            sum += a[(row, k)] * b[(k, col)];
        }
        sum
    });
    out
}

/// `A B Aᵀ` for a symmetric `B` (a covariance pushed through a linear map: `F P Fᵀ`, the
/// Joseph form's terms), as `A (B Aᵀ)` with [`symmetric_product`]: exactly symmetric, no
/// symmetrising pass needed; zero entries of `A` are skipped.
#[inline]
pub fn congruence<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    b: &SMatrix<f64, C, C>,
) -> SMatrix<f64, R, R> {
    symmetric_product(a, &product_transpose(b, a))
}

/// `S += w (D Dᵀ + E Eᵀ)`: the weighted sum of the outer products of the columns of `D` and
/// `E`, as in the sigma-point covariances; `S` stays exactly symmetric if it was.
#[inline]
pub fn add_weighted_gram<const R: usize, const C: usize>(
    sum: &mut SMatrix<f64, R, R>,
    weight: f64,
    d: &SMatrix<f64, R, C>,
    e: &SMatrix<f64, R, C>,
) {
    update_symmetric(sum, |row, col, current| {
        let mut dot = 0.0;
        for k in 0..C {
            dot += d[(row, k)] * d[(col, k)] + e[(row, k)] * e[(col, k)];
        }
        current + weight * dot
    });
}

/// `S += w v vᵀ`, exactly symmetric.
#[inline]
pub fn add_weighted_outer<const R: usize>(
    sum: &mut SMatrix<f64, R, R>,
    weight: f64,
    v: &SVector<f64, R>,
) {
    update_symmetric(sum, |row, col, current| {
        current + v[row] * (weight * v[col])
    });
}

/// `S -= W Wᵀ`, exactly symmetric.
#[inline]
pub fn subtract_gram<const R: usize, const C: usize>(
    sum: &mut SMatrix<f64, R, R>,
    w: &SMatrix<f64, R, C>,
) {
    update_symmetric(sum, |row, col, current| {
        let mut dot = 0.0;
        for k in 0..C {
            dot += w[(row, k)] * w[(col, k)];
        }
        current - dot
    });
}

/// The lower Cholesky factor `L` of a symmetric positive definite matrix (`L Lᵀ = A`), with the
/// reciprocals of its diagonal kept for the triangular solves.
///
/// nalgebra's `Cholesky` serves any dimension through general column views; this fixed-size
/// version is several times faster on the 4×4 and 5×5 matrices of a filter step, and it
/// refuses (rather than propagates) a non-finite matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CholeskyFactor<const N: usize> {
    lower: SMatrix<f64, N, N>,
    inverse_diagonal: [f64; N],
}

impl<const N: usize> CholeskyFactor<N> {
    /// Factorises `A` from its lower triangle. `None` when a pivot is not a positive finite
    /// number: `A` is not numerically positive definite or has non-finite entries (every entry
    /// of the factor enters a later pivot, so a finite last pivot means a finite factor).
    ///
    /// The elimination runs as `A = U D Uᵀ` with a unit lower `U` (Cholesky-Crout without
    /// square roots), and `L = U √D` is formed at the end: the chain from one column to the
    /// next then holds one division instead of a square root and a division, which is what
    /// bounds the time of so small a factorisation.
    #[inline]
    pub fn new(a: &SMatrix<f64, N, N>) -> Option<Self> {
        // U is kept below the diagonal of `unit`; a bad pivot does not exit at once (an exit
        // inside the elimination keeps it from being straight-line code) but is replaced by 1,
        // which keeps the remaining arithmetic finite, and reported at the end.
        let mut unit = SMatrix::<f64, N, N>::zeros();
        let mut pivots = [0.0; N];
        let mut inverse_pivots = [0.0; N];
        let mut positive = true;
        unrolled_for!(j in 0..N => {
            // (U D)ⱼₖ for k < j.
            let mut scaled_row = [0.0; N];
            for k in 0..j {
                scaled_row[k] = unit[(j, k)] * pivots[k];
            }
            let mut pivot = a[(j, j)];
            for k in 0..j {
                pivot -= unit[(j, k)] * scaled_row[k];
            }
            let usable = pivot > 0.0 && pivot < f64::INFINITY;
            positive &= usable;
            let pivot = if usable { pivot } else { 1.0 };
            pivots[j] = pivot;
            let inverse = 1.0 / pivot;
            inverse_pivots[j] = inverse;
            for i in (j + 1)..N {
                let mut value = a[(i, j)];
                for k in 0..j {
                    value -= unit[(i, k)] * scaled_row[k];
                }
                unit[(i, j)] = value * inverse;
            }
        });
        if !positive {
            return None;
        }
        let mut lower = unit;
        let mut inverse_diagonal = [0.0; N];
        unrolled_for!(j in 0..N => {
            let root = pivots[j].sqrt();
            inverse_diagonal[j] = inverse_pivots[j].sqrt();
            lower[(j, j)] = root;
            for i in (j + 1)..N {
                lower[(i, j)] *= root;
            }
        });
        Some(Self {
            lower,
            inverse_diagonal,
        })
    }

    /// `ln det A = 2 Σ ln Lᵢᵢ`.
    pub fn log_determinant(&self) -> f64 {
        -2.0 * self.inverse_diagonal.iter().map(|d| d.ln()).sum::<f64>()
    }

    /// `L` (zero above the diagonal).
    pub fn lower(&self) -> &SMatrix<f64, N, N> {
        &self.lower
    }

    /// `L⁻¹ b` by forward substitution.
    #[inline]
    pub fn solve_lower(&self, b: &SVector<f64, N>) -> SVector<f64, N> {
        let mut x = *b;
        unrolled_for!(j in 0..N => {
            let value = x[j] * self.inverse_diagonal[j];
            x[j] = value;
            for i in (j + 1)..N {
                x[i] -= self.lower[(i, j)] * value;
            }
        });
        x
    }

    /// `C L⁻ᵀ`, row by row the forward substitution `L wᵀ = cᵀ`. With `C = Pxy` this is the
    /// "whitened" cross-covariance `W`: `K = Pxy A⁻¹ = W L⁻¹` and `K A Kᵀ = W Wᵀ`.
    #[inline]
    pub fn solve_right_transpose<const R: usize>(
        &self,
        c: &SMatrix<f64, R, N>,
    ) -> SMatrix<f64, R, N> {
        let mut w = *c;
        unrolled_for!(j in 0..N => {
            for k in 0..j {
                let factor = self.lower[(j, k)];
                for row in 0..R {
                    w[(row, j)] -= w[(row, k)] * factor;
                }
            }
            let inverse = self.inverse_diagonal[j];
            for row in 0..R {
                w[(row, j)] *= inverse;
            }
        });
        w
    }

    /// `W L⁻¹`, row by row the back substitution `Lᵀ kᵀ = wᵀ`; with [`Self::solve_right_transpose`]
    /// it gives `C A⁻¹`.
    #[inline]
    pub fn solve_right<const R: usize>(&self, w: &SMatrix<f64, R, N>) -> SMatrix<f64, R, N> {
        let mut k = *w;
        unrolled_for!(reversed in 0..N => {
            let j = N - 1 - reversed;
            for i in (j + 1)..N {
                let factor = self.lower[(i, j)];
                for row in 0..R {
                    k[(row, j)] -= k[(row, i)] * factor;
                }
            }
            let inverse = self.inverse_diagonal[j];
            for row in 0..R {
                k[(row, j)] *= inverse;
            }
        });
        k
    }
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
    /// The factorisation of the input, or of its repaired version.
    pub factor: CholeskyFactor<N>,
    /// The repaired matrix that was factorised instead of the input, if the input needed one.
    pub repaired: Option<SMatrix<f64, N, N>>,
}

/// Cholesky factorisation of a symmetric matrix (read from its lower triangle) with a repair
/// fallback: when the plain factorisation fails (the matrix is not numerically positive
/// definite), the matrix is repaired with [`repair_positive_definite`] and factorised again.
/// `None` only for non-finite input.
pub fn cholesky_with_repair<const N: usize>(
    matrix: &SMatrix<f64, N, N>,
) -> Option<RepairedCholesky<N>> {
    if let Some(factor) = CholeskyFactor::new(matrix) {
        return Some(RepairedCholesky {
            factor,
            repaired: None,
        });
    }
    let repaired = repair_positive_definite(matrix)?;
    let factor = CholeskyFactor::new(&repaired)?;
    Some(RepairedCholesky {
        factor,
        repaired: Some(repaired),
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
        assert!(factor.repaired.is_none());
        let l = factor.factor.lower();
        assert!((l * l.transpose() - m).amax() < 1e-14);
    }

    #[test]
    fn indefinite_matrix_is_repaired_to_positive_definite() {
        // Eigenvalues 3, -1 and 1: not a covariance.
        let m = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        let factor = cholesky_with_repair(&m).unwrap();
        let repaired = factor.repaired.unwrap();
        let l = factor.factor.lower();
        assert!((l * l.transpose() - repaired).amax() < 1e-12);
        let (eigenvalues, _) = symmetric_eigen_jacobi(&repaired);
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

    /// A deterministic symmetric positive definite matrix and a dense one with a few zeros.
    fn test_matrices<const N: usize, const M: usize>(
    ) -> (SMatrix<f64, N, N>, SMatrix<f64, M, N>, SMatrix<f64, N, M>) {
        let root = SMatrix::<f64, N, N>::from_fn(|i, j| ((i * 7 + j * 3) % 5) as f64 - 1.7);
        let spd = root * root.transpose() + SMatrix::<f64, N, N>::identity();
        let a = SMatrix::<f64, M, N>::from_fn(|i, j| {
            if (i + 2 * j) % 3 == 0 {
                0.0
            } else {
                (i as f64 - 0.3 * j as f64).sin()
            }
        });
        let b = SMatrix::<f64, N, M>::from_fn(|i, j| (0.7 * i as f64 + j as f64).cos());
        (spd, a, b)
    }

    /// The kernels against nalgebra's plain products, for a size the kernels write out
    /// (5, 4) and one beyond (9, 3), where they run as loops.
    fn kernels_agree_with_nalgebra<const N: usize, const M: usize>() {
        let (p, h, k) = test_matrices::<N, M>();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
        let agree = |ours: &[f64], reference: &[f64]| {
            assert!(ours.iter().zip(reference).all(|(a, b)| close(*a, *b)));
        };
        agree(product(&k, &h).as_slice(), (k * h).as_slice());
        agree(
            product_transpose(&p, &h).as_slice(),
            (p * h.transpose()).as_slice(),
        );
        let s = congruence(&h, &p);
        assert_eq!(s, s.transpose(), "exactly symmetric");
        agree(s.as_slice(), (h * p * h.transpose()).as_slice());
        let mut sum = p;
        add_weighted_gram(&mut sum, 0.25, &k, &(2.0 * k));
        assert_eq!(sum, sum.transpose());
        agree(
            sum.as_slice(),
            (p + 0.25 * (k * k.transpose() + 4.0 * k * k.transpose())).as_slice(),
        );
        let v = k.column(0).into_owned();
        let mut outer = p;
        add_weighted_outer(&mut outer, -0.5, &v);
        agree(outer.as_slice(), (p - 0.5 * v * v.transpose()).as_slice());
        let mut reduced = p;
        subtract_gram(&mut reduced, &k);
        agree(reduced.as_slice(), (p - k * k.transpose()).as_slice());

        let factor = CholeskyFactor::new(&p).unwrap();
        let l = factor.lower();
        agree((l * l.transpose()).as_slice(), p.as_slice());
        assert!((0..N).all(|i| ((i + 1)..N).all(|j| l[(i, j)] == 0.0)));
        let reference = p.cholesky().unwrap();
        let b = k.column(1).into_owned();
        agree(
            factor.solve_lower(&b).as_slice(),
            reference.l().solve_lower_triangular(&b).unwrap().as_slice(),
        );
        // C A⁻¹ through the two half-solves.
        let c = h;
        agree(
            factor
                .solve_right(&factor.solve_right_transpose(&c))
                .as_slice(),
            (c * p.try_inverse().unwrap()).as_slice(),
        );
    }

    #[test]
    fn kernels_agree_with_nalgebra_written_out_and_as_loops() {
        kernels_agree_with_nalgebra::<5, 4>();
        kernels_agree_with_nalgebra::<9, 3>();
    }

    #[test]
    fn a_matrix_that_is_not_positive_definite_has_no_factor() {
        // Eigenvalues 3, -1 and 1; and a semi-definite one (a zero pivot).
        let indefinite = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(CholeskyFactor::new(&indefinite).is_none());
        let semidefinite = Matrix3::new(1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(CholeskyFactor::new(&semidefinite).is_none());
    }

    #[test]
    fn non_finite_matrix_is_refused() {
        // The factorisation reads the lower triangle (the filters' covariances are exactly
        // symmetric); a non-finite entry anywhere there, diagonal or not, is refused.
        for (row, col) in [(2, 1), (1, 0), (2, 0), (0, 0), (1, 1), (2, 2)] {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut m = Matrix3::identity();
                m[(row, col)] = bad;
                assert!(CholeskyFactor::new(&m).is_none(), "{bad} at ({row}, {col})");
                assert!(
                    cholesky_with_repair(&m).is_none(),
                    "{bad} at ({row}, {col})"
                );
            }
        }
        let mut m = Matrix3::identity();
        m[(1, 2)] = f64::NAN;
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
