//! What every estimator offers, so that a caller (the FMU, the harness, a test) can switch between
//! them at run time without knowing which one it holds.

use nalgebra::{SMatrix, SVector};

/// Which measurement rows are present in one sample. A row is missing when its mask entry is
/// `false` or its value is not finite (NaN sensor data): the filter skips that row instead of
/// feeding garbage into the update (SPEC §6).
pub type MeasurementMask<const M: usize> = [bool; M];

/// What one measurement update reports about its own consistency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateReport<const M: usize> {
    /// Innovation `y - h(x⁻, u)`; zero in the rows that were skipped.
    pub innovation: SVector<f64, M>,
    /// Normalised innovation squared `νᵀ S⁻¹ ν` over the rows used (chi-square with `rows_used`
    /// degrees of freedom when the filter is consistent); 0 when no row was used.
    pub nis: f64,
    /// How many measurement rows entered the update.
    pub rows_used: usize,
    /// Which rows entered the update.
    pub used: MeasurementMask<M>,
}

impl<const M: usize> UpdateReport<M> {
    /// The report of an update in which every row was missing: nothing changed.
    pub fn skipped() -> Self {
        Self {
            innovation: SVector::zeros(),
            nis: 0.0,
            rows_used: 0,
            used: [false; M],
        }
    }
}

/// Something went wrong numerically and the estimator had to repair itself. Never fatal: the
/// estimate stays finite, the caller gets to know (the FMU maps this to its `status` output).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FilterIssue {
    #[error("the covariance was not positive definite and was repaired")]
    CovarianceRepaired,
    #[error("the innovation covariance was singular; the update was skipped")]
    UpdateSkipped,
    #[error("the state became non-finite and was reset to the last finite estimate")]
    StateReset,
    #[error("all particle weights vanished; the particle weights were reset to uniform")]
    WeightsReset,
}

/// One recursive state estimator with `N` states, `M` measurements and `U` inputs.
///
/// Timing convention (000: 4.64-4.75): `predict(u(k))` moves the estimate from `k` to `k+1`
/// using the input applied over that interval, then `update(y(k+1), u(k+1), mask)` corrects it
/// with the measurement taken at `k+1` (whose feed-through uses the input at `k+1`).
pub trait Estimator<const N: usize, const M: usize, const U: usize> {
    /// Time update with the input applied during the coming sample interval.
    fn predict(&mut self, input: &SVector<f64, U>) -> Result<(), FilterIssue>;

    /// Measurement update; rows that are masked out or not finite are skipped.
    fn update(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &MeasurementMask<M>,
    ) -> Result<UpdateReport<M>, FilterIssue>;

    /// The current state estimate (always finite).
    fn state(&self) -> &SVector<f64, N>;

    /// The current error covariance (symmetric positive semi-definite; for the particle filter,
    /// the weighted sample covariance).
    fn covariance(&self) -> &SMatrix<f64, N, N>;
}
