//! Alignment of a log's signals to the estimator's communication grid.
//!
//! The grid: `t_n = t_0 + n h` (never accumulated), `t_0` the log's first time stamp, `h` the
//! map's `log.step` or else the median interval of the log's time stamps (the fastest channel
//! group of an MF4 file), up to the last time stamp.
//!
//! Each signal keeps only its present samples (a NaN, an empty CSV cell or an invalid MF4
//! sample is no sample: a slower channel in a CSV simply leaves the rows between its samples
//! empty). At `t_n` it gives
//! * `hold` (the default): the latest present sample at or before `t_n` — what an ECU reading
//!   the CAN bus at `t_n` has, causal, no look-ahead;
//! * `linear`: the straight line between the present samples just before and just after `t_n`
//!   (looks ahead by less than one sample interval: for offline analysis);
//!
//! and NaN — which the estimator FMU takes as "sample missing" and skips — when that sample is
//! *stale*: older than `stale_after` (for `linear`, when the two samples are further apart than
//! that). `stale_after` is the map's (per channel or log-wide), by default 2.5 times the median
//! interval between the signal's present samples: one lost message is bridged, two are a gap.

/// How a signal is read between its samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Alignment {
    Hold,
    Linear,
}

impl Alignment {
    pub fn from_name(name: &str) -> Option<Alignment> {
        match name {
            "hold" => Some(Alignment::Hold),
            "linear" => Some(Alignment::Linear),
            _ => None,
        }
    }
}

/// Stale limit when the map gives none, in median sample intervals.
pub const DEFAULT_STALE_INTERVALS: f64 = 2.5;

/// The communication grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub start: f64,
    pub step: f64,
    pub rows: usize,
}

impl Grid {
    /// From `start` to `end` (inclusive when it falls on the grid) every `step`.
    pub fn new(start: f64, end: f64, step: f64) -> Grid {
        let rows = ((end - start) / step * (1.0 + 1e-12)).floor() as usize + 1;
        Grid { start, step, rows }
    }

    pub fn time(&self, n: usize) -> f64 {
        self.start + n as f64 * self.step
    }

    pub fn times(&self) -> Vec<f64> {
        (0..self.rows).map(|n| self.time(n)).collect()
    }

    /// The rows whose time lies in `[from, to]`.
    pub fn rows_within(&self, from: f64, to: f64) -> std::ops::Range<usize> {
        let first = ((from - self.start) / self.step).ceil().max(0.0) as usize;
        let last = (((to - self.start) / self.step).floor().max(-1.0) + 1.0) as usize;
        first.min(self.rows)..last.min(self.rows)
    }
}

/// The median of the intervals between consecutive present samples; `None` with fewer than two.
pub fn median_interval(times: &[f64], values: &[f64]) -> Option<f64> {
    let present: Vec<f64> = times
        .iter()
        .zip(values)
        .filter(|(_, v)| v.is_finite())
        .map(|(t, _)| *t)
        .collect();
    let mut intervals: Vec<f64> = present.windows(2).map(|w| w[1] - w[0]).collect();
    if intervals.is_empty() {
        return None;
    }
    intervals.sort_by(f64::total_cmp);
    Some(intervals[intervals.len() / 2])
}

/// `values` at the times `times` read on `grid` (see the module text).
pub fn align(
    times: &[f64],
    values: &[f64],
    grid: &Grid,
    how: Alignment,
    stale_after: f64,
) -> Vec<f64> {
    let present: Vec<(f64, f64)> = times
        .iter()
        .zip(values)
        .filter(|(_, v)| v.is_finite())
        .map(|(t, v)| (*t, *v))
        .collect();
    // Time stamps within a millionth of a step of a grid point count as on it.
    let tolerance = grid.step * 1e-6;
    let mut next = 0usize;
    (0..grid.rows)
        .map(|n| {
            let t = grid.time(n);
            while next < present.len() && present[next].0 <= t + tolerance {
                next += 1;
            }
            let Some(&(t_before, v_before)) = next.checked_sub(1).map(|k| &present[k]) else {
                return f64::NAN;
            };
            match how {
                Alignment::Hold if t - t_before <= stale_after => v_before,
                Alignment::Linear => match present.get(next) {
                    _ if t - t_before <= tolerance => v_before,
                    Some(&(t_after, v_after)) if t_after - t_before <= stale_after => {
                        v_before + (v_after - v_before) * (t - t_before) / (t_after - t_before)
                    }
                    _ => f64::NAN,
                },
                Alignment::Hold => f64::NAN,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hold_and_linear_bridge_one_sample_and_mark_a_gap_missing() {
        let grid = Grid::new(0.0, 0.6, 0.1);
        assert_eq!(grid.rows, 7);
        // 0.2-s samples, one value missing at 0.4 (NaN) and none after 0.4.
        let times = [0.0, 0.2, 0.4];
        let values = [0.0, 2.0, f64::NAN];
        let held = align(&times, &values, &grid, Alignment::Hold, 0.25);
        assert_eq!(&held[..5], &[0.0, 0.0, 2.0, 2.0, 2.0]);
        assert!(held[5..].iter().all(|v| v.is_nan()), "{held:?}");
        let linear = align(&times, &values, &grid, Alignment::Linear, 0.25);
        assert!(
            (linear[1] - 1.0).abs() < 1e-12 && linear[2] == 2.0,
            "{linear:?}"
        );
        assert!(
            linear[3].is_nan(),
            "no sample after 0.2 within 0.25 s: {linear:?}"
        );
        let median = median_interval(&[0.0, 0.1, 0.3, 0.4], &[1.0; 4]).unwrap();
        assert!((median - 0.1).abs() < 1e-15, "{median}");
        assert_eq!(grid.rows_within(0.15, 0.4), 2..5);
    }
}
