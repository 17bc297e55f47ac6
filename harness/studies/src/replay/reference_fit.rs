//! Model B's tyre-stiffness level from the log's sideslip reference, where the log has one.
//!
//! **Why the reference.** In a quasi-steady drive the sensors model B reads (yaw rate, ay) fix
//! the balance of the axles' cornering stiffness (the understeer) and not its level: the FMU's
//! training NIS is nearly flat along `k_F = k_R`, while the held-out sideslip along that line
//! runs from 0.06° to 0.77° (harness/logs/README.md, "Why the sensors alone fit no tyre
//! factors of model B").
//! What pins the level is the quantity itself: a log from a test drive usually carries an
//! inertial reference with a sideslip channel (a GNSS-aided IMU or an optical sensor), and
//! calibrating the estimator to reproduce it on a training segment is what such a reference is
//! for. The held-out segment, which the fit never sees, says whether the level carries over.
//!
//! **Why one factor, not two.** Both factors `cornering_stiffness_scale_front/_rear` are
//! multiplied by one level `λ`, so their ratio (the map's or `--parameters`', 1:1 by default:
//! the HSRI law's stiffness at each axle's load) stays. Fitted freely, the two factors moved
//! along the narrow valley of the training RMSE that a segment of moderate lateral acceleration
//! leaves open, and the balance they chose did not carry over to the held-out segment's higher
//! lateral acceleration (measured with a Nelder-Mead simplex on the Ford Escort's,
//! BMW 320i's and VW Vanagon's drives, `--train 2:8 --validate 8:14`: training sideslip RMSE
//! 0.026-0.043° down to 0.012-0.016°, held-out 0.159 / 0.070 / 0.041° to 0.131 / 0.303 /
//! 0.263°). The level alone: 0.159 / 0.070 / 0.041° to 0.085 / 0.038 / 0.039°
//! (harness/logs/README.md, "Model B's tyre level from the sideslip reference").
//!
//! **How.** The training sideslip RMSE of FMU runs (from the log's first row, so that the filter
//! meets the training rows warm, as [`super::fit`] scores the held-out rows) is minimised over
//! `ln λ` by golden-section search on [`LEVEL_RANGE`] to [`LEVEL_TOLERANCE`]. The level is kept
//! only if it lowers the training RMSE; otherwise the map's factors stay. No random start: the
//! same log gives the same file.

use anyhow::{bail, Result};

use super::friction::golden_section;

/// Search range of the level `λ`: from 0.7 to 1.4 times the starting factors, wider than the
/// spread of passenger-car tyres around the HSRI law at the axle's load (the three CommonRoad
/// cars' Magic Formula cornering stiffness at the static load over the HSRI law: 0.97-1.09,
/// harness/logs/README.md).
pub const LEVEL_RANGE: (f64, f64) = (0.7, 1.4);
/// Width of the final bracket of `ln λ`: 0.2 %, finer than the held-out score resolves (a 2 %
/// step moves it by 0.005-0.06°).
pub const LEVEL_TOLERANCE: f64 = 2e-3;
/// The relative one-sigma uncertainty of the rear stiffness that the FMU's consider term
/// (`cornering_stiffness_uncertainty`, default 0.2 for a stiffness nobody measured; 0.25 when
/// this was measured) keeps once the level is fitted: the level that fits a training segment is not the one that fits a
/// drive beyond it (the held-out segments' own best levels lay 0-7 % from the fitted ones; the
/// BMW 320i's held-out 20-30 s at the limit wanted 0.96 against 1.034), and the reported
/// sideslip std must cover that. Measured on the three cars' drives, both splits
/// (harness/logs/README.md): held-out sideslip NEES 0.00-0.12 with 0.25, 0.02-0.72 with 0.1 (at
/// least 99 % of the samples inside the 95 % bound), while 0.05 gave 2.25 with 80 % inside on
/// the BMW's drive to the limit. The fit writes the smaller of this and the starting value.
pub const FITTED_LEVEL_UNCERTAINTY: f64 = 0.1;
/// Fewest finite reference samples the training segment must hold for a fit (one second at
/// 100 Hz: less is a transient, not a drive).
pub const MIN_REFERENCE_ROWS: usize = 100;

/// What the search found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelFit {
    /// `[k_F, k_R]` written to the .ssv (`λ` times the starting ones; the starting ones when
    /// no level lowered the training RMSE).
    pub scales: [f64; 2],
    /// The starting factors and the level found.
    pub start: [f64; 2],
    pub level: f64,
    /// Training sideslip RMSE (degrees) at the starting factors and at the fitted ones.
    pub rmse_start: f64,
    pub rmse: f64,
}

/// Why model B's tyre level was not fitted, or what the fit found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TyreFit {
    /// The map names no `reference.sideslip`, or it has fewer than [`MIN_REFERENCE_ROWS`] finite
    /// samples in the training segment.
    NoReference,
    Fitted(LevelFit),
}

impl TyreFit {
    pub fn summary(&self) -> String {
        match self {
            TyreFit::NoReference => "  tyre stiffness not fitted (the map names no reference.sideslip with samples in the training segment, and the sensors do not tell its level: harness/logs/README.md)\n".to_string(),
            TyreFit::Fitted(f) => format!(
                "  cornering_stiffness_scale_front = {:.4}, cornering_stiffness_scale_rear = {:.4} (level {:.4} on {:.4}, {:.4} by the training sideslip reference, RMSE {:.4} -> {:.4} deg)\n",
                f.scales[0], f.scales[1], f.level, f.start[0], f.start[1], f.rmse_start, f.rmse
            ),
        }
    }
}

/// Minimises `training_rmse([k_F, k_R])` over `λ` with `[k_F, k_R] = λ start` (module text).
/// `training_rmse` runs the FMU with the factors and returns the training sideslip RMSE; a
/// non-finite value (a run the filter could not follow) counts as the worst.
pub fn fit_level(
    start: [f64; 2],
    mut training_rmse: impl FnMut([f64; 2]) -> Result<f64>,
) -> Result<LevelFit> {
    let mut objective = |log_level: f64| -> Result<f64> {
        let value = training_rmse(start.map(|k| k * log_level.exp()))?;
        Ok(if value.is_finite() {
            value
        } else {
            f64::INFINITY
        })
    };
    let rmse_start = objective(0.0)?;
    if !rmse_start.is_finite() {
        bail!("the FMU with the starting tyre factors {start:?} gave no finite training sideslip; check the map's reference.sideslip and the car's data");
    }
    let (log_level, rmse) = golden_section(
        &mut objective,
        (LEVEL_RANGE.0.ln(), LEVEL_RANGE.1.ln()),
        LEVEL_TOLERANCE,
    )?;
    let level = if rmse < rmse_start {
        log_level.exp()
    } else {
        1.0
    };
    Ok(LevelFit {
        scales: start.map(|k| k * level),
        start,
        level,
        rmse_start,
        rmse: rmse.min(rmse_start),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_of_least_training_error_is_found_and_the_balance_kept() {
        // The training RMSE of the Ford Escort's 2-8 s along k_F = k_R (0.96-1.10: 0.074 ...
        // 0.013 at 1.06 ... 0.031), as a parabola in ln λ; the starting balance 1 : 1.05.
        let rmse = |k: [f64; 2]| -> Result<f64> {
            assert!((k[1] / k[0] - 1.05).abs() < 1e-12, "balance changed: {k:?}");
            Ok(0.013 + 6.0 * (k[0].ln() - 1.06f64.ln()).powi(2))
        };
        let fit = fit_level([1.0, 1.05], rmse).unwrap();
        assert!((fit.level - 1.06).abs() < 0.005, "{fit:?}");
        assert!((fit.scales[1] - 1.05 * fit.scales[0]).abs() < 1e-12);
        assert!(fit.rmse < fit.rmse_start);
    }

    #[test]
    fn no_gain_keeps_the_starting_factors_bit_for_bit() {
        let flat = |k: [f64; 2]| -> Result<f64> { Ok(0.2 + (k[0] - 0.9).powi(2)) };
        let fit = fit_level([0.9, 1.1], flat).unwrap();
        assert_eq!(fit.scales, [0.9, 1.1]);
        assert_eq!(fit.level, 1.0);
        assert_eq!(fit.rmse, fit.rmse_start);
    }

    #[test]
    fn a_run_the_filter_cannot_follow_counts_as_worst_and_a_failed_start_is_an_error() {
        let rmse = |k: [f64; 2]| -> Result<f64> {
            Ok(if k[0] > 1.2 {
                f64::NAN
            } else {
                0.1 + (k[0] - 0.8).powi(2)
            })
        };
        let fit = fit_level([1.0, 1.0], rmse).unwrap();
        assert!((fit.level - 0.8).abs() < 0.005, "{fit:?}");
        assert!(fit_level([1.0, 1.0], |_| Ok(f64::NAN)).is_err());
    }
}
