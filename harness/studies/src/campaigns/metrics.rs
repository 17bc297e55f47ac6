//! Figures read off a recorded run, shared by the robustness cases and the mismatch campaigns:
//! errors against the truth, the estimator's consistency, the status bits it raised.

use anyhow::{anyhow, Result};

use fmi_master::cosim::RunResult;
use fmi_master::scoring::chi_square_quantile;
use model_description::docs::STATUS_BITS;

/// The recorded column `instance.variable`.
pub fn column<'a>(result: &'a RunResult, instance: &str, variable: &str) -> Result<&'a [f64]> {
    result
        .column(&format!("{instance}.{variable}"))
        .ok_or_else(|| {
            anyhow!(
                "run {}: no recorded column '{instance}.{variable}'",
                result.scenario
            )
        })
}

/// Root mean square of the finite values (0 for none).
pub fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, count) = values
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    if count == 0 {
        0.0
    } else {
        (sum / count as f64).sqrt()
    }
}

/// One estimate against its truth over a run: `estimate - truth` and the reported one-sigma,
/// scored on the samples of `mask`; an angle's differences are wrapped into (-pi, pi].
pub struct Track<'a> {
    pub times: &'a [f64],
    pub truth: &'a [f64],
    pub estimate: &'a [f64],
    pub std: &'a [f64],
    pub mask: Vec<bool>,
    pub angle: bool,
}

/// Sideslip is scored only where the true speed is at least this: at a standstill the true
/// atan2(vy, vx) is that of two noise-sized numbers, any value between -180 and 180 deg.
pub const SIDESLIP_MIN_SPEED: f64 = 2.0;

/// The speed requirement: with the torques unknown, vx within 2 % of the true speed.
pub const SPEED_LIMIT: f64 = 0.02;

/// Below this true speed, m/s, a relative speed error is meaningless and not scored.
pub const RELATIVE_SPEED_FLOOR: f64 = 2.0;

impl<'a> Track<'a> {
    /// `variable` of the truth (`vehicle`) with `variable_est` and `variable_std` of `estimator`,
    /// every sample scored.
    pub fn of(
        result: &'a RunResult,
        vehicle: &str,
        estimator: &str,
        variable: &str,
    ) -> Result<Self> {
        let truth = column(result, vehicle, variable)?;
        Ok(Track {
            times: &result.times,
            truth,
            estimate: column(result, estimator, &format!("{variable}_est"))?,
            std: column(result, estimator, &format!("{variable}_std"))?,
            mask: vec![true; truth.len()],
            angle: false,
        })
    }

    /// The sideslip angle, scored where the true |vx| is at least [`SIDESLIP_MIN_SPEED`].
    pub fn sideslip(result: &'a RunResult, vehicle: &str, estimator: &str) -> Result<Self> {
        let speed = column(result, vehicle, "vx")?;
        let mut track = Track::of(result, vehicle, estimator, "sideslip")?;
        track.mask = speed
            .iter()
            .map(|v| v.abs() >= SIDESLIP_MIN_SPEED)
            .collect();
        track.angle = true;
        Ok(track)
    }

    /// `a - b`, wrapped for an angle.
    pub fn difference(&self, a: f64, b: f64) -> f64 {
        let d = a - b;
        if self.angle {
            let turn = std::f64::consts::TAU;
            d - turn * (d / turn).round()
        } else {
            d
        }
    }

    pub fn error(&self, k: usize) -> f64 {
        self.difference(self.estimate[k], self.truth[k])
    }

    /// Scored sample indices at or after `t`.
    pub fn from_time(&self, t: f64) -> impl Iterator<Item = usize> + '_ {
        let first = self.times.partition_point(|&time| time < t - 1e-9);
        (first..self.times.len()).filter(|&k| self.mask[k])
    }

    /// Root mean square error over the scored samples where both are finite.
    pub fn rmse(&self) -> f64 {
        rms(self.from_time(f64::NEG_INFINITY).map(|k| self.error(k)))
    }

    /// RMS of the truth over the scored samples: the RMSE of reporting zero.
    pub fn zero_baseline(&self) -> f64 {
        rms(self.from_time(f64::NEG_INFINITY).map(|k| self.truth[k]))
    }

    /// Largest |error| from `t` on; infinite when an estimate there is not finite.
    pub fn max_error_from(&self, t: f64) -> f64 {
        self.from_time(t).fold(0.0, |m: f64, k| {
            let e = self.error(k).abs();
            if e.is_nan() {
                f64::INFINITY
            } else {
                m.max(e)
            }
        })
    }

    /// Largest |error| / |truth| from `t` on where |truth| >= `floor` (a relative error is
    /// meaningless near zero); infinite for a non-finite estimate there.
    pub fn max_relative_error_from(&self, t: f64, floor: f64) -> f64 {
        self.from_time(t)
            .filter(|&k| self.truth[k].abs() >= floor)
            .fold(0.0f64, |m, k| {
                let e = (self.error(k) / self.truth[k]).abs();
                if e.is_nan() {
                    f64::INFINITY
                } else {
                    m.max(e)
                }
            })
    }

    /// Whether every estimate and std is finite.
    pub fn all_finite(&self) -> bool {
        self.estimate.iter().chain(self.std).all(|v| v.is_finite())
    }

    /// Time-averaged NEES e²/σ² (1 degree of freedom) and the share of samples with e²/σ²
    /// inside the chi-square(1) 95 % bound 3.84, over the samples with finite values and σ > 0.
    /// A sample with a non-finite estimate counts as outside.
    pub fn consistency(&self) -> (f64, f64) {
        self.consistency_from(f64::NEG_INFINITY)
    }

    /// [`Self::consistency`] over the scored samples from time `t` on.
    pub fn consistency_from(&self, t: f64) -> (f64, f64) {
        let bound = chi_square_quantile(0.95, 1.0);
        let (mut sum, mut used, mut inside, mut total) = (0.0, 0usize, 0usize, 0usize);
        for k in self.from_time(t) {
            if !self.truth[k].is_finite() {
                continue;
            }
            total += 1;
            let (e, s) = (self.error(k), self.std[k]);
            if e.is_finite() && s.is_finite() && s > 0.0 {
                let nees = e * e / (s * s);
                sum += nees;
                used += 1;
                inside += usize::from(nees <= bound);
            }
        }
        let mean = if used == 0 {
            f64::NAN
        } else {
            sum / used as f64
        };
        (mean, inside as f64 / total.max(1) as f64)
    }
}

/// The estimator's `status` bits raised anywhere in the run, OR-ed.
pub fn status_seen(result: &RunResult, estimator: &str) -> Result<u32> {
    Ok(column(result, estimator, "status")?
        .iter()
        .filter(|v| v.is_finite() && **v >= 0.0)
        .fold(0u32, |bits, &v| bits | v as u32))
}

/// `bits` as "value (name, name)", or "0" when none is set.
pub fn describe_status(bits: u32) -> String {
    if bits == 0 {
        return "0".into();
    }
    let names: Vec<&str> = STATUS_BITS
        .iter()
        .filter(|(bit, _, _)| bits & bit != 0)
        .map(|(_, name, _)| *name)
        .collect();
    format!("{bits} ({})", names.join(", "))
}
