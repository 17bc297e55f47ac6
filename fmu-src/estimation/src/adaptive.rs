//! Innovation-based adaptive process noise: the filter watches its own corrections and
//! normalised innovations and raises the process noise of the states that its updates correct
//! by more than `Q` claims.
//!
//! **What is watched.** The corrections of every state (below), and for the status the NIS:
//! the NIS `νᵀ S⁻¹ ν` of every update is chi-square with `m` degrees of freedom (the rows used)
//! when the filter is consistent. Over a moving window of the last `W`
//! updates the sum of the NIS is chi-square with the summed rows `D` as degrees of freedom
//! (independent innovations, Bar-Shalom, Li and Kirubarajan, *Estimation with Applications to
//! Tracking and Navigation*, 2001, §5.4.2), so the ratio `ρ = ΣNIS / D` lies inside the 95 %
//! band `[q(0.025, D)/D, q(0.975, D)/D]` 95 % of the time. The quantiles are Wilson and
//! Hilferty's cube-root approximation (1931), accurate to well under 1 % for `D ≥ 10`.
//!
//! **How `Q` adapts.** Covariance matching, per state (Mohamed and Schwarz, "Adaptive Kalman
//! filtering for INS/GPS", J. Geodesy 73, 1999: the process noise estimated from the state
//! corrections `Δx = K ν` over a moving window, `Q̂_k = (1/W) Σ Δx Δxᵀ + P⁺_k − Φ P⁺_{k−1} Φᵀ`;
//! after Mehra, "Approaches to adaptive filtering", IEEE TAC 17, 1972). With the prior
//! `P⁻_k = Φ P⁺_{k−1} Φᵀ + Q₀` that is `Q̂ = Q₀ + (1/W) Σ (Δx Δxᵀ − (P⁻ − P⁺))`: the process
//! noise the filter was tuned with plus the excess of the corrections it actually made over
//! those its own covariance predicts (`E[Δx Δxᵀ] = K S Kᵀ = P⁻ − P⁺` when it is consistent).
//! A state whose model is wrong is corrected by more than predicted, and only that state's
//! noise grows; the well-modelled ones (wheel speeds, `vx` in a corner) keep their `Q₀`.
//!
//! The first scheme of this module, one scale on the whole `Q` driven by the windowed NIS
//! (Bar-Shalom et al.'s noise-level adjustment, §11.7.2), inflated every state when one row's
//! innovations grew (the wheel speeds under braking) and let the lateral states drift: 16-24 deg
//! sideslip RMSE on braking in a turn in the mismatch campaigns, and no row nearer its NEES
//! target. Here only the diagonal is kept (a sum of squares, so the added noise stays positive
//! semi-definite), and each state's excess is taken only when its windowed ratio
//! `ρ_i = Σ Δx_i² / Σ (P⁻ − P⁺)_ii` lies above the upper edge of the chi-square band of `W`
//! degrees of freedom (a consistent filter's ratio stays inside 97.5 % of the time, so its `Q`
//! is not changed by chance). The noise of state `i` is `s_i Q₀_ii` with
//!
//! `s_i = min(max(1 + excess_i / Q₀_ii, s_i,released), s_max)`, `s_i ≥ 1`,
//!
//! where `s_i,released` is the previous `s_i` decayed towards 1 by `exp(−1/(10 W))` per update:
//! the noise follows a larger correction at once and falls back over about ten windows, because
//! a model error that shows in the corrections only while excited still biases the unmeasured
//! states afterwards. No decision is taken before the window is full. The filter applies it by
//! adding `diag((s_i − 1) Q₀_ii)` to its prior covariance after each prediction
//! ([`crate::running::RunningEstimator::inflate_covariance`]).
//!
//! **Status.** `adapting`: some `s_i` is above 1; `inconsistent`: the windowed NIS ratio
//! `ΣNIS / D` is outside its band.
//!
//! The window, the scales and the status are part of the running state
//! ([`NoiseAdaptation::save`]).

use nalgebra::{SMatrix, SVector};

use crate::kalman::SettingsError;
use crate::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};
use crate::UpdateReport;

/// The settings of the adaptation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptationConfig {
    /// Updates in the moving window, at least 10 (the FMU: its window in seconds over its
    /// sample time).
    pub window: usize,
    /// The largest scale `s_max` of a state's process noise, at least 1.
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
    /// Some state's process noise is inflated (`s_i > 1`).
    pub adapting: bool,
    /// The window's NIS ratio is outside its 95 % band.
    pub inconsistent: bool,
}

/// A raised noise decays back to `Q₀` over about this many windows (fast attack, slow
/// release): a model error that shows in the corrections only while it is excited (a tyre law
/// that is wrong in a transient but fits in steady cornering) still biases the estimate
/// afterwards.
const RELEASE_WINDOWS: f64 = 10.0;

/// The 0.025 and 0.975 quantiles of the standard normal distribution.
const Z_975: f64 = 1.959_963_984_540_054;

/// The 0.9995 quantile of the standard normal distribution: the gate of a state's correction
/// ratio. The windowed ratio of a consistent filter moves slowly (consecutive windows share all
/// but one update), so a 97.5 % gate is crossed in long stretches and, against a state whose
/// `Q₀` is tiny beside the variance its updates remove (a position beside its velocity), the
/// excess of such a stretch is many times `Q₀`.
const Z_9995: f64 = 3.290_526_731_491_926;

/// Wilson-Hilferty: `q(p, d) ≈ d (1 − 2/(9d) + z_p √(2/(9d)))³`.
pub(crate) fn chi_square_quantile(z: f64, dof: f64) -> f64 {
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

/// What one measurement update did to the state, per state: the squared correction `Δx_i²`
/// (`x⁺ − x⁻`) and the variance the filter removed, `(P⁻ − P⁺)_ii`, which is what it expects
/// `Δx_i²` to be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correction<const N: usize> {
    pub squared: SVector<f64, N>,
    pub expected: SVector<f64, N>,
}

impl<const N: usize> Correction<N> {
    /// From the estimate and covariance before (`x⁻`, `P⁻`) and after (`x⁺`, `P⁺`) an update.
    pub fn between(
        prior: (&SVector<f64, N>, &SMatrix<f64, N, N>),
        posterior: (&SVector<f64, N>, &SMatrix<f64, N, N>),
    ) -> Self {
        Self {
            squared: (posterior.0 - prior.0).map(|d| d * d),
            expected: (prior.1.diagonal() - posterior.1.diagonal()).map(|v| v.max(0.0)),
        }
    }

    fn is_finite(&self) -> bool {
        self.squared
            .iter()
            .chain(self.expected.iter())
            .all(|v| v.is_finite())
    }
}

/// One update in the window.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry<const N: usize> {
    nis: f64,
    rows: f64,
    correction: Correction<N>,
}

impl<const N: usize> Summable for Entry<N> {
    const ZERO: Self = Self {
        nis: 0.0,
        rows: 0.0,
        correction: Correction {
            squared: SVector::from_array_storage(nalgebra::ArrayStorage([[0.0; N]; 1])),
            expected: SVector::from_array_storage(nalgebra::ArrayStorage([[0.0; N]; 1])),
        },
    };

    fn add_scaled(&mut self, other: &Self, sign: f64) {
        self.nis += sign * other.nis;
        self.rows += sign * other.rows;
        self.correction.squared += other.correction.squared * sign;
        self.correction.expected += other.correction.expected * sign;
    }
}

/// An entry of a [`MovingSum`]: it adds to and subtracts from the window's sum.
pub(crate) trait Summable: Copy {
    /// The sum of no entry.
    const ZERO: Self;
    /// `self += sign · other`, field by field.
    fn add_scaled(&mut self, other: &Self, sign: f64);
}

/// The last `len` entries (a ring, allocated once) and their sum, which is summed afresh each
/// time the ring wraps, so rounding does not accumulate over a long run: the window of the
/// adaptive process noise and of the observer's innovation scaling
/// ([`crate::innovation_scaling`]).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MovingSum<E> {
    ring: Vec<E>,
    next: usize,
    filled: usize,
    sum: E,
}

impl<E: Summable> MovingSum<E> {
    pub(crate) fn new(len: usize) -> Self {
        Self {
            ring: vec![E::ZERO; len],
            next: 0,
            filled: 0,
            sum: E::ZERO,
        }
    }

    /// The window's length in entries.
    pub(crate) fn len(&self) -> usize {
        self.ring.len()
    }

    /// Every entry of the window has been pushed at least once.
    pub(crate) fn is_full(&self) -> bool {
        self.filled == self.ring.len()
    }

    /// The sum of the entries in the window.
    pub(crate) fn sum(&self) -> &E {
        &self.sum
    }

    /// Adds `entry`, replacing the oldest once the window is full.
    pub(crate) fn push(&mut self, entry: E) {
        let old = std::mem::replace(&mut self.ring[self.next], entry);
        self.next = (self.next + 1) % self.ring.len();
        self.filled = (self.filled + 1).min(self.ring.len());
        if self.next == 0 {
            self.sum = E::ZERO;
            for e in &self.ring {
                self.sum.add_scaled(e, 1.0);
            }
        } else {
            self.sum.add_scaled(&entry, 1.0);
            self.sum.add_scaled(&old, -1.0);
        }
    }

    /// Writes the position, the fill, every entry and the sum (each by `write`).
    pub(crate) fn save(
        &self,
        sink: &mut dyn SnapshotSink,
        write: impl Fn(&E, &mut dyn SnapshotSink),
    ) {
        sink.u64(self.next as u64);
        sink.u64(self.filled as u64);
        for entry in self.ring.iter().chain(std::iter::once(&self.sum)) {
            write(entry, sink);
        }
    }

    /// Reads what [`Self::save`] wrote into a window of the same length; `what` names the
    /// owner in the error and in the values read.
    pub(crate) fn restore(
        &mut self,
        source: &mut dyn SnapshotSource,
        what: &str,
        read: impl Fn(&mut dyn SnapshotSource) -> Result<E, SnapshotError>,
    ) -> Result<(), SnapshotError> {
        let length = self.ring.len();
        let next = source.u64(&format!("{what} position"))? as usize;
        let filled = source.u64(&format!("{what} fill"))? as usize;
        if next >= length || filled > length {
            return Err(SnapshotError(format!(
                "{what} state: position {next}, fill {filled} do not fit a window of {length}"
            )));
        }
        for entry in self.ring.iter_mut().chain(std::iter::once(&mut self.sum)) {
            *entry = read(source)?;
        }
        self.next = next;
        self.filled = filled;
        Ok(())
    }
}

/// The monitor and the per-state scales of `Q`: feed it every update's report and correction,
/// inflate the prior with [`Self::inflation`] after every prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseAdaptation<const N: usize> {
    config: AdaptationConfig,
    /// The last updates and the sums of every field of [`Entry`].
    window: MovingSum<Entry<N>>,
    /// `s_i`: state `i`'s process noise is `s_i Q₀_ii`.
    scales: SVector<f64, N>,
    status: AdaptationStatus,
}

impl<const N: usize> NoiseAdaptation<N> {
    pub fn new(config: AdaptationConfig) -> Result<Self, SettingsError> {
        config.validate()?;
        Ok(Self {
            config,
            window: MovingSum::new(config.window),
            scales: SVector::repeat(1.0),
            status: AdaptationStatus::default(),
        })
    }

    /// The largest scale `s_i` of the states' process noise.
    pub fn scale(&self) -> f64 {
        self.scales.max()
    }

    /// Every state's scale `s_i`.
    pub fn scales(&self) -> &SVector<f64, N> {
        &self.scales
    }

    /// The status after the last update.
    pub fn status(&self) -> AdaptationStatus {
        self.status
    }

    /// Takes one update's NIS and correction into the window and moves the scales of
    /// `process_noise` (`Q₀`); an update that used no row says nothing and changes nothing.
    pub fn observe<const M: usize>(
        &mut self,
        report: &UpdateReport<M>,
        correction: &Correction<N>,
        process_noise: &SMatrix<f64, N, N>,
    ) -> AdaptationStatus {
        if report.rows_used == 0 || !report.nis.is_finite() || !correction.is_finite() {
            return self.status;
        }
        self.window.push(Entry {
            nis: report.nis,
            rows: report.rows_used as f64,
            correction: *correction,
        });
        if !self.window.is_full() {
            return self.status;
        }
        let sum = *self.window.sum();
        let updates = self.window.len() as f64;
        let high = chi_square_quantile(Z_9995, updates) / updates;
        let release = (-1.0 / (RELEASE_WINDOWS * updates)).exp();
        for i in 0..N {
            let (made, expected) = (sum.correction.squared[i], sum.correction.expected[i]);
            let q0 = process_noise[(i, i)];
            let released = 1.0 + (self.scales[i] - 1.0) * release;
            let matched = if made > high * expected && q0 > 0.0 {
                1.0 + (made - expected) / (updates * q0)
            } else {
                1.0
            };
            self.scales[i] = matched.max(released).min(self.config.max_scale);
        }
        let ratio = sum.nis / sum.rows;
        let (low, high) = nis_ratio_band(sum.rows);
        self.status = AdaptationStatus {
            adapting: self.scales.iter().any(|&s| s > 1.0),
            inconsistent: !(low..=high).contains(&ratio),
        };
        self.status
    }

    /// What to add to the prior covariance after a prediction with `Q₀`:
    /// `diag((s_i − 1) Q₀_ii)`, or `None` while every `s_i = 1`.
    pub fn inflation(&self, process_noise: &SMatrix<f64, N, N>) -> Option<SMatrix<f64, N, N>> {
        (self.scale() > 1.0).then(|| {
            let extra = process_noise
                .diagonal()
                .component_mul(&self.scales.add_scalar(-1.0));
            SMatrix::from_diagonal(&extra)
        })
    }

    /// Writes the running state (scales, window, position, sums, status).
    pub fn save(&self, sink: &mut dyn SnapshotSink) {
        sink.f64s(self.scales.as_slice());
        self.window.save(sink, |entry, sink| {
            sink.f64(entry.nis);
            sink.f64(entry.rows);
            sink.f64s(entry.correction.squared.as_slice());
            sink.f64s(entry.correction.expected.as_slice());
        });
        sink.bool(self.status.adapting);
        sink.bool(self.status.inconsistent);
    }

    /// Reads what [`Self::save`] wrote into an adaptation built with the same settings.
    pub fn restore(&mut self, source: &mut dyn SnapshotSource) -> Result<(), SnapshotError> {
        let mut scales = SVector::<f64, N>::zeros();
        source.f64s_into(scales.as_mut_slice(), "adaptation scales")?;
        let max = self.config.max_scale;
        if !scales.iter().all(|s| (1.0..=max).contains(s)) {
            return Err(SnapshotError(format!(
                "adaptation state: scales {:?} do not fit a max scale of {max}",
                scales.as_slice()
            )));
        }
        self.window.restore(source, "adaptation", |source| {
            let mut entry = Entry::<N>::ZERO;
            entry.nis = source.f64("adaptation NIS")?;
            entry.rows = source.f64("adaptation rows")?;
            let c = &mut entry.correction;
            source.f64s_into(c.squared.as_mut_slice(), "adaptation corrections")?;
            source.f64s_into(c.expected.as_mut_slice(), "adaptation expected corrections")?;
            Ok(entry)
        })?;
        self.status = AdaptationStatus {
            adapting: source.bool("adaptation adapting")?,
            inconsistent: source.bool("adaptation inconsistent")?,
        };
        self.scales = scales;
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
            let (prior, prior_p) = (*filter.state(), *filter.covariance());
            let report = filter.update(&y, &input, &[true]).unwrap();
            if adapt {
                let posterior = (filter.state(), filter.covariance());
                let correction = Correction::between((&prior, &prior_p), posterior);
                adaptation.observe(&report, &correction, &q);
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

    /// The acceleration is a deterministic error, not the white noise the match assumes: the
    /// per-state match takes the velocity's noise to about the size of its corrections (scale
    /// above 100) and the NEES down by two orders of magnitude, not to 1 (measured 6690 -> 50;
    /// the first scheme, one scale on `Q` driven by the NIS, reached about 1 here, and on the
    /// vehicle's campaigns inflated the well-modelled states with the rest).
    #[test]
    fn a_mismatched_model_grows_q_and_brings_the_nees_down() {
        let fixed = run(manoeuvre, false);
        let adapted = run(manoeuvre, true);
        assert!(
            fixed.velocity_nees > 1000.0,
            "fixed Q NEES {}",
            fixed.velocity_nees
        );
        assert!(adapted.max_scale > 100.0, "scale {}", adapted.max_scale);
        assert!(
            adapted.velocity_nees < fixed.velocity_nees / 50.0,
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
        let config = AdaptationConfig {
            window: 12,
            max_scale: 100.0,
        };
        let mut original = NoiseAdaptation::<2>::new(config).unwrap();
        let report = |nis: f64| UpdateReport::<1> {
            innovation: SVector::zeros(),
            nis,
            rows_used: 1,
            used: [true],
        };
        let q = SMatrix::<f64, 2, 2>::from_diagonal(&SVector::from([1e-4, 2e-4]));
        let correction = |k: f64| Correction {
            squared: SVector::from([1e-3 * k, 1e-5 * k]),
            expected: SVector::from([1e-4, 1e-4]),
        };
        for k in 0..30 {
            let k = k as f64;
            original.observe(&report(1.0 + 0.37 * k), &correction(k), &q);
        }
        assert!(original.scale() > 1.0);
        let mut tape = crate::snapshot::Tape::default();
        original.save(&mut tape);
        let mut restored = NoiseAdaptation::new(config).unwrap();
        restored.restore(&mut tape).unwrap();
        for k in 0..20 {
            let (r, c) = (report(0.1 * k as f64), correction(30.0 - k as f64));
            assert_eq!(original.observe(&r, &c, &q), restored.observe(&r, &c, &q));
        }
        assert_eq!(original, restored);
    }
}
