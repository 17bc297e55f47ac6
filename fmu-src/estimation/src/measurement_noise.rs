//! Each measurement row's noise variance learned online from the filter's innovations, floored
//! by the variance the filter was tuned with.
//!
//! **Why.** A sensor's data-sheet noise is not what it measures in a car: an accelerometer on a
//! vibrating body reads the cornering acceleration plus 1-4 m/s² RMS of vibration, where the
//! default assumes 0.1 m/s². With too small an `R` the filter trusts every vibration, the gate
//! throws out the sensor's real peaks as outliers, and the reported standard deviation shrinks
//! below the error.
//!
//! **How.** Innovation-based covariance matching (Mehra, "On the identification of variances
//! and adaptive Kalman filtering", IEEE TAC 15(2), 1970, and "Approaches to adaptive filtering",
//! IEEE TAC 17(5), 1972; Mohamed and Schwarz, "Adaptive Kalman filtering for INS/GPS",
//! J. Geodesy 73, 1999, eq. 25): for a consistent filter the innovation `ν` of row `i` is white
//! with the variance `S_ii = (H P⁻ Hᵀ)_ii + R_ii`, so `R̂_ii = E[ν²] − (H P⁻ Hᵀ)_ii`. On a car
//! the innovations also hold the model's error, which is not white: a tyre law that is not the
//! car's gives the `ay` row an offset that lasts through a corner, and taken into `R` it would
//! switch the accelerometer off exactly where it carries the sideslip (measured on the MBDS
//! recording: model A's sideslip drifted to 70° with `ν²` matching). So the variance is taken
//! from successive differences of the innovations, `E[(ν_k − ν_{k−1})²] = S_k + S_{k−1}` for
//! white innovations, in which a slowly varying model error cancels: the mean square successive
//! difference (von Neumann, "Distribution of the ratio of the mean square successive difference
//! to the variance", Ann. Math. Stat. 12, 1941; as a noise-variance estimator beside a smooth
//! signal, Rice, "Bandwidth choice for nonparametric regression", Ann. Stat. 12, 1984). The
//! expectation is a moving average, exponentially weighted with the time constant `τ` (weight
//! `α = T / τ` per sample, a window of about `τ / T` samples), `p = (H P⁻ Hᵀ)_ii`:
//!
//! `R̂ ← (1 − α) R̂ + α (Δν_c² / 2 − (p_k + p_{k−1}) / 2)`,
//!
//! and the filter uses `max(R₀, R̂)`, never less than the tuned `R₀`: the learner only ever
//! says a sensor is noisier than assumed. A single spike must not move the estimate, so the
//! difference enters clipped, `Δν_c = clamp(Δν, ±c √(2S))` with `S` the innovation variance at
//! the current `R`: Huber's bounded influence (Huber, "Robust estimation of a location parameter",
//! Ann. Math. Stat. 35, 1964; for the Kalman filter Masreliez and Martin, IEEE TAC 22(3), 1977).
//! One spike of any size moves `R̂` by at most `α (c² S)`, a fraction `α c²` of the variance;
//! a noise that really is larger raises `R̂` by up to the factor `1 + α (c² − 1)` per sample,
//! so a ten times larger std is learned within about `ln(100) / (α (c² − 1))` samples.
//!
//! **Beside it, the sensor's own signal.** The innovations carry what the filter makes of the
//! noise: a filter tuned to trust a vibrating accelerometer follows part of the vibration, so
//! its innovations, and `R̂` with them, stay below the sensor's noise (the MBDS recording's
//! `ay`, about 1.05 m/s² of vibration: the innovations gave about 0.5-0.7). So each row's noise
//! is also measured on the sensor's own samples, without any model, by their second difference
//! (Gasser, Sroka and Jennen-Steinmetz, "Residual variance and residual pattern in nonlinear
//! regression", Biometrika 73, 1986): `E[(x_{k+1} − 2 x_k + x_{k−1})²] = 6 σ²` for white noise
//! on a signal that is smooth over two samples (a car's motion at 100 Hz), averaged and clipped
//! as above (`c √(6 R)`), and a value that repeats the last one exactly (a logger or importer
//! holding a slower signal) is left out, since its differences would be the motion's. A noise
//! that is not white (a vibration at a few hertz) is seen only in part, so this is a lower
//! bound beside `R̂`; the filter uses `max(R₀, R̂, R̂_signal)`.
//!
//! **What the sensor showed lately.** The sensor's own variance is also averaged over a longer
//! memory, and the filter takes the larger of the two: `max(R₀, R̂, R̂_signal, R̂_memory)`. A
//! car's vibration grows with its speed, so an accelerometer shakes least in the corners, where
//! it also carries errors that are not white and that no difference shows: the gravity of the
//! body's roll and of the road's bank, and a sensor off the centre of gravity, tenths of a m/s²
//! that last through the corner (the MBDS recording's `ay` reads 0.40 m/s² more than
//! `r vx + dvy/dt` in its left corners, 0.13 less in its right ones). A quieter corner is no
//! reason to trust the sensor more than on the straight before it. Where the noise is
//! stationary the memory changes nothing; the short average still follows a rougher road
//! within seconds.
//!
//! The learned variances are part of the running state ([`NoiseMatching::save`]) and are kept
//! when the filter is re-seeded: they belong to the sensor, not to the estimate.

use crate::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};

/// The clip `c` of the innovation, in standard deviations of its predicted variance: 3, the
/// edge of a Gaussian's 99.7 %. The clipped squares of a Gaussian innovation average 0.97 of its
/// variance, a bias of 3 % towards a smaller `R̂`.
pub const INNOVATION_CLIP: f64 = 3.0;

/// The learned measurement noise of `M` rows.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseMatching<const M: usize> {
    /// `R₀_ii`, the variances the filter was tuned with: the floor.
    floor: [f64; M],
    /// `R̂_ii`, the running estimates (may fall below the floor).
    learned: [f64; M],
    /// The previous sample's innovation and its `(H P⁻ Hᵀ)_ii` per row; NaN where that sample
    /// had none (a difference needs two samples in a row).
    previous: [(f64, f64); M],
    /// `R̂_signal`, the running estimates from each sensor's own second differences.
    signal: [f64; M],
    /// `R̂_memory`, the same averaged over the longer memory (module text, what the sensor
    /// showed lately), and how many samples it holds so far (until the memory is full it is
    /// their plain mean, so that it does not start at 0 for `τ_memory`).
    memory: [f64; M],
    memory_samples: [f64; M],
    /// Each row's last two distinct values, newest last; NaN until there are two in a row.
    recent: [[f64; 2]; M],
    /// `α = T / τ`.
    weight: f64,
    /// `T / τ_memory`.
    memory_weight: f64,
}

impl<const M: usize> NoiseMatching<M> {
    /// Starts at the tuned variances `floor` with the weight `T / τ` per sample (in (0, 1]),
    /// the memory as long as `τ` (see [`Self::remembering`]).
    pub fn new(floor: [f64; M], weight: f64) -> Self {
        let weight = weight.clamp(f64::MIN_POSITIVE, 1.0);
        Self {
            floor,
            learned: floor,
            previous: [(f64::NAN, f64::NAN); M],
            signal: [0.0; M],
            memory: [0.0; M],
            memory_samples: [0.0; M],
            recent: [[f64::NAN; 2]; M],
            weight,
            memory_weight: weight,
        }
    }

    /// The learner with the sensor's own variance also averaged with the weight `T / τ_memory`
    /// per sample (in (0, 1]; module text, what the sensor showed lately).
    pub fn remembering(self, memory_weight: f64) -> Self {
        Self {
            memory_weight: memory_weight.clamp(f64::MIN_POSITIVE, 1.0),
            ..self
        }
    }

    /// The values learned so far with `tuned`'s floor and weight (a retune of the tuned noise).
    pub fn retuned_as(&self, tuned: &Self) -> Self {
        Self {
            learned: self.learned,
            previous: self.previous,
            signal: self.signal,
            memory: self.memory,
            memory_samples: self.memory_samples,
            recent: self.recent,
            ..tuned.clone()
        }
    }

    /// The variance the filter uses for row `row`: `max(R₀, R̂, R̂_signal, R̂_memory)`.
    pub fn variance(&self, row: usize) -> f64 {
        self.floor[row]
            .max(self.learned[row])
            .max(self.signal[row])
            .max(self.memory[row])
    }

    /// What the learner adds to row `row`'s tuned variance, `variance − R₀ >= 0`.
    pub fn excess(&self, row: usize) -> f64 {
        self.variance(row) - self.floor[row]
    }

    /// Takes the sensor's own value of row `row` in this sample (module text, the sensor's own
    /// signal); `None` (or a non-finite value) where the row has none, which breaks the
    /// sequence of second differences. A value equal to the last one is a held sample and is
    /// left out without breaking the sequence.
    pub fn observe_signal(&mut self, row: usize, value: Option<f64>) {
        let [older, last] = self.recent[row];
        let Some(value) = value.filter(|value| value.is_finite()) else {
            self.recent[row] = [f64::NAN; 2];
            return;
        };
        if value == last {
            return;
        }
        self.recent[row] = [last, value];
        if !(older.is_finite() && last.is_finite()) {
            return;
        }
        let reach = INNOVATION_CLIP * (6.0 * self.variance(row)).sqrt();
        let difference = (value - 2.0 * last + older).clamp(-reach, reach);
        let sample = difference * difference / 6.0;
        average(&mut self.signal[row], sample, self.weight);
        self.memory_samples[row] += 1.0;
        let weight = self.memory_weight.max(1.0 / self.memory_samples[row]);
        average(&mut self.memory[row], sample, weight);
    }

    /// Takes the innovation `innovation` of row `row` in this sample, whose predicted part
    /// `(H P⁻ Hᵀ)_ii` is `predicted_variance`; `None` (or a non-finite value) where the row has
    /// none in this sample, which breaks the sequence of differences.
    pub fn observe(&mut self, row: usize, innovation: Option<(f64, f64)>) {
        let current = innovation
            .filter(|(value, variance)| value.is_finite() && variance.is_finite())
            .unwrap_or((f64::NAN, f64::NAN));
        let (previous, previous_variance) = std::mem::replace(&mut self.previous[row], current);
        let (value, predicted_variance) = current;
        if !(value.is_finite() && previous.is_finite()) {
            return;
        }
        let predicted = 0.5 * (predicted_variance + previous_variance);
        let reach = INNOVATION_CLIP * (2.0 * (predicted + self.variance(row))).sqrt();
        let difference = (value - previous).clamp(-reach, reach);
        let sample = 0.5 * difference * difference - predicted;
        average(&mut self.learned[row], sample, self.weight);
    }

    pub fn save(&self, sink: &mut dyn SnapshotSink) {
        sink.f64s(&self.learned);
        for (value, variance) in self.previous {
            sink.f64(value);
            sink.f64(variance);
        }
        sink.f64s(&self.signal);
        sink.f64s(&self.memory);
        sink.f64s(&self.memory_samples);
        for recent in &self.recent {
            sink.f64s(recent);
        }
    }

    pub fn restore(&mut self, source: &mut dyn SnapshotSource) -> Result<(), SnapshotError> {
        source.f64s_into(&mut self.learned, "learned measurement noise")?;
        for previous in &mut self.previous {
            *previous = (
                source.f64("previous innovation")?,
                source.f64("previous innovation variance")?,
            );
        }
        source.f64s_into(&mut self.signal, "measurement noise from the signal")?;
        source.f64s_into(
            &mut self.memory,
            "measurement noise remembered from the signal",
        )?;
        source.f64s_into(&mut self.memory_samples, "samples of the remembered noise")?;
        for recent in &mut self.recent {
            source.f64s_into(recent, "last sensor values")?;
        }
        Ok(())
    }
}

/// One step of the exponentially weighted moving average `x ← x + α (sample − x)`; a
/// non-finite result leaves `x` as it was.
fn average(x: &mut f64, sample: f64, weight: f64) {
    let updated = *x + weight * (sample - *x);
    if updated.is_finite() {
        *x = updated;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn a_noisier_sensor_than_tuned_is_learned_within_a_few_time_constants() {
        let mut learner = NoiseMatching::<1>::new([0.1 * 0.1], 0.005);
        let noise = Normal::new(0.0, 2.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for _ in 0..2000 {
            learner.observe(0, Some((noise.sample(&mut rng), 0.0)));
        }
        let std = learner.variance(0).sqrt();
        assert!((1.8..2.2).contains(&std), "learned std {std}, true 2");
    }

    #[test]
    fn a_consistent_sensor_keeps_its_tuned_noise() {
        let mut learner = NoiseMatching::<1>::new([1.0], 0.005);
        let noise = Normal::new(0.0, 1.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for _ in 0..5000 {
            learner.observe(0, Some((noise.sample(&mut rng), 0.0)));
        }
        assert!(learner.variance(0) < 1.15, "{}", learner.variance(0));
        assert!(learner.variance(0) >= 1.0);
    }

    #[test]
    fn a_lasting_offset_of_the_model_is_not_taken_for_noise() {
        let mut learner = NoiseMatching::<1>::new([0.1 * 0.1], 0.005);
        let noise = Normal::new(0.0, 0.1).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for k in 0..4000 {
            // a model error of 2 sigma... 30 sigma, changing over seconds
            let offset = 3.0 * (k as f64 * 0.002).sin();
            learner.observe(0, Some((offset + noise.sample(&mut rng), 0.0)));
        }
        assert!(
            learner.variance(0).sqrt() < 0.12,
            "{}",
            learner.variance(0).sqrt()
        );
    }

    /// White noise of std 1.0 on a corner's smooth signal (a sine of 5 m/s² every 6 s at
    /// 100 Hz), which the filter partly follows so its innovations show only 0.3 of it: the
    /// sensor's own second differences find the noise.
    #[test]
    fn the_sensors_own_signal_shows_the_noise_the_innovations_hide() {
        let mut learner = NoiseMatching::<1>::new([0.1 * 0.1], 0.005);
        let noise = Normal::new(0.0, 1.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for k in 0..4000 {
            let e = noise.sample(&mut rng);
            learner.observe(0, Some((0.3 * e, 0.0)));
            let corner = 5.0 * (k as f64 * 0.01 * std::f64::consts::TAU / 6.0).sin();
            learner.observe_signal(0, Some(corner + e));
        }
        let std = learner.variance(0).sqrt();
        assert!((0.9..1.1).contains(&std), "learned std {std}, true 1");
    }

    /// A sensor that shakes with std 1.0 for 20 s and then 0.5 (a straight and the slower
    /// corner after it, at 100 Hz): with a memory of 30 s its noise stays near the straight's
    /// for the next 5 s; without, it falls to the corner's within a few time constants.
    #[test]
    fn a_quieter_stretch_keeps_the_noise_the_sensor_showed_lately() {
        let quieting = |learner: NoiseMatching<1>| {
            let mut learner = learner;
            let mut rng = ChaCha8Rng::seed_from_u64(5);
            let unit = Normal::new(0.0, 1.0).unwrap();
            for k in 0..2500 {
                let std = if k < 2000 { 1.0 } else { 0.5 };
                learner.observe_signal(0, Some(std * unit.sample(&mut rng)));
            }
            learner.variance(0).sqrt()
        };
        let short = quieting(NoiseMatching::<1>::new([0.01], 0.005));
        let remembered = quieting(NoiseMatching::<1>::new([0.01], 0.005).remembering(0.01 / 30.0));
        assert!((0.45..0.6).contains(&short), "without the memory {short}");
        assert!(remembered > 0.8, "with the memory {remembered}");
    }

    /// A clean sensor on a fast manoeuvre (a 10 m/s² step over 0.3 s, sampled at 100 Hz and
    /// held every other sample as a 50 Hz logger gives it) keeps its tuned noise: the motion is
    /// smooth over two samples and held values are left out.
    #[test]
    fn a_smooth_held_signal_is_not_taken_for_noise() {
        let mut learner = NoiseMatching::<1>::new([0.1 * 0.1], 0.005);
        for k in 0..2000 {
            let t = (k / 2 * 2) as f64 * 0.01;
            let ramp = 10.0 * ((t - 5.0) / 0.3).clamp(0.0, 1.0);
            learner.observe_signal(0, Some(ramp));
        }
        assert_eq!(learner.variance(0), 0.1 * 0.1);
        learner.observe_signal(0, None);
        learner.observe_signal(0, Some(f64::NAN));
        assert!(learner.variance(0).is_finite());
    }

    #[test]
    fn one_spike_moves_the_learned_noise_by_a_few_percent_at_most() {
        let mut learner = NoiseMatching::<1>::new([1.0], 0.005);
        learner.observe(0, Some((0.0, 0.0)));
        learner.observe(0, Some((1e6, 0.0)));
        learner.observe(0, Some((0.0, 0.0)));
        assert!(learner.variance(0) < 1.1, "{}", learner.variance(0));
        learner.observe(0, Some((f64::NAN, 0.0)));
        learner.observe(0, None);
        assert!(learner.variance(0).is_finite());
    }
}
