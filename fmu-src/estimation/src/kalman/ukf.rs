//! Unscented Kalman filter with additive noise, with two sigma-point sets:
//!
//! - [`SigmaPoints::Symmetric`]: the seed-000 filter, `2n` points `x̂ ± (√(n P))ᵢ` with equal
//!   weights `1/(2n)` (000: 4.114-4.144). filterpy's `JulierSigmaPoints(n, kappa=0)` is the same
//!   set (its centre point carries weight 0).
//! - [`SigmaPoints::Scaled`]: the scaled `2n+1` set of Julier/Uhlmann and Wan/van der Merwe
//!   (001 refs [13, 16]), `λ = α²(n + κ) - n`, points `x̂` and `x̂ ± (√((n + λ) P))ᵢ`, mean weights
//!   `λ/(n+λ)` and `1/(2(n+λ))`, covariance weight of the centre `λ/(n+λ) + 1 - α² + β`; the
//!   same as filterpy's `MerweScaledSigmaPoints`.
//!
//! The matrix square root is the lower Cholesky factor `L` (`L Lᵀ = c P`); its columns are the
//! seed's "rows of √(nP)" (000: 4.115, `√(nP)ᵀ` row-wise) and filterpy's rows of its upper factor.
//!
//! As in the seed (000: 4.135-4.137), the update draws fresh sigma points from the prior
//! `(x̂⁻, P⁻)` rather than reusing the propagated ones, and the covariance update is
//! `P⁺ = P⁻ - K S Kᵀ` (000: 4.144); filterpy 2.0.0 does both the same way. `K S Kᵀ` is
//! evaluated as `W Wᵀ` with `W = Pxy L⁻ᵀ`, `S = L Lᵀ` (equal in exact arithmetic, see
//! [`super::GainStep`]): no inverse, no product with `S`, exactly symmetric.
//!
//! The sigma points live in `N × N` matrices (one column per point, `+` and `-` sets apart), so
//! the filter needs no `2N + 1`-sized array and never allocates.

use nalgebra::{SMatrix, SVector};

use super::{
    conclude_update, finish_prediction, keep_positive_definite, masked_gain, validated_noise,
    InitialEstimate, SettingsError,
};
use crate::linalg::{
    add_weighted_gram, add_weighted_outer, all_finite, cholesky_with_repair, product_transpose,
    subtract_gram,
};
use crate::{Estimator, FilterIssue, MeasurementMask, StateSpaceModel, UpdateReport};

/// Which sigma-point set the UKF uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SigmaPoints {
    /// `2n` points, weights `1/(2n)` (000: 4.114-4.122).
    Symmetric,
    /// Scaled `2n + 1` points (Wan/van der Merwe).
    Scaled { alpha: f64, beta: f64, kappa: f64 },
}

impl SigmaPoints {
    /// The scaled set, filterpy's `MerweScaledSigmaPoints(n, alpha, beta, kappa)`; the usual
    /// choice for Gaussian noise is `beta = 2`. Checked when the filter is built.
    pub fn scaled(alpha: f64, beta: f64, kappa: f64) -> Self {
        Self::Scaled { alpha, beta, kappa }
    }
}

/// Spread and weights of a sigma-point set for dimension `n`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SigmaWeights {
    /// `√c` for `x̂ ± (√(c P))ᵢ`.
    spread_root: f64,
    /// Mean weight of the centre point.
    mean_centre: f64,
    /// Covariance weight of the centre point.
    covariance_centre: f64,
    /// Weight of every other point (mean and covariance).
    outer: f64,
    /// Whether the centre point enters at all (it does not in the 2n set).
    uses_centre: bool,
}

impl SigmaWeights {
    fn new(points: SigmaPoints, dimension: usize) -> Result<Self, SettingsError> {
        let n = dimension as f64;
        match points {
            SigmaPoints::Symmetric => Ok(Self {
                spread_root: n.sqrt(),
                mean_centre: 0.0,
                covariance_centre: 0.0,
                outer: 1.0 / (2.0 * n),
                uses_centre: false,
            }),
            SigmaPoints::Scaled { alpha, beta, kappa } => {
                if !(alpha.is_finite() && alpha > 0.0) {
                    return Err(SettingsError(format!(
                        "the UKF spread alpha must be a positive number, got {alpha}"
                    )));
                }
                if !beta.is_finite() || !kappa.is_finite() {
                    return Err(SettingsError(format!(
                        "the UKF parameters beta and kappa must be finite, got beta = {beta}, kappa = {kappa}"
                    )));
                }
                let lambda = alpha * alpha * (n + kappa) - n;
                let spread = n + lambda;
                if spread.is_nan() || spread <= 0.0 {
                    return Err(SettingsError(format!(
                        "the UKF parameters need alpha²·(n + kappa) > 0, got alpha = {alpha}, kappa = {kappa}, n = {dimension}"
                    )));
                }
                Ok(Self {
                    spread_root: spread.sqrt(),
                    mean_centre: lambda / spread,
                    covariance_centre: lambda / spread + 1.0 - alpha * alpha + beta,
                    outer: 1.0 / (2.0 * spread),
                    uses_centre: true,
                })
            }
        }
    }
}

/// The UKF of seed 000 (and the scaled variant of seed 001) on any [`StateSpaceModel`].
#[derive(Debug, Clone)]
pub struct UnscentedKalmanFilter<Model, const N: usize, const M: usize, const U: usize> {
    model: Model,
    points: SigmaPoints,
    weights: SigmaWeights,
    process_noise: SMatrix<f64, N, N>,
    measurement_noise: SMatrix<f64, M, M>,
    state: SVector<f64, N>,
    covariance: SMatrix<f64, N, N>,
    last_report: UpdateReport<M>,
}

impl<Model, const N: usize, const M: usize, const U: usize> UnscentedKalmanFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    /// A UKF on `model` with the sigma-point set `points`, starting from `initial`.
    pub fn new(
        model: Model,
        points: SigmaPoints,
        initial: &InitialEstimate<N>,
    ) -> Result<Self, SettingsError> {
        initial.validate()?;
        let (process_noise, measurement_noise) = validated_noise(&model)?;
        let weights = SigmaWeights::new(points, N)?;
        Ok(Self {
            model,
            points,
            weights,
            process_noise,
            measurement_noise,
            state: initial.state,
            covariance: initial.symmetric_covariance(),
            last_report: UpdateReport::skipped(),
        })
    }

    /// The sigma-point set in use.
    pub fn sigma_points(&self) -> SigmaPoints {
        self.points
    }

    /// The model the filter runs on.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The report of the last measurement update.
    pub fn last_report(&self) -> &UpdateReport<M> {
        &self.last_report
    }

    /// The sigma-point deviations `(√(c P))ᵢ` of the current `P` as columns, and whether `P`
    /// had to be repaired first (it is replaced by the repaired matrix then).
    ///
    /// `chol(c P) = √c · chol(P)`: factorising `P` itself keeps the (rare) repaired matrix a
    /// covariance without a division per entry on every step.
    fn draw(&mut self) -> Option<(SMatrix<f64, N, N>, bool)> {
        let factor = cholesky_with_repair(&self.covariance)?;
        let repaired = match factor.repaired {
            Some(repaired) => {
                self.covariance = repaired;
                true
            }
            None => false,
        };
        Some((factor.factor.lower() * self.weights.spread_root, repaired))
    }
}

impl<Model, const N: usize, const M: usize, const U: usize> Estimator<N, M, U>
    for UnscentedKalmanFilter<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    fn predict(&mut self, input: &SVector<f64, U>) -> Result<(), FilterIssue> {
        let previous_state = self.state;
        let previous_covariance = self.covariance;
        let Some((deviations, repaired)) = self.draw() else {
            self.covariance = previous_covariance + self.process_noise;
            return Err(FilterIssue::StateReset);
        };
        let w = self.weights;
        // Propagate every sigma point through f (000: 4.129-4.132).
        let mut plus = SMatrix::<f64, N, N>::zeros();
        let mut minus = SMatrix::<f64, N, N>::zeros();
        for i in 0..N {
            let deviation = deviations.column(i);
            plus.set_column(i, &self.model.transition(&(self.state + deviation), input));
            minus.set_column(i, &self.model.transition(&(self.state - deviation), input));
        }
        let centre = if w.uses_centre {
            self.model.transition(&self.state, input)
        } else {
            SVector::zeros()
        };
        // Weighted mean (000: 4.133) and covariance plus Q (000: 4.134).
        // As products over the deviation matrices (one column per point): cheaper than 2n
        // rank-one updates with temporaries.
        let mean = w.mean_centre * centre + w.outer * (plus.column_sum() + minus.column_sum());
        for i in 0..N {
            plus.set_column(i, &(plus.column(i) - mean));
            minus.set_column(i, &(minus.column(i) - mean));
        }
        let mut covariance = self.process_noise;
        add_weighted_gram(&mut covariance, w.outer, &plus, &minus);
        if w.uses_centre {
            add_weighted_outer(&mut covariance, w.covariance_centre, &(centre - mean));
        }
        self.state = mean;
        self.covariance = covariance;
        let outcome = finish_prediction(
            &mut self.state,
            &mut self.covariance,
            previous_state,
            previous_covariance,
            &self.process_noise,
        );
        match outcome {
            Ok(()) if repaired => Err(FilterIssue::CovarianceRepaired),
            other => other,
        }
    }

    fn update(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &MeasurementMask<M>,
    ) -> Result<UpdateReport<M>, FilterIssue> {
        let previous_state = self.state;
        let previous_covariance = self.covariance;
        // Fresh sigma points from the prior (000: 4.135-4.137).
        let Some((deviations, repaired)) = self.draw() else {
            self.last_report = UpdateReport::skipped();
            return Err(FilterIssue::StateReset);
        };
        let w = self.weights;
        // Their images under h (000: 4.138) and the predicted measurement (000: 4.139).
        let mut plus = SMatrix::<f64, M, N>::zeros();
        let mut minus = SMatrix::<f64, M, N>::zeros();
        for i in 0..N {
            let deviation = deviations.column(i);
            plus.set_column(i, &self.model.measurement(&(self.state + deviation), input));
            minus.set_column(i, &self.model.measurement(&(self.state - deviation), input));
        }
        let centre = if w.uses_centre {
            self.model.measurement(&self.state, input)
        } else {
            SVector::zeros()
        };
        let predicted = w.mean_centre * centre + w.outer * (plus.column_sum() + minus.column_sum());
        for i in 0..N {
            plus.set_column(i, &(plus.column(i) - predicted));
            minus.set_column(i, &(minus.column(i) - predicted));
        }
        // Innovation covariance (000: 4.140) and cross-covariance (000: 4.141); the centre
        // point's state deviation is zero, so it only enters S. The state deviations of the
        // `+`/`-` points are `±L`, so Pxy = w L (Y₊ - Y₋)ᵀ.
        let mut innovation_covariance = self.measurement_noise;
        add_weighted_gram(&mut innovation_covariance, w.outer, &plus, &minus);
        if w.uses_centre {
            add_weighted_outer(
                &mut innovation_covariance,
                w.covariance_centre,
                &(centre - predicted),
            );
        }
        let cross = product_transpose(&deviations, &(plus - minus)) * w.outer;
        let step = match masked_gain(cross, innovation_covariance, measurement, &predicted, mask) {
            Ok(Some(step)) => step,
            Ok(None) => {
                self.last_report = UpdateReport::skipped();
                return if repaired {
                    Err(FilterIssue::CovarianceRepaired)
                } else {
                    Ok(self.last_report)
                };
            }
            Err(issue) => {
                self.last_report = UpdateReport::skipped();
                return Err(issue);
            }
        };
        // K = Pxy S⁻¹ (000: 4.142), x̂⁺ = x̂⁻ + K (y - ŷ) (000: 4.143), P⁺ = P⁻ - K S Kᵀ (000: 4.144),
        // as x̂⁻ + W e and P⁻ - W Wᵀ.
        self.state += step.correction();
        subtract_gram(&mut self.covariance, &step.whitened_cross);
        let outcome = match keep_positive_definite(&mut self.covariance) {
            Some(repaired_now) if all_finite(&self.state) => {
                Ok((step.report, repaired_now || repaired))
            }
            _ => {
                self.state = previous_state;
                self.covariance = previous_covariance;
                Err(FilterIssue::StateReset)
            }
        };
        conclude_update(&mut self.last_report, outcome)
    }

    fn state(&self) -> &SVector<f64, N> {
        &self.state
    }

    fn covariance(&self) -> &SMatrix<f64, N, N> {
        &self.covariance
    }
}

/// In the registry: fully described by `(x̂, P)` and its settings (the default snapshot).
impl<Model, const N: usize, const M: usize, const U: usize>
    crate::running::RunningEstimator<N, M, U> for UnscentedKalmanFilter<Model, N, M, U>
where
    Model: crate::running::RegistryModel<N, M, U>,
{
    fn last_report(&self) -> UpdateReport<M> {
        self.last_report
    }

    /// `P` is this filter's own Gaussian: adding to it is a larger `Q` in the last prediction.
    fn inflate_covariance(&mut self, extra: &nalgebra::SMatrix<f64, N, N>) -> bool {
        self.covariance += extra;
        true
    }

    // `R + extra` for one update, in the innovation covariance (000: 4.140).
    super::update_with_r_plus_extra!();

    super::condition_on_own_gaussian!();
}
