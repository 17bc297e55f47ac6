//! Innovation-based adaptive process noise: the filter watches its own normalised innovations
//! and scales its process noise `Q` when they say the model is worse than `Q` claims.
//!
//! **What is watched.** The NIS `νᵀ S⁻¹ ν` of every update is chi-square with `m` degrees of
//! freedom (the rows used) when the filter is consistent. Over a moving window of the last `W`
//! updates the sum of the NIS is chi-square with the summed rows `D` as degrees of freedom
//! (independent innovations, Bar-Shalom, Li and Kirubarajan, *Estimation with Applications to
//! Tracking and Navigation*, 2001, §5.4.2), so the ratio `ρ = ΣNIS / D` lies inside the 95 %
//! band `[q(0.025, D)/D, q(0.975, D)/D]` 95 % of the time. The quantiles are Wilson and
//! Hilferty's cube-root approximation (1931), accurate to well under 1 % for `D ≥ 10`.
//!
//! **How `Q` adapts.** The scheme is covariance matching on the innovations (Mehra, "Approaches
//! to adaptive filtering", IEEE TAC 17, 1972; Mohamed and Schwarz, "Adaptive Kalman filtering
//! for INS/GPS", J. Geodesy 73, 1999): choose the noise so that the innovations' sample
//! covariance matches the one the filter predicts, `E[ν νᵀ] = S`. With one scale factor on the
//! process noise, `Q(k) = s(k) Q₀`, as in Bar-Shalom et al.'s continuous noise-level adjustment
//! (2001, §11.7.2), the match is `ρ = 1`; each update moves `s` by the factor `ρ^(1/W)`, so that
//! over one window `s` changes by about `ρ`:
//!
//! - `ρ` above the band (innovations larger than the filter believes): `s` grows;
//! - `ρ < 1` while `s > 1` (the inflated `Q` now over-explains the innovations): `s` shrinks,
//!   ten times more slowly (`ρ^(1/(10 W))` per update), because a model error that shows in the
//!   innovations only while excited still biases the unmeasured states afterwards;
//! - otherwise `s` holds (`1 ≤ ρ ≤` the upper band edge is consistent enough);
//!
//! bounded to `1 ≤ s ≤ s_max`, so the adaptation never makes the filter more confident than its
//! tuned `Q₀` and never lets `Q` run away. No decision is taken before the window is full.
//! The filter applies `s` by adding `(s − 1) Q₀` to its prior covariance after each prediction
//! ([`crate::running::RunningEstimator::inflate_covariance`]), which is the prediction with `s Q₀`.
//!
//! The scale and the window are part of the running state ([`NoiseAdaptation::save`]).

use nalgebra::SMatrix;

use crate::kalman::SettingsError;
use crate::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};
use crate::UpdateReport;

/// The settings of the adaptation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptationConfig {
    /// Updates in the moving window, at least 10 (the FMU: its window in seconds over its
    /// sample time).
    pub window: usize,
    /// The largest scale `s_max` of `Q`, at least 1.
    pub max_scale: f64,
}

impl AdaptationConfig {
    /// Checks the settings; the error names the one that is wrong.
    pub fn validate(&self) -> Result<(), SettingsError> {
        if !(MIN_WINDOW..=MAX_WINDOW).contains(&self.window) {
            return Err(SettingsError(format!(
                "adaptation window of {} updates; expected {MIN_WINDOW} to {MAX_WINDOW}",
                self.window
            )));
        }
        if !(self.max_scale.is_finite() && self.max_scale >= 1.0) {
            return Err(SettingsError(format!(
                "adaptation max scale {}; expected a finite value >= 1",
                self.max_scale
            )));
        }
        Ok(())
    }
}

/// Fewer updates than this make the window's band too wide to say anything.
pub const MIN_WINDOW: usize = 10;

/// The longest window, in updates (its ring is allocated when the filter is built).
pub const MAX_WINDOW: usize = 1_000_000;

/// What the last observed update said.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AdaptationStatus {
    /// The process noise is inflated by more than the window can resolve (`s` above the upper
    /// edge of the NIS ratio's band).
    pub adapting: bool,
    /// The window's NIS ratio is outside its 95 % band.
    pub inconsistent: bool,
}

/// The scale falls this many times slower than it rises (fast attack, slow release): a model
/// error that shows in the innovations only while it is excited (a tyre law that is wrong in a
/// transient but fits in steady cornering) still biases the estimate afterwards, so the
/// inflated `Q` is kept for about this many windows.
const RELEASE_WINDOWS: f64 = 10.0;

/// The 0.025 and 0.975 quantiles of the standard normal distribution.
const Z_975: f64 = 1.959_963_984_540_054;

/// Wilson-Hilferty: `q(p, d) ≈ d (1 − 2/(9d) + z_p √(2/(9d)))³`.
fn chi_square_quantile(z: f64, dof: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + z * a.sqrt()).powi(3)
}

/// The band of `ΣNIS / D` for `D` summed degrees of freedom.
pub fn nis_ratio_band(dof: f64) -> (f64, f64) {
    (
        chi_square_quantile(-Z_975, dof) / dof,
        chi_square_quantile(Z_975, dof) / dof,
    )
}

/// The monitor and the scale of `Q`: feed it every update's report, inflate the prior with
/// [`Self::inflation`] after every prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseAdaptation {
    config: AdaptationConfig,
    /// `(NIS, rows)` of the last updates, a ring; allocated once.
    window: Vec<(f64, f64)>,
    next: usize,
    filled: usize,
    nis_sum: f64,
    dof_sum: f64,
    scale: f64,
    status: AdaptationStatus,
}

impl NoiseAdaptation {
    pub fn new(config: AdaptationConfig) -> Result<Self, SettingsError> {
        config.validate()?;
        Ok(Self {
            config,
            window: vec![(0.0, 0.0); config.window],
            next: 0,
            filled: 0,
            nis_sum: 0.0,
            dof_sum: 0.0,
            scale: 1.0,
            status: AdaptationStatus::default(),
        })
    }

    /// The current scale `s` of `Q`.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The status after the last update.
    pub fn status(&self) -> AdaptationStatus {
        self.status
    }

    /// Takes one update's NIS into the window and moves the scale; an update that used no row
    /// says nothing and changes nothing.
    pub fn observe<const M: usize>(&mut self, report: &UpdateReport<M>) -> AdaptationStatus {
        if report.rows_used == 0 || !report.nis.is_finite() {
            return self.status;
        }
        self.push(report.nis, report.rows_used as f64);
        if self.filled < self.window.len() {
            return self.status;
        }
        let ratio = self.nis_sum / self.dof_sum;
        let (low, high) = nis_ratio_band(self.dof_sum);
        let updates = self.window.len() as f64;
        if ratio > high {
            self.scale = (self.scale * ratio.powf(1.0 / updates)).min(self.config.max_scale);
        } else if ratio < 1.0 && self.scale > 1.0 {
            let release = ratio.powf(1.0 / (RELEASE_WINDOWS * updates));
            self.scale = (self.scale * release).max(1.0);
        }
        // A scale within the band's width is not told apart from 1 by the window: only a larger
        // one counts as adapting (a consistent filter's scale wanders just above 1).
        self.status = AdaptationStatus {
            adapting: self.scale > high,
            inconsistent: !(low..=high).contains(&ratio),
        };
        self.status
    }

    /// Adds a sample to the ring; the sums are summed afresh each time the ring wraps, so
    /// rounding does not accumulate over a long run.
    fn push(&mut self, nis: f64, dof: f64) {
        let (old_nis, old_dof) = self.window[self.next];
        self.window[self.next] = (nis, dof);
        self.next = (self.next + 1) % self.window.len();
        self.filled = (self.filled + 1).min(self.window.len());
        if self.next == 0 {
            self.nis_sum = self.window.iter().map(|w| w.0).sum();
            self.dof_sum = self.window.iter().map(|w| w.1).sum();
        } else {
            self.nis_sum += nis - old_nis;
            self.dof_sum += dof - old_dof;
        }
    }

    /// What to add to the prior covariance after a prediction with `Q₀`: `(s − 1) Q₀`, or
    /// `None` while `s = 1`.
    pub fn inflation<const N: usize>(
        &self,
        process_noise: &SMatrix<f64, N, N>,
    ) -> Option<SMatrix<f64, N, N>> {
        (self.scale > 1.0).then(|| process_noise * (self.scale - 1.0))
    }

    /// Writes the running state (scale, window, position).
    pub fn save(&self, sink: &mut dyn SnapshotSink) {
        sink.f64(self.scale);
        sink.u64(self.next as u64);
        sink.u64(self.filled as u64);
        let (nis, dof): (Vec<f64>, Vec<f64>) = self.window.iter().copied().unzip();
        sink.f64s(&nis);
        sink.f64s(&dof);
        sink.f64(self.nis_sum);
        sink.f64(self.dof_sum);
        sink.bool(self.status.adapting);
        sink.bool(self.status.inconsistent);
    }

    /// Reads what [`Self::save`] wrote into an adaptation built with the same settings.
    pub fn restore(&mut self, source: &mut dyn SnapshotSource) -> Result<(), SnapshotError> {
        let length = self.window.len();
        let scale = source.f64("adaptation scale")?;
        let next = source.u64("adaptation position")? as usize;
        let filled = source.u64("adaptation fill")? as usize;
        if !(scale >= 1.0 && scale <= self.config.max_scale) || next >= length || filled > length {
            return Err(SnapshotError(format!(
                "adaptation state: scale {scale}, position {next}, fill {filled} do not fit a \
                 window of {length} with max scale {}",
                self.config.max_scale
            )));
        }
        let mut nis = vec![0.0; length];
        let mut dof = vec![0.0; length];
        source.f64s_into(&mut nis, "adaptation window NIS")?;
        source.f64s_into(&mut dof, "adaptation window rows")?;
        self.nis_sum = source.f64("adaptation NIS sum")?;
        self.dof_sum = source.f64("adaptation rows sum")?;
        self.status = AdaptationStatus {
            adapting: source.bool("adaptation adapting")?,
            inconsistent: source.bool("adaptation inconsistent")?,
        };
        self.window = nis.into_iter().zip(dof).collect();
        self.scale = scale;
        self.next = next;
        self.filled = filled;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{SMatrix, SVector};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    use super::*;
    use crate::kalman::{ExtendedKalmanFilter, InitialEstimate};
    use crate::running::RunningEstimator;
    use crate::{Estimator, StateSpaceModel};

    const T: f64 = 0.01;

    /// Position and velocity at constant velocity, the position measured; `Q = q · diag(T³/3, T)`
    /// roughly as a white acceleration would give, `R = r`.
    #[derive(Debug, Clone)]
    struct ConstantVelocity {
        q: f64,
        r: f64,
    }

    impl StateSpaceModel<2, 1, 1> for ConstantVelocity {
        fn state_names(&self) -> [&'static str; 2] {
            ["position", "velocity"]
        }
        fn measurement_names(&self) -> [&'static str; 1] {
            ["position"]
        }
        fn transition(&self, x: &SVector<f64, 2>, _: &SVector<f64, 1>) -> SVector<f64, 2> {
            SVector::<f64, 2>::new(x[0] + T * x[1], x[1])
        }
        fn transition_jacobian(
            &self,
            _: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 2, 2> {
            SMatrix::<f64, 2, 2>::new(1.0, T, 0.0, 1.0)
        }
        fn transition_input_jacobian(
            &self,
            _: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 2, 1> {
            SMatrix::<f64, 2, 1>::zeros()
        }
        fn measurement(&self, x: &SVector<f64, 2>, _: &SVector<f64, 1>) -> SVector<f64, 1> {
            SVector::<f64, 1>::new(x[0])
        }
        fn measurement_jacobian(
            &self,
            _: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 1, 2> {
            SMatrix::<f64, 1, 2>::new(1.0, 0.0)
        }
        fn measurement_input_jacobian(
            &self,
            _: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 1, 1> {
            SMatrix::<f64, 1, 1>::zeros()
        }
        fn process_noise(&self) -> SMatrix<f64, 2, 2> {
            SMatrix::<f64, 2, 2>::new(self.q * T * T * T / 3.0, 0.0, 0.0, self.q * T)
        }
        fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
            SMatrix::<f64, 1, 1>::new(self.r)
        }
    }

    /// What a run shows: the velocity's NEES averaged over the second half, the largest scale,
    /// the share of updates with the scale above 1.
    struct Outcome {
        velocity_nees: f64,
        max_scale: f64,
        adapting_share: f64,
    }

    /// Runs an EKF on the constant-velocity model against a truth whose acceleration is
    /// `acceleration(t)` plus the model's own process noise, with or without adaptation.
    fn run(acceleration: fn(f64) -> f64, adapt: bool) -> Outcome {
        let model = ConstantVelocity { q: 1e-4, r: 1e-4 };
        let initial = InitialEstimate::diagonal(SVector::zeros(), SVector::from([1e-4, 1e-4]));
        let mut filter = ExtendedKalmanFilter::new(model.clone(), &initial).unwrap();
        let config = AdaptationConfig {
            window: 50,
            max_scale: 1e6,
        };
        let mut adaptation = NoiseAdaptation::new(config).unwrap();
        let q = model.process_noise();
        let root_q = q.map(f64::sqrt);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
        let (mut truth, input) = (SVector::<f64, 2>::zeros(), SVector::<f64, 1>::zeros());
        let steps = 4000;
        let (mut nees_sum, mut max_scale, mut adapting) = (0.0, 1.0_f64, 0);
        for k in 0..steps {
            let t = k as f64 * T;
            let y = SVector::<f64, 1>::new(truth[0] + model.r.sqrt() * normal());
            let report = filter.update(&y, &input, &[true]).unwrap();
            if adapt {
                adaptation.observe(&report);
            }
            filter.predict(&input).unwrap();
            if let Some(extra) = adaptation.inflation(&q) {
                assert!(filter.inflate_covariance(&extra));
            }
            let noise = root_q * SVector::<f64, 2>::new(normal(), normal());
            truth = model.transition(&truth, &input)
                + SVector::<f64, 2>::new(0.5 * T * T, T) * acceleration(t)
                + noise;
            max_scale = max_scale.max(adaptation.scale());
            adapting += usize::from(adaptation.status().adapting);
            if k >= steps / 2 {
                let error = filter.state()[1] - truth[1];
                nees_sum += error * error / filter.covariance()[(1, 1)];
            }
        }
        Outcome {
            velocity_nees: nees_sum / (steps / 2) as f64,
            max_scale,
            adapting_share: adapting as f64 / steps as f64,
        }
    }

    /// An unmodelled acceleration of 2 m/s² changing with 0.5 Hz.
    fn manoeuvre(t: f64) -> f64 {
        2.0 * (std::f64::consts::PI * t).sin()
    }

    #[test]
    fn a_mismatched_model_grows_q_and_brings_the_nees_down() {
        let fixed = run(manoeuvre, false);
        let adapted = run(manoeuvre, true);
        assert!(
            fixed.velocity_nees > 50.0,
            "fixed Q NEES {}",
            fixed.velocity_nees
        );
        assert!(adapted.max_scale > 100.0, "scale {}", adapted.max_scale);
        assert!(
            adapted.velocity_nees < 3.0 && adapted.velocity_nees > 0.3,
            "adapted NEES {} (fixed {})",
            adapted.velocity_nees,
            fixed.velocity_nees
        );
    }

    #[test]
    fn a_matched_model_does_not_adapt() {
        let matched = run(|_| 0.0, true);
        assert!(matched.max_scale < 1.5, "scale {}", matched.max_scale);
        assert!(
            matched.adapting_share < 0.02,
            "adapting {}",
            matched.adapting_share
        );
        assert!(
            (0.7..1.3).contains(&matched.velocity_nees),
            "NEES {}",
            matched.velocity_nees
        );
    }

    #[test]
    fn the_band_is_the_chi_square_band() {
        // q(0.025, 100) = 74.22, q(0.975, 100) = 129.56 (tables).
        let (low, high) = nis_ratio_band(100.0);
        assert!((low * 100.0 - 74.22).abs() < 0.1, "{low}");
        assert!((high * 100.0 - 129.56).abs() < 0.1, "{high}");
    }

    #[test]
    fn save_and_restore_continue_bit_identically() {
        #[derive(Default)]
        struct Tape(Vec<f64>, Vec<bool>, usize, usize);
        impl SnapshotSink for Tape {
            fn u8(&mut self, v: u8) {
                self.0.push(f64::from(v));
            }
            fn u32(&mut self, v: u32) {
                self.0.push(f64::from(v));
            }
            fn u64(&mut self, v: u64) {
                self.0.push(v as f64);
            }
            fn f64(&mut self, v: f64) {
                self.0.push(v);
            }
            fn bool(&mut self, v: bool) {
                self.1.push(v);
            }
            fn bytes(&mut self, _: &[u8]) {
                unreachable!()
            }
            fn f64s(&mut self, v: &[f64]) {
                self.0.extend_from_slice(v);
            }
        }
        impl SnapshotSource for Tape {
            fn u8(&mut self, w: &str) -> Result<u8, SnapshotError> {
                Ok(SnapshotSource::f64(self, w)? as u8)
            }
            fn u32(&mut self, w: &str) -> Result<u32, SnapshotError> {
                Ok(SnapshotSource::f64(self, w)? as u32)
            }
            fn u64(&mut self, w: &str) -> Result<u64, SnapshotError> {
                Ok(SnapshotSource::f64(self, w)? as u64)
            }
            fn f64(&mut self, _: &str) -> Result<f64, SnapshotError> {
                self.2 += 1;
                Ok(self.0[self.2 - 1])
            }
            fn bool(&mut self, _: &str) -> Result<bool, SnapshotError> {
                self.3 += 1;
                Ok(self.1[self.3 - 1])
            }
            fn bytes(&mut self, _: &str) -> Result<Vec<u8>, SnapshotError> {
                unreachable!()
            }
            fn f64s(&mut self, _: &str, _: usize) -> Result<Vec<f64>, SnapshotError> {
                unreachable!()
            }
            fn f64s_into(&mut self, target: &mut [f64], w: &str) -> Result<(), SnapshotError> {
                for value in target.iter_mut() {
                    *value = SnapshotSource::f64(self, w)?;
                }
                Ok(())
            }
        }
        let config = AdaptationConfig {
            window: 12,
            max_scale: 100.0,
        };
        let mut original = NoiseAdaptation::new(config).unwrap();
        let report = |nis: f64| UpdateReport::<1> {
            innovation: SVector::zeros(),
            nis,
            rows_used: 1,
            used: [true],
        };
        for k in 0..30 {
            original.observe(&report(1.0 + 0.37 * k as f64));
        }
        assert!(original.scale() > 1.0);
        let mut tape = Tape::default();
        original.save(&mut tape);
        let mut restored = NoiseAdaptation::new(config).unwrap();
        restored.restore(&mut tape).unwrap();
        for k in 0..20 {
            let r = report(0.1 * k as f64);
            assert_eq!(original.observe(&r), restored.observe(&r));
        }
        assert_eq!(original, restored);
    }
}
