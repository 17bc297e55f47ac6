//! The reported covariance of a fixed-gain observer, scaled to what its innovations show.
//!
//! A Luenberger observer's gain is placed by its poles (002: §4), not computed from a
//! covariance, so the error covariance it propagates for that gain ([`crate::luenberger`],
//! Joseph form) holds only while its linear model is the car's. Against another car the
//! innovations are larger than that covariance predicts: over a moving window of the last `W`
//! updates the ratio `ρ = ΣNIS / D` (`D` the rows summed) leaves its 95 % chi-square band
//! ([`crate::adaptive::nis_ratio_band`]). The reported covariance is then `ρ P`: the
//! noise-level adjustment of Bar-Shalom, Li and Kirubarajan (*Estimation with Applications to
//! Tracking and Navigation*, 2001, §11.7.2), which scales the covariance until the innovations
//! fit it. For a Kalman filter that scale would move its gain and its estimate as well (and was
//! measured to cost accuracy there, `adaptive`); the observer's gain does not depend on its
//! covariance, so here it changes what the observer reports and nothing it estimates.
//!
//! While `ρ` lies inside the band the scale is 1, so an observer whose model is right (the
//! seeds' setups) reports its propagated covariance unchanged; no decision is taken before the
//! window is full.

use crate::adaptive::{
    nis_ratio_band, AdaptationStatus, MovingSum, Summable, MAX_WINDOW, MIN_WINDOW,
};
use crate::kalman::SettingsError;
use crate::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};
use crate::UpdateReport;

/// One update in the window: its NIS and the rows it used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Innovations {
    pub(crate) nis: f64,
    pub(crate) rows: f64,
}

impl Summable for Innovations {
    const ZERO: Self = Self {
        nis: 0.0,
        rows: 0.0,
    };

    fn add_scaled(&mut self, other: &Self, sign: f64) {
        self.nis += sign * other.nis;
        self.rows += sign * other.rows;
    }
}

/// The NIS values of the last updates and their sums: the window of the observer's scaling and
/// of the innovation monitor ([`crate::innovation_monitor`]), named `what` in its errors.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NisWindow {
    window: MovingSum<Innovations>,
    what: &'static str,
}

impl NisWindow {
    /// A window of `window` updates, [`MIN_WINDOW`] to [`MAX_WINDOW`].
    pub(crate) fn new(window: usize, what: &'static str) -> Result<Self, SettingsError> {
        if !(MIN_WINDOW..=MAX_WINDOW).contains(&window) {
            return Err(SettingsError(format!(
                "{what} window of {window} updates; expected {MIN_WINDOW} to {MAX_WINDOW}"
            )));
        }
        Ok(Self {
            window: MovingSum::new(window),
            what,
        })
    }

    /// Takes one update's NIS; an update that used no row (or a non-finite NIS) says nothing
    /// and is not taken (returns false).
    pub(crate) fn push<const M: usize>(&mut self, report: &UpdateReport<M>) -> bool {
        if report.rows_used == 0 || !report.nis.is_finite() {
            return false;
        }
        self.window.push(Innovations {
            nis: report.nis,
            rows: report.rows_used as f64,
        });
        true
    }

    /// The window's sums of NIS and rows, once every entry has been pushed.
    pub(crate) fn full_sum(&self) -> Option<&Innovations> {
        self.window.is_full().then(|| self.window.sum())
    }

    pub(crate) fn save(&self, sink: &mut dyn SnapshotSink) {
        self.window.save(sink, |entry, sink| {
            sink.f64(entry.nis);
            sink.f64(entry.rows);
        });
    }

    pub(crate) fn restore(&mut self, source: &mut dyn SnapshotSource) -> Result<(), SnapshotError> {
        let what = self.what;
        self.window.restore(source, what, |source| {
            Ok(Innovations {
                nis: source.f64(&format!("{what} NIS"))?,
                rows: source.f64(&format!("{what} rows"))?,
            })
        })
    }
}

/// The window of NIS values and the scale it gives.
#[derive(Debug, Clone, PartialEq)]
pub struct InnovationScaling {
    /// The last updates and their sums.
    window: NisWindow,
    scale: f64,
    status: AdaptationStatus,
}

impl InnovationScaling {
    /// A window of `window` updates, [`MIN_WINDOW`] to [`MAX_WINDOW`].
    pub fn new(window: usize) -> Result<Self, SettingsError> {
        Ok(Self {
            window: NisWindow::new(window, "innovation-scaling")?,
            scale: 1.0,
            status: AdaptationStatus::default(),
        })
    }

    /// The factor on the reported covariance, at least 1.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Takes one update's NIS into the window; an update that used no row says nothing.
    /// `adapting`: the scale is above 1; `inconsistent`: `ρ` is outside its band.
    pub fn observe<const M: usize>(&mut self, report: &UpdateReport<M>) -> AdaptationStatus {
        if !self.window.push(report) {
            return self.status;
        }
        let Some(sum) = self.window.full_sum() else {
            return self.status;
        };
        let ratio = sum.nis / sum.rows;
        let (low, high) = nis_ratio_band(sum.rows);
        self.scale = if ratio > high { ratio } else { 1.0 };
        self.status = AdaptationStatus {
            adapting: self.scale > 1.0,
            inconsistent: !(low..=high).contains(&ratio),
        };
        self.status
    }

    /// Writes the running state (window, position, fill, sums, scale, status).
    pub fn save(&self, sink: &mut dyn SnapshotSink) {
        self.window.save(sink);
        sink.f64(self.scale);
        sink.bool(self.status.adapting);
        sink.bool(self.status.inconsistent);
    }

    /// Reads what [`Self::save`] wrote into a scaling built with the same window.
    pub fn restore(&mut self, source: &mut dyn SnapshotSource) -> Result<(), SnapshotError> {
        self.window.restore(source)?;
        let scale = source.f64("innovation-scaling scale")?;
        if !(scale.is_finite() && scale >= 1.0) {
            return Err(SnapshotError(format!(
                "innovation-scaling scale {scale}; expected a finite value >= 1"
            )));
        }
        self.scale = scale;
        self.status = AdaptationStatus {
            adapting: source.bool("innovation-scaling adapting")?,
            inconsistent: source.bool("innovation-scaling inconsistent")?,
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MeasurementMask;
    use nalgebra::SVector;

    fn report(nis: f64, rows_used: usize) -> UpdateReport<2> {
        UpdateReport {
            innovation: SVector::zeros(),
            nis,
            rows_used,
            used: MeasurementMask::from([true; 2]),
        }
    }

    #[test]
    fn innovations_that_fit_the_covariance_leave_it_unscaled() {
        let mut scaling = InnovationScaling::new(50).unwrap();
        // NIS of two rows at its mean, 2: the ratio is 1, inside the band.
        for _ in 0..200 {
            let status = scaling.observe(&report(2.0, 2));
            assert!(!status.adapting && !status.inconsistent);
        }
        assert_eq!(scaling.scale(), 1.0);
    }

    #[test]
    fn innovations_larger_than_predicted_scale_the_covariance_by_their_ratio_and_release_it() {
        let mut scaling = InnovationScaling::new(50).unwrap();
        for _ in 0..49 {
            scaling.observe(&report(40.0, 2));
        }
        // No decision before the window is full.
        assert_eq!(scaling.scale(), 1.0);
        let status = scaling.observe(&report(40.0, 2));
        assert!(status.adapting && status.inconsistent);
        assert!((scaling.scale() - 20.0).abs() < 1e-9, "{}", scaling.scale());
        // Skipped updates say nothing.
        scaling.observe(&report(f64::NAN, 2));
        scaling.observe(&report(0.0, 0));
        assert!((scaling.scale() - 20.0).abs() < 1e-9);
        // A window of fitting innovations brings it back to 1.
        for _ in 0..50 {
            scaling.observe(&report(2.0, 2));
        }
        assert_eq!(scaling.scale(), 1.0);
    }

    #[test]
    fn innovations_smaller_than_predicted_are_inconsistent_but_never_shrink_the_covariance() {
        let mut scaling = InnovationScaling::new(50).unwrap();
        for _ in 0..60 {
            scaling.observe(&report(0.2, 2));
        }
        let status = scaling.observe(&report(0.2, 2));
        assert!(status.inconsistent && !status.adapting);
        assert_eq!(scaling.scale(), 1.0);
    }

    #[test]
    fn save_and_restore_continue_bit_identically() {
        let mut original = InnovationScaling::new(12).unwrap();
        for k in 0..30 {
            original.observe(&report(1.0 + 0.9 * k as f64, 2));
        }
        assert!(original.scale() > 1.0);
        let mut tape = crate::snapshot::Tape::default();
        original.save(&mut tape);
        let mut restored = InnovationScaling::new(12).unwrap();
        restored.restore(&mut tape).unwrap();
        for k in 0..20 {
            let r = report(0.3 * k as f64, 2);
            assert_eq!(original.observe(&r), restored.observe(&r));
        }
        assert_eq!(original, restored);
    }

    #[test]
    fn a_window_shorter_than_the_least_is_refused_by_name() {
        let error = InnovationScaling::new(3).unwrap_err();
        assert!(
            error.0.contains("innovation-scaling window of 3"),
            "{}",
            error.0
        );
    }
}
