//! Gaussian building blocks of the particle filter: square roots of covariances, weighted
//! moments of a particle set, the used rows of a measurement and the log-likelihood over them.

use nalgebra::{SMatrix, SVector};
use rand::Rng;
use rand_distr::StandardNormal;

use super::ParticleFilterError;
use crate::estimator::MeasurementMask;

/// A lower-triangular square root `S` with `S Sᵀ = P` of a symmetric positive semi-definite
/// matrix: the Cholesky factor, computed so that a singular `P` (e.g. a state without process
/// noise, or an exactly known initial state) is legitimate: a pivot that is zero up to rounding
/// gives a zero column instead of a failure. A clearly negative pivot is an error.
pub fn covariance_square_root<const N: usize>(
    covariance: &SMatrix<f64, N, N>,
    what: &'static str,
) -> Result<SMatrix<f64, N, N>, ParticleFilterError> {
    if covariance.iter().any(|value| !value.is_finite()) {
        return Err(ParticleFilterError::NotPositiveSemiDefinite(what, f64::NAN));
    }
    let symmetric = (covariance + covariance.transpose()) * 0.5;
    let tolerance = 1e-12 * symmetric.amax().max(f64::MIN_POSITIVE);
    let mut root = SMatrix::<f64, N, N>::zeros();
    for column in 0..N {
        let mut pivot = symmetric[(column, column)];
        for k in 0..column {
            pivot -= root[(column, k)] * root[(column, k)];
        }
        if pivot < -tolerance {
            return Err(ParticleFilterError::NotPositiveSemiDefinite(what, pivot));
        }
        if pivot <= tolerance {
            continue;
        }
        let diagonal = pivot.sqrt();
        root[(column, column)] = diagonal;
        for row in column + 1..N {
            let mut value = symmetric[(row, column)];
            for k in 0..column {
                value -= root[(row, k)] * root[(column, k)];
            }
            root[(row, column)] = value / diagonal;
        }
    }
    Ok(root)
}

/// Weighted mean and weighted sample covariance `Σ w_i (x_i - x̄)(x_i - x̄)ᵀ` of normalised weights.
pub fn weighted_moments<const N: usize>(
    particles: &[SVector<f64, N>],
    weights: &[f64],
) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
    let mut mean = SVector::<f64, N>::zeros();
    for (particle, &weight) in particles.iter().zip(weights) {
        if weight > 0.0 {
            mean += particle * weight;
        }
    }
    let mut covariance = SMatrix::<f64, N, N>::zeros();
    for (particle, &weight) in particles.iter().zip(weights) {
        if weight > 0.0 {
            let deviation = particle - mean;
            covariance.ger(weight, &deviation, &deviation, 1.0);
        }
    }
    (mean, covariance)
}

/// The measurement rows used in one update: masked in and finite.
pub(crate) fn used_rows<const M: usize>(
    measurement: &SVector<f64, M>,
    mask: &MeasurementMask<M>,
) -> MeasurementMask<M> {
    let mut used = [false; M];
    for (row, flag) in used.iter_mut().enumerate() {
        *flag = mask[row] && measurement[row].is_finite();
    }
    used
}

/// `R` restricted to the used rows, padded to full size: unused rows and columns become those of
/// the identity, so a Cholesky of the padded matrix is the Cholesky of the used block, and a
/// residual that is zero in unused rows gives the used-rows quadratic form. No allocation.
pub(crate) fn masked_covariance<const M: usize>(
    covariance: &SMatrix<f64, M, M>,
    used: &MeasurementMask<M>,
) -> SMatrix<f64, M, M> {
    let mut masked = *covariance;
    for row in 0..M {
        for column in 0..M {
            if !used[row] || !used[column] {
                masked[(row, column)] = if row == column { 1.0 } else { 0.0 };
            }
        }
    }
    masked
}

/// `log N(y; ŷ, R)` over the used rows, up to a constant shared by all particles (003: 2.60);
/// `noise_cholesky` is that of `R` restricted to them ([`masked_covariance`]).
pub(super) fn log_likelihood<const M: usize>(
    measurement: &SVector<f64, M>,
    predicted: &SVector<f64, M>,
    used: &MeasurementMask<M>,
    noise_cholesky: &nalgebra::Cholesky<f64, nalgebra::Const<M>>,
) -> f64 {
    let mut residual = measurement - predicted;
    for (row, &flag) in used.iter().enumerate() {
        if !flag {
            residual[row] = 0.0;
        }
    }
    let whitened = noise_cholesky
        .l_dirty()
        .solve_lower_triangular(&residual)
        .unwrap_or_else(|| SVector::repeat(f64::INFINITY));
    -0.5 * whitened.norm_squared()
}

/// A vector of independent standard normal draws.
pub(super) fn standard_normal_vector<const N: usize, R: Rng + ?Sized>(
    rng: &mut R,
) -> SVector<f64, N> {
    SVector::from_fn(|_, _| rng.sample(StandardNormal))
}
