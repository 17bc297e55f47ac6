//! Kalman-type filters over [`StateSpaceModel`]: the linear Kalman filter on a fixed
//! linearisation ([`LinearKalmanFilter`], 000: 4.64-4.75), the extended Kalman filter
//! ([`ExtendedKalmanFilter`], 000: 4.99-4.113) and the unscented Kalman filter with either the
//! seed's 2n sigma points or the scaled 2n+1 set ([`UnscentedKalmanFilter`], 000: 4.114-4.144;
//! 001 [13, 16]).
//!
//! A caller that picks the estimator at run time (the FMU) builds it through
//! [`crate::registry`].
//!
//! Missing measurements: a row whose mask entry is `false` or whose value is not finite is
//! skipped. The filters do that without allocating by giving the skipped rows a unit innovation
//! covariance and a zero cross-covariance: the innovation covariance is then block-diagonal
//! between used and skipped rows, so the gain columns of the skipped rows are exactly zero and the
//! update is exactly the update with the used rows alone.

mod ekf;
pub(crate) mod linearised;
mod lkf;
mod ukf;

pub use ekf::ExtendedKalmanFilter;
pub use linearised::LinearisedModel;
pub use lkf::LinearKalmanFilter;
pub use ukf::{SigmaPoints, UnscentedKalmanFilter};

use nalgebra::{Complex, SMatrix, SVector};

use crate::linalg::{
    all_finite, check_covariance, product, product_transpose, repair_positive_definite,
    symmetric_product, symmetrize, update_symmetric, CholeskyFactor,
};
use crate::{FilterIssue, MeasurementMask, StateSpaceModel, UpdateReport};

/// An estimator setting that cannot work, with a message naming the setting and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid estimator setting: {0}")]
pub struct SettingsError(pub String);

/// The Gaussian an estimator starts from: `x̂⁺(0)` and `P⁺(0)` (000: 4.69-4.70).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialEstimate<const N: usize> {
    pub state: SVector<f64, N>,
    pub covariance: SMatrix<f64, N, N>,
}

impl<const N: usize> InitialEstimate<N> {
    /// A start with a diagonal covariance.
    pub fn diagonal(state: SVector<f64, N>, variances: SVector<f64, N>) -> Self {
        Self {
            state,
            covariance: SMatrix::from_diagonal(&variances),
        }
    }

    /// Checks that the state is finite and the covariance symmetric positive definite.
    pub fn validate(&self) -> Result<(), SettingsError> {
        if !all_finite(&self.state) {
            return Err(SettingsError(format!(
                "the initial state must be finite, got {}",
                self.state.transpose()
            )));
        }
        check_covariance("the initial covariance", &self.covariance).map_err(SettingsError)
    }

    /// The covariance made exactly symmetric (it passes [`Self::validate`] when symmetric to
    /// 1e-9); the Kalman filters keep it exactly symmetric from there on.
    pub(crate) fn symmetric_covariance(&self) -> SMatrix<f64, N, N> {
        let mut covariance = self.covariance;
        symmetrize(&mut covariance);
        covariance
    }
}

/// Checks the model's `Q` and `R` once, when a filter is built, and makes them exactly
/// symmetric (they pass the check when symmetric to 1e-9): the filters build their covariances
/// exactly symmetric, and adding an exactly symmetric `Q` or `R` keeps them so without a
/// symmetrising pass per step.
fn validated_noise<Model, const N: usize, const M: usize, const U: usize>(
    model: &Model,
) -> Result<(SMatrix<f64, N, N>, SMatrix<f64, M, M>), SettingsError>
where
    Model: StateSpaceModel<N, M, U>,
{
    let process_noise = model.process_noise();
    let measurement_noise = model.measurement_noise();
    check_covariance("the process noise covariance Q", &process_noise).map_err(SettingsError)?;
    check_covariance("the measurement noise covariance R", &measurement_noise)
        .map_err(SettingsError)?;
    let (mut process_noise, mut measurement_noise) = (process_noise, measurement_noise);
    symmetrize(&mut process_noise);
    symmetrize(&mut measurement_noise);
    Ok((process_noise, measurement_noise))
}

/// Which rows take part in an update: present in the mask, finite in the measurement and finite
/// in the prediction.
fn usable_rows<const M: usize>(
    measurement: &SVector<f64, M>,
    predicted: &SVector<f64, M>,
    mask: &MeasurementMask<M>,
) -> MeasurementMask<M> {
    let mut used = [false; M];
    for row in 0..M {
        used[row] = mask[row] && measurement[row].is_finite() && predicted[row].is_finite();
    }
    used
}

/// The gain, innovation and consistency of one masked measurement update, kept in the factored
/// form `S = L Lᵀ`, `W = Pxy L⁻ᵀ`, `e = L⁻¹ ν`: then `K = W L⁻¹`, `K ν = W e`,
/// `K S Kᵀ = W Wᵀ` and `NIS = eᵀ e`, so no inverse of `S` is ever formed and a filter that does
/// not need `K` itself (the UKF) does not compute it.
pub(crate) struct GainStep<const N: usize, const M: usize> {
    factor: CholeskyFactor<M>,
    /// `W = Pxy L⁻ᵀ`.
    pub(crate) whitened_cross: SMatrix<f64, N, M>,
    /// `e = L⁻¹ ν`.
    pub(crate) whitened_innovation: SVector<f64, M>,
    pub(crate) report: UpdateReport<M>,
}

impl<const N: usize, const M: usize> GainStep<N, M> {
    /// `K = Pxy S⁻¹ = W L⁻¹` (000: 4.72, 4.111, 4.142); zero columns for the skipped rows.
    pub(crate) fn gain(&self) -> SMatrix<f64, N, M> {
        self.factor.solve_right(&self.whitened_cross)
    }

    /// The state correction `K ν = W e` (000: 4.74, 4.112, 4.143).
    pub(crate) fn correction(&self) -> SVector<f64, N> {
        product(&self.whitened_cross, &self.whitened_innovation)
    }
}

/// `K = Pxy S⁻¹` over the used rows (000: 4.72, 4.111, 4.142), the innovation `ν = y - ŷ` and
/// `NIS = νᵀ S⁻¹ ν`. `cross` is `Pxy` (`P⁻Hᵀ` for the LKF/EKF), `innovation_covariance` is `S`
/// including `R` (symmetric; its lower triangle is read). Returns `Ok(None)` when no row is
/// usable and `Err(UpdateSkipped)` when `S` is not positive definite or `Pxy` not finite.
#[inline]
pub(crate) fn masked_gain<const N: usize, const M: usize>(
    mut cross: SMatrix<f64, N, M>,
    mut innovation_covariance: SMatrix<f64, M, M>,
    measurement: &SVector<f64, M>,
    predicted: &SVector<f64, M>,
    mask: &MeasurementMask<M>,
) -> Result<Option<GainStep<N, M>>, FilterIssue> {
    let used = usable_rows(measurement, predicted, mask);
    let rows_used = used.iter().filter(|&&u| u).count();
    if rows_used == 0 {
        return Ok(None);
    }
    let innovation = if rows_used == M {
        measurement - predicted
    } else {
        let mut innovation = SVector::<f64, M>::zeros();
        for row in 0..M {
            if used[row] {
                innovation[row] = measurement[row] - predicted[row];
            } else {
                // Decouple the skipped row: unit variance, no correlation, no cross-covariance.
                innovation_covariance.row_mut(row).fill(0.0);
                innovation_covariance.column_mut(row).fill(0.0);
                innovation_covariance[(row, row)] = 1.0;
                cross.column_mut(row).fill(0.0);
            }
        }
        innovation
    };
    if !all_finite(&cross) {
        return Err(FilterIssue::UpdateSkipped);
    }
    // The factorisation also refuses a non-finite S.
    let Some(factor) = CholeskyFactor::new(&innovation_covariance) else {
        return Err(FilterIssue::UpdateSkipped);
    };
    let whitened_innovation = factor.solve_lower(&innovation);
    Ok(Some(GainStep {
        factor,
        whitened_cross: factor.solve_right_transpose(&cross),
        whitened_innovation,
        report: UpdateReport {
            innovation,
            nis: masked_dot(&whitened_innovation, &whitened_innovation, &used),
            rows_used,
            used,
        },
    }))
}

/// `aᵀ b` over a masked update's rows (its skipped rows are 0 in `a` or `b`): summed over the
/// rows up to the last used one, but at least the first four, in the order nalgebra's `dot`
/// uses for a vector of that length. A model with extra trailing rows that are not used this
/// time (model A's optional `vx` row) then gives the NIS of the model without them bit
/// for bit, the seeds' four rows included (nalgebra sums four products as `(a + c) + (b + d)`,
/// more in order).
pub(crate) fn masked_dot<const M: usize>(
    a: &SVector<f64, M>,
    b: &SVector<f64, M>,
    used: &MeasurementMask<M>,
) -> f64 {
    let last_used = used.iter().rposition(|&u| u).unwrap_or(0);
    let length = (last_used + 1).max(M.min(4));
    match length {
        4 => a.fixed_rows::<4>(0).dot(&b.fixed_rows::<4>(0)),
        3 => a.fixed_rows::<3>(0).dot(&b.fixed_rows::<3>(0)),
        2 => a.fixed_rows::<2>(0).dot(&b.fixed_rows::<2>(0)),
        _ if length == M => a.dot(b),
        _ => a.rows(0, length).dot(&b.rows(0, length)),
    }
}

/// Keeps a posterior covariance symmetric positive definite. A Joseph-form or `P - K S Kᵀ`
/// result is positive semi-definite in exact arithmetic; rounding can break that, which this
/// detects cheaply (negative or zero diagonal) or via the Cholesky attempt of the next step.
/// The filters build their covariances exactly symmetric ([`congruence`],
/// [`crate::linalg::add_weighted_gram`], [`crate::linalg::subtract_gram`]), so no symmetrising pass is needed here.
/// Returns whether a repair was needed, or `None` if the covariance is not finite.
#[inline]
fn keep_positive_definite<const N: usize>(covariance: &mut SMatrix<f64, N, N>) -> Option<bool> {
    if !all_finite(covariance) {
        return None;
    }
    if covariance
        .diagonal()
        .iter()
        .fold(true, |positive, &v| positive & (v > 0.0))
    {
        return Some(false);
    }
    *covariance = repair_positive_definite(covariance)?;
    Some(true)
}

/// Discrete poles `zᵢ = exp(sᵢ T)` from continuous-time poles `sᵢ` and the sample time `T`:
/// seed 002 designs in continuous time, the observer here is discrete.
pub fn discrete_poles<const K: usize>(
    continuous: [Complex<f64>; K],
    sample_time: f64,
) -> [Complex<f64>; K] {
    continuous.map(|pole| (pole * sample_time).exp())
}

/// Shared step bookkeeping: the state and covariance before a step, restored when a step would
/// leave them non-finite (SPEC §6: no NaN ever leaves the estimator).
pub(crate) fn finite_or_restore<const N: usize>(
    state: &mut SVector<f64, N>,
    covariance: &mut SMatrix<f64, N, N>,
    previous_state: SVector<f64, N>,
    previous_covariance: SMatrix<f64, N, N>,
) -> bool {
    if all_finite(state) && all_finite(covariance) {
        true
    } else {
        *state = previous_state;
        *covariance = previous_covariance;
        false
    }
}

/// The Joseph-form covariance update `P⁺ = (I - K H) P⁻ (I - K H)ᵀ + K R Kᵀ` (004; 000: 4.61),
/// valid for any gain, so it also serves the fixed-gain Luenberger observer.
pub(crate) fn joseph_update<const N: usize, const M: usize>(
    covariance: &SMatrix<f64, N, N>,
    gain: &SMatrix<f64, N, M>,
    output_matrix: &SMatrix<f64, M, N>,
    measurement_noise: &SMatrix<f64, M, M>,
) -> SMatrix<f64, N, N> {
    let cross = product_transpose(covariance, output_matrix);
    joseph_update_with_cross(covariance, &cross, gain, output_matrix, measurement_noise)
}

/// [`joseph_update`] with `P⁻ Hᵀ` already at hand: `P⁻ (I - K H)ᵀ = P⁻ - (P⁻ Hᵀ) Kᵀ`, then
/// `(I - K H)` times that and `(K R) Kᵀ` as exactly symmetric products (zero entries of `H` and
/// `R` skipped).
#[inline]
fn joseph_update_with_cross<const N: usize, const M: usize>(
    covariance: &SMatrix<f64, N, N>,
    cross: &SMatrix<f64, N, M>,
    gain: &SMatrix<f64, N, M>,
    output_matrix: &SMatrix<f64, M, N>,
    measurement_noise: &SMatrix<f64, M, M>,
) -> SMatrix<f64, N, N> {
    let mut i_minus_kh = -product(gain, output_matrix);
    for i in 0..N {
        i_minus_kh[(i, i)] += 1.0;
    }
    let right = covariance - product_transpose(cross, gain);
    symmetric_product(&i_minus_kh, &right)
        + symmetric_product(&product(gain, measurement_noise), &gain.transpose())
}

/// `R` as the LKF and EKF use it: the matrix, and its diagonal when `R` is diagonal
/// (uncorrelated sensors, as in every model of this crate), which lets the update run row by row
/// ([`sequential_update`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MeasurementNoise<const M: usize> {
    covariance: SMatrix<f64, M, M>,
    variances: Option<SVector<f64, M>>,
}

impl<const M: usize> MeasurementNoise<M> {
    pub(crate) fn new(covariance: SMatrix<f64, M, M>) -> Self {
        let diagonal = (0..M).all(|i| (0..M).all(|j| i == j || covariance[(i, j)] == 0.0));
        Self {
            covariance,
            variances: diagonal.then(|| covariance.diagonal()),
        }
    }
}

/// An `R` to which one update's extra noise is added
/// ([`crate::running::RunningEstimator::update_with_extra_noise`]).
pub(crate) trait NoisePlus<const M: usize>: Copy {
    /// `R + extra`, exactly symmetric (the filters rely on a symmetric `R`, see
    /// [`validated_noise`]).
    fn plus(&self, extra: &SMatrix<f64, M, M>) -> Self;
}

impl<const M: usize> NoisePlus<M> for SMatrix<f64, M, M> {
    fn plus(&self, extra: &SMatrix<f64, M, M>) -> Self {
        let mut sum = self + extra;
        symmetrize(&mut sum);
        sum
    }
}

/// A diagonal `extra` keeps the row-by-row update.
impl<const M: usize> NoisePlus<M> for MeasurementNoise<M> {
    fn plus(&self, extra: &SMatrix<f64, M, M>) -> Self {
        Self::new(self.covariance.plus(extra))
    }
}

/// [`crate::running::RunningEstimator::update_with_extra_noise`] for an estimator whose `R` is
/// its field `measurement_noise` (a [`NoisePlus`]): the update with `R + extra`, then `R` back
/// as it was, bit for bit.
macro_rules! update_with_r_plus_extra {
    () => {
        fn update_with_extra_noise(
            &mut self,
            measurement: &nalgebra::SVector<f64, M>,
            input: &nalgebra::SVector<f64, U>,
            mask: &crate::MeasurementMask<M>,
            extra: &nalgebra::SMatrix<f64, M, M>,
        ) -> Result<crate::UpdateReport<M>, crate::FilterIssue> {
            use crate::kalman::NoisePlus;
            let own = self.measurement_noise;
            self.measurement_noise = own.plus(extra);
            let outcome = crate::Estimator::update(self, measurement, input, mask);
            self.measurement_noise = own;
            outcome
        }
    };
}
pub(crate) use update_with_r_plus_extra;

/// [`crate::running::RunningEstimator::condition_on`] for a filter that owns its Gaussian
/// (`state`, `covariance`): the scalar update `K = P hᵀ / (h P hᵀ + r)`, `x̂ += K residual`,
/// `P = (I − K h) P (I − K h)ᵀ + K r Kᵀ` (Joseph form, 004).
macro_rules! condition_on_own_gaussian {
    () => {
        fn condition_on(
            &mut self,
            h: &nalgebra::SVector<f64, N>,
            residual: f64,
            variance: f64,
        ) -> bool {
            crate::kalman::scalar_update(
                &mut self.state,
                &mut self.covariance,
                h,
                residual,
                variance,
            )
        }
    };
}
pub(crate) use condition_on_own_gaussian;

/// The scalar update of [`condition_on_own_gaussian`]; `false`, changing nothing, when
/// `variance` is not positive or the result is not finite.
pub(crate) fn scalar_update<const N: usize>(
    state: &mut SVector<f64, N>,
    covariance: &mut SMatrix<f64, N, N>,
    h: &SVector<f64, N>,
    residual: f64,
    variance: f64,
) -> bool {
    let ph = *covariance * h;
    let innovation_variance = h.dot(&ph) + variance;
    if !(variance > 0.0 && innovation_variance.is_finite() && residual.is_finite()) {
        return false;
    }
    let gain = ph / innovation_variance;
    let reduction = SMatrix::<f64, N, N>::identity() - gain * h.transpose();
    let updated =
        reduction * *covariance * reduction.transpose() + gain * gain.transpose() * variance;
    let corrected = *state + gain * residual;
    if !(updated.iter().all(|p| p.is_finite()) && corrected.iter().all(|x| x.is_finite())) {
        return false;
    }
    *state = corrected;
    *covariance = (updated + updated.transpose()) * 0.5;
    true
}

/// A posterior step common to the LKF, the EKF and the marginalised particle filter's
/// particles: gain, state correction and Joseph-form covariance (004) from the prediction `ŷ` and
/// the measurement matrix `H` at the prior. Returns the report, whether the covariance needed a
/// repair, and `ln det S` of the innovation covariance over the used rows (0 when none is),
/// which with the NIS gives the predictive likelihood `ln N(y; ŷ, S) = -½ (NIS + ln det S)` up
/// to a constant. Leaves state and covariance untouched when no row is usable.
#[inline]
pub(crate) fn linearised_update<const N: usize, const M: usize>(
    state: &mut SVector<f64, N>,
    covariance: &mut SMatrix<f64, N, N>,
    predicted_measurement: &SVector<f64, M>,
    output_matrix: &SMatrix<f64, M, N>,
    noise: &MeasurementNoise<M>,
    measurement: &SVector<f64, M>,
    mask: &MeasurementMask<M>,
) -> Result<(UpdateReport<M>, bool, f64), FilterIssue> {
    let used = usable_rows(measurement, predicted_measurement, mask);
    let rows_used = used.iter().filter(|&&u| u).count();
    if rows_used == 0 {
        return Ok((UpdateReport::skipped(), false, 0.0));
    }
    let previous_state = *state;
    let previous_covariance = *covariance;
    let outcome = match noise.variances {
        Some(variances) => sequential_update(
            state,
            covariance,
            predicted_measurement,
            output_matrix,
            &variances,
            measurement,
            &used,
        ),
        None => batch_update(
            state,
            covariance,
            predicted_measurement,
            output_matrix,
            &noise.covariance,
            measurement,
            mask,
        ),
    };
    let (report, log_det) = match outcome {
        Ok(outcome) => outcome,
        Err(issue) => {
            *state = previous_state;
            *covariance = previous_covariance;
            return Err(issue);
        }
    };
    // `keep_positive_definite` checks the covariance for finiteness; only the state is left.
    let repaired = keep_positive_definite(covariance);
    if repaired.is_none() || !all_finite(state) {
        *state = previous_state;
        *covariance = previous_covariance;
        return Err(FilterIssue::StateReset);
    }
    Ok((report, repaired == Some(true), log_det))
}

/// The update for a diagonal `R`, one measurement row after the other (sequential processing):
/// with uncorrelated measurement noise, the batch update `K = P⁻Hᵀ(H P⁻ Hᵀ + R)⁻¹` (000: 4.72,
/// 4.111) is the same as the scalar updates in turn, each on the estimate the rows before left,
/// with the linearisation kept at the prior (so the EKF is not re-linearised in between). Each
/// row's innovation variance `s = hᵀ P h + r` is a pivot of the batch `S`, its gain `k = P h / s`
/// needs no matrix inverse, and its Joseph form (004)
/// `P⁺ = (I - k hᵀ) P (I - k hᵀ)ᵀ + r k kᵀ` is a rank-one correction. `NIS = Σ ν̃ᵢ² / sᵢ` over
/// the rows' innovations against the running estimate equals `νᵀ S⁻¹ ν` (the chain rule of
/// the Gaussian likelihood). On an error the caller restores the prior.
#[inline]
fn sequential_update<const N: usize, const M: usize>(
    state: &mut SVector<f64, N>,
    covariance: &mut SMatrix<f64, N, N>,
    predicted_measurement: &SVector<f64, M>,
    output_matrix: &SMatrix<f64, M, N>,
    variances: &SVector<f64, M>,
    measurement: &SVector<f64, M>,
    used: &MeasurementMask<M>,
) -> Result<(UpdateReport<M>, f64), FilterIssue> {
    let prior_state = *state;
    let mut innovation = SVector::<f64, M>::zeros();
    let mut nis = 0.0;
    // ln det S: S's pivots are the rows' innovation variances in turn.
    let mut log_det = 0.0;
    for row in 0..M {
        if !used[row] {
            continue;
        }
        let h: SVector<f64, N> = output_matrix.row(row).transpose();
        innovation[row] = measurement[row] - predicted_measurement[row];
        // ŷᵢ + hᵀ (x - x⁻) predicts this row from the estimate the earlier rows left.
        let running_innovation = innovation[row] - h.dot(&(*state - prior_state));
        let cross = product(covariance, &h);
        let variance = h.dot(&cross) + variances[row];
        if !(variance > 0.0 && variance < f64::INFINITY && all_finite(&cross)) {
            return Err(FilterIssue::UpdateSkipped);
        }
        // One division; the gain entries as products (a division per entry costs more).
        let inverse_variance = 1.0 / variance;
        let gain = cross * inverse_variance;
        *state += gain * running_innovation;
        nis += running_innovation * running_innovation * inverse_variance;
        log_det += variance.ln();
        // (I - k hᵀ) P = P - k (P h)ᵀ, then times (I - k hᵀ)ᵀ: minus ((I - k hᵀ) P h) kᵀ.
        let left = *covariance - gain * cross.transpose();
        let left_h = product(&left, &h);
        let noise = variances[row];
        update_symmetric(covariance, |i, j, _| {
            left[(i, j)] - left_h[i] * gain[j] + noise * gain[i] * gain[j]
        });
    }
    let rows_used = used.iter().filter(|&&u| u).count();
    let report = UpdateReport {
        innovation,
        nis,
        rows_used,
        used: *used,
    };
    Ok((report, log_det))
}

/// The update with a full `R`: gain from `P⁻ Hᵀ` and `S = H P⁻ Hᵀ + R` ([`masked_gain`]), state
/// correction, Joseph-form covariance. On an error the caller restores the prior.
#[inline]
fn batch_update<const N: usize, const M: usize>(
    state: &mut SVector<f64, N>,
    covariance: &mut SMatrix<f64, N, N>,
    predicted_measurement: &SVector<f64, M>,
    output_matrix: &SMatrix<f64, M, N>,
    measurement_noise: &SMatrix<f64, M, M>,
    measurement: &SVector<f64, M>,
    mask: &MeasurementMask<M>,
) -> Result<(UpdateReport<M>, f64), FilterIssue> {
    let cross = product_transpose(covariance, output_matrix);
    let innovation_covariance = symmetric_product(output_matrix, &cross) + measurement_noise;
    let Some(step) = masked_gain(
        cross,
        innovation_covariance,
        measurement,
        predicted_measurement,
        mask,
    )?
    else {
        return Ok((UpdateReport::skipped(), 0.0));
    };
    let gain = step.gain();
    *state += product(&gain, &step.report.innovation);
    // Skipped rows have zero gain columns; zero their H rows and P⁻Hᵀ columns too so that a
    // non-finite entry in a skipped row cannot leak into the covariance as 0 · NaN.
    // With every row used (the common case) H is taken as it is, without a masked copy.
    *covariance = if step.report.rows_used == M {
        joseph_update_with_cross(covariance, &cross, &gain, output_matrix, measurement_noise)
    } else {
        let mut used_output_matrix = *output_matrix;
        let mut used_cross = cross;
        for row in 0..M {
            if !step.report.used[row] {
                used_output_matrix.row_mut(row).fill(0.0);
                used_cross.column_mut(row).fill(0.0);
            }
        }
        joseph_update_with_cross(
            covariance,
            &used_cross,
            &gain,
            &used_output_matrix,
            measurement_noise,
        )
    };
    // The skipped rows' unit diagonal adds nothing to ln det S.
    Ok((step.report, step.factor.log_determinant()))
}

/// Records the outcome of an update as the filter's last report and turns a repaired covariance
/// into the [`FilterIssue`] the caller sees (the estimate itself was still corrected).
#[inline]
pub(crate) fn conclude_update<const M: usize>(
    last_report: &mut UpdateReport<M>,
    outcome: Result<(UpdateReport<M>, bool), FilterIssue>,
) -> Result<UpdateReport<M>, FilterIssue> {
    match outcome {
        Ok((report, repaired)) => {
            *last_report = report;
            if repaired {
                Err(FilterIssue::CovarianceRepaired)
            } else {
                Ok(report)
            }
        }
        Err(issue) => {
            *last_report = UpdateReport::skipped();
            Err(issue)
        }
    }
}

/// A prior step common to the filters: checks the new state and covariance, restores the old
/// ones (inflated by `Q`, since time has passed) if the prediction was not finite.
#[inline]
pub(crate) fn finish_prediction<const N: usize>(
    state: &mut SVector<f64, N>,
    covariance: &mut SMatrix<f64, N, N>,
    previous_state: SVector<f64, N>,
    previous_covariance: SMatrix<f64, N, N>,
    process_noise: &SMatrix<f64, N, N>,
) -> Result<(), FilterIssue> {
    // `keep_positive_definite` checks the covariance for finiteness.
    let repaired = if all_finite(state) {
        keep_positive_definite(covariance)
    } else {
        None
    };
    match repaired {
        Some(false) => Ok(()),
        Some(true) => Err(FilterIssue::CovarianceRepaired),
        None => {
            *state = previous_state;
            *covariance = previous_covariance + process_noise;
            Err(FilterIssue::StateReset)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3-state covariance, a measurement matrix with a unit row, a dense row and a sparse one,
    /// and a diagonal `R`.
    fn case() -> (
        SVector<f64, 3>,
        SMatrix<f64, 3, 3>,
        SMatrix<f64, 3, 3>,
        SMatrix<f64, 3, 3>,
    ) {
        let state = SVector::<f64, 3>::new(0.4, -1.2, 2.0);
        let root = SMatrix::<f64, 3, 3>::new(1.0, 0.0, 0.0, 0.3, 0.8, 0.0, -0.2, 0.5, 0.6);
        let covariance = root * root.transpose();
        let output_matrix = SMatrix::<f64, 3, 3>::new(0.0, 1.0, 0.0, 0.7, -0.4, 1.3, 0.0, 0.0, 2.0);
        let noise = SMatrix::<f64, 3, 3>::from_diagonal(&SVector::<f64, 3>::new(0.05, 0.2, 0.01));
        (state, covariance, output_matrix, noise)
    }

    fn relative(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    #[test]
    fn row_by_row_update_equals_the_batch_update() {
        let (state, covariance, output_matrix, noise) = case();
        let sequential = MeasurementNoise::new(noise);
        assert!(sequential.variances.is_some());
        let batch = MeasurementNoise {
            covariance: noise,
            variances: None,
        };
        let predicted = output_matrix * state;
        let measurement = predicted + SVector::<f64, 3>::new(0.3, -0.5, 0.25);
        let mut nan_row = measurement;
        nan_row[1] = f64::NAN;
        for (y, mask) in [
            (measurement, [true; 3]),
            (measurement, [true, false, true]),
            (measurement, [false, true, false]),
            (nan_row, [true; 3]),
        ] {
            let run = |noise: &MeasurementNoise<3>| {
                let (mut x, mut p) = (state, covariance);
                let (report, repaired, log_det) =
                    linearised_update(&mut x, &mut p, &predicted, &output_matrix, noise, &y, &mask)
                        .unwrap();
                assert!(!repaired);
                (x, p, report, log_det)
            };
            let (x_seq, p_seq, report_seq, log_det_seq) = run(&sequential);
            let (x_batch, p_batch, report_batch, log_det_batch) = run(&batch);
            // ln det S over the used rows, from nalgebra's determinant of that block
            let rows: Vec<usize> = (0..3).filter(|&r| report_batch.used[r]).collect();
            let s = output_matrix * covariance * output_matrix.transpose() + noise;
            let block =
                nalgebra::DMatrix::from_fn(rows.len(), rows.len(), |i, j| s[(rows[i], rows[j])]);
            let expected = block.determinant().ln();
            assert!((log_det_seq - expected).abs() < 1e-12, "{mask:?}");
            assert!((log_det_batch - expected).abs() < 1e-12, "{mask:?}");
            assert_eq!(report_seq.used, report_batch.used);
            assert_eq!(report_seq.innovation, report_batch.innovation);
            assert!((report_seq.nis - report_batch.nis).abs() < 1e-13 * report_batch.nis);
            assert!(
                relative(x_seq.as_slice(), x_batch.as_slice()) < 1e-14,
                "{mask:?}"
            );
            assert!(
                relative(p_seq.as_slice(), p_batch.as_slice()) < 1e-14,
                "{mask:?}"
            );
            assert_eq!(p_seq, p_seq.transpose());
            // Not vacuous: the update moved the estimate.
            assert!((x_seq - state).amax() > 1e-3);
        }
    }

    #[test]
    fn a_non_finite_measurement_matrix_row_skips_the_whole_update() {
        let (state, covariance, mut output_matrix, noise) = case();
        let predicted = output_matrix * state;
        let measurement = predicted + SVector::<f64, 3>::new(0.3, -0.5, 0.25);
        // Row 2 comes after rows 0 and 1 have been processed: the prior must come back.
        output_matrix[(2, 1)] = f64::NAN;
        for noise in [
            MeasurementNoise::new(noise),
            MeasurementNoise {
                covariance: noise,
                variances: None,
            },
        ] {
            let (mut x, mut p) = (state, covariance);
            let outcome = linearised_update(
                &mut x,
                &mut p,
                &predicted,
                &output_matrix,
                &noise,
                &measurement,
                &[true; 3],
            );
            assert_eq!(outcome, Err(FilterIssue::UpdateSkipped));
            assert_eq!((x, p), (state, covariance));
        }
    }
}
