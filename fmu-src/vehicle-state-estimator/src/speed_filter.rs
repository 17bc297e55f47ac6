//! The speed models A and B report. Model B takes the speed as an input
//! (001: eqs 6-11); taken as it comes, the measured speed's noise would go
//! straight into its `vx_est` and into its lateral dynamics. Model A estimates its speed as a
//! state of its force balance, where with the torques unknown its tyre law's error goes (up to
//! 9 % off on the harness campaigns). With a measured longitudinal acceleration both now report
//! the estimate of a scalar Kalman filter on the longitudinal kinematics of a rigid body in the
//! body frame, `dvx/dt = ax + r vy` (ISO 8855; the relation model A's speed anchor uses,
//! `SpeedAnchoredModel`), explicit Euler over one sample:
//!
//! `vx⁻ = vx + T (ax + r vy)`, `P⁻ = P + q`; with the measured speed `z` (variance `R`):
//! `K = P⁻ / (P⁻ + R)`, `vx = vx⁻ + K (z − vx⁻)`, `P = (1 − K) P⁻`
//!
//! (000: 4.64-4.75, the LKF in one dimension). `q` is `process_noise_std_vx²` (the integrated
//! accelerometer's error over a sample, its bias from pitch and road grade included) and the
//! share of the lateral estimate's error ([`SpeedSample::prediction_variance`]). The measured
//! speed is tested by the FMU's chi-square gate, `(z − vx⁻)² ≤ gate_threshold (P⁻ + R)`: a
//! rejected sample keeps the prediction (status 128); rejected for `readmit_time` in a row, the
//! filter restarts from the measured speed (status 256), so a real step cannot lock it out. A
//! sample without a measured speed keeps the prediction, one without `ax` holds the last, each
//! for up to [`HELD_AX_TIME`] ([`HELD_AX_STD`]). Without a measured `ax` (or without
//! `use_speed_measurements`, as the seed scenarios set) model B's speed is the measured one, as
//! seed 001 takes it, and model A's its own state.
//!
//! The filtered speed `vx` of a sample is model B's input for that sample; what the FMU reports
//! (`vx_est`, `vx_std`) is, like its other outputs, the estimate for the next sample instant:
//! `vx + T (ax − b + r vy)` with variance `P + q`.
//!
//! **The accelerometer's offset.** A real `ax` is offset (the sensor's own offset, the road's
//! grade `g sin γ`, the body's pitch), and integrated over a drive the offset takes the speed
//! off and its std no longer covers the error. So the filter carries the offset `b` as a second
//! state, `vx⁻ = vx + T (ax − b + r vy)`, `b⁻ = a b`, a Gauss-Markov process about 0 of std
//! `ax_offset_std` and correlation time [`AX_OFFSET_TIME_CONSTANT`] (Brown and Hwang, §2.9;
//! the 2 × 2 Kalman filter, Joseph form). Only while the car drives straight (`|r|` below
//! [`STRAIGHT_YAW_RATE`]) does the measured speed update `b`: in a corner `r vy` and `b` enter
//! the speed alike, and a `b` learned there takes up the lateral estimate's error. In a corner
//! `b` is held, its variance still carried (a consider state: Schmidt 1966). Models A and the
//! grip model take `ax − b` in their own kinematics too (`model_a::reported_speed_sample`), where
//! an offset would read as `b / r` of lateral velocity.

use fmi_export::{StateError, StateReader, StateWriter};

use crate::gauss_markov::GaussMarkov;
use crate::model_description::Variables;
use crate::runner::ChiSquareGate;
use crate::status;

/// The correlation time of the lateral estimate's error, s: half the period of a sine with
/// dwell's 0.7 Hz steer, the longest manoeuvre period of the campaigns (FMVSS 126 S7.5).
pub const LATERAL_CORRELATION_TIME: f64 = 0.7;

/// The one-sigma uncertainty of an acceleration held for want of a measured one, m/s²: about
/// the change of a car's deceleration over 0.1 s while a brake builds up at 10 m/s³.
pub const HELD_AX_STD: f64 = 1.0;

/// The longest an acceleration is held, or the speed predicted without a measured one, s: issue
/// 12 point 3's 0.5 s outage of a sensor.
pub const HELD_AX_TIME: f64 = 0.5;

/// Correlation time of the accelerometer offset, s: a sensor's offset drifts with temperature
/// over minutes, a road's grade changes over hundreds of metres.
pub const AX_OFFSET_TIME_CONSTANT: f64 = 600.0;

/// The yaw rate below which the car counts as driving straight and the measured speed updates
/// the accelerometer offset, rad/s (1.1°/s: at 20 m/s a radius of 1 km, where `r vy` is at most
/// a few mm/s²).
pub const STRAIGHT_YAW_RATE: f64 = 0.02;

/// `ax` as the models take it (finite and plausible, else `None`) if it is a measured
/// acceleration: an `ax_meas` left unconnected reads its start value, exactly 0, and a speed
/// predicted at 0 m/s² would lag a braking car (0.8 m/s at 4 m/s² with the defaults), so an `ax`
/// of exactly 0 counts as not measured.
pub fn measured_ax(ax: Option<f64>) -> Option<f64> {
    ax.filter(|&ax| ax != 0.0)
}

/// The filter's state; `variance` NaN while the speed is taken as measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedFilter {
    /// The filtered speed (model B runs at it), m/s.
    pub value: f64,
    /// `P`, (m/s)²; NaN while not filtering (no `ax`).
    pub variance: f64,
    /// Measured speeds rejected in a row by the gate.
    pub rejected: u64,
    /// The one-step prediction `vx + T (ax + r vy)` and its variance `P + q` (the outputs);
    /// the measured speed and NaN while not filtering.
    pub ahead: f64,
    pub ahead_variance: f64,
    /// The acceleration of the last prediction, m/s² (NaN while not filtering).
    pub ax: f64,
    /// Samples in a row whose prediction held `ax` for want of a measured one.
    pub ax_held: u64,
    /// Samples in a row without a measured speed.
    pub unmeasured: u64,
    /// The offset `b` of the measured `ax`, m/s² (module docs), its variance and its covariance
    /// with the speed; 0, NaN and 0 while not filtering.
    pub ax_offset: f64,
    pub ax_offset_variance: f64,
    pub speed_offset_covariance: f64,
}

/// What one sample gives the filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedSample {
    /// The measured speed (model B: `vx_meas`, else the wheels' rolling speed; model A:
    /// `vx_meas`), at least `min_speed`; NaN if there is none this sample.
    pub measured: f64,
    /// `R` of `measured`, (m/s)².
    pub measurement_variance: f64,
    /// The measured longitudinal acceleration, m/s², if any.
    pub ax: Option<f64>,
    /// The yaw rate and lateral velocity of the lateral filter's predicted estimate.
    pub yaw_rate: f64,
    pub lateral_velocity: f64,
    /// The lateral velocity's variance in that estimate, (m/s)².
    pub lateral_velocity_variance: f64,
    /// `T`, s.
    pub sample_time: f64,
    /// `q`, (m/s)² per sample: the accelerometer's share ([`Self::prediction_variance`] adds
    /// the lateral estimate's).
    pub process_variance: f64,
    /// The speed below which model B holds (`min_speed`).
    pub min_speed: f64,
    /// The accelerometer offset's stationary variance `ax_offset_std²`, (m/s²)²; 0 takes `ax`
    /// as it comes.
    pub offset_variance: f64,
}

impl SpeedSample {
    /// The sample at the FMU's parameters (`measurement_noise_std_vx`, `process_noise_std_vx`,
    /// `sample_time`): `lateral_velocity` is `value tan β` of the filter's speed `value` and the
    /// lateral filter's sideslip β; `ax` as the models take it, of which only a
    /// [`measured_ax`] filters.
    pub fn at(
        v: &Variables,
        measured: f64,
        ax: Option<f64>,
        (yaw_rate, lateral_velocity, lateral_velocity_variance): (f64, f64, f64),
        min_speed: f64,
    ) -> Self {
        Self {
            measured,
            measurement_variance: v.measurement_noise_std_vx * v.measurement_noise_std_vx,
            ax: measured_ax(ax),
            yaw_rate,
            lateral_velocity,
            lateral_velocity_variance,
            sample_time: v.sample_time,
            process_variance: v.process_noise_std_vx * v.process_noise_std_vx,
            min_speed,
            offset_variance: v.ax_offset_std * v.ax_offset_std,
        }
    }

    /// The offset's process: `a = exp(−T/τb)` and `σb² (1 − a²)` per sample.
    fn offset_process(&self) -> GaussMarkov {
        GaussMarkov::new(
            self.offset_variance,
            self.sample_time,
            AX_OFFSET_TIME_CONSTANT,
        )
    }

    /// The offset's decay per sample, `a`.
    fn offset_decay(&self) -> f64 {
        self.offset_process().decay
    }

    /// The variance one prediction adds: `q` and what the lateral estimate's uncertainty puts
    /// into the integrated `r vy`. That error is not white: it lasts as long as the lateral
    /// estimate's error, about a manoeuvre's half period. As a first-order Gauss-Markov process
    /// of variance `(r σvy)²` and correlation time `τ` ([`LATERAL_CORRELATION_TIME`]) its
    /// integral grows in variance by `2 τ (r σvy)²` per second over times longer than `τ`
    /// (Brown and Hwang, Introduction to Random Signals and Applied Kalman Filtering, 4th ed.
    /// 2012, §2.9), `2 τ T (r σvy)²` per sample,
    /// `σvy` as the FMU reports it (the models pass it with the rear stiffness's consider
    /// term). Without it a lateral estimate that is off (the Luenberger observer's on the
    /// Vanagon's sine with dwell, 8° of sideslip) drew the speed off `vx_meas` until the gate
    /// locked the measurement out: 4.2 % off; with the filter's covariance alone, the speed's
    /// reported std was overconfident on the sines (model A's EKF on the Vanagon's: NEES 6.3).
    pub fn prediction_variance(&self) -> f64 {
        let rate_error = self.yaw_rate * self.yaw_rate * self.lateral_velocity_variance;
        let lateral = 2.0 * LATERAL_CORRELATION_TIME * self.sample_time * rate_error;
        if lateral.is_finite() {
            self.process_variance + lateral
        } else {
            self.process_variance
        }
    }
}

impl SpeedFilter {
    /// The measured speed, not filtering.
    pub fn measured(speed: f64) -> Self {
        Self {
            value: speed,
            variance: f64::NAN,
            rejected: 0,
            ahead: speed,
            ahead_variance: f64::NAN,
            ax: f64::NAN,
            ax_held: 0,
            unmeasured: 0,
            ax_offset: 0.0,
            ax_offset_variance: f64::NAN,
            speed_offset_covariance: 0.0,
        }
    }

    /// Whether the filter runs (else the speed is taken as measured).
    pub fn filtering(&self) -> bool {
        self.variance.is_finite()
    }

    /// The standard deviation of the one-step prediction while filtering.
    pub fn std(&self) -> Option<f64> {
        self.ahead_variance
            .is_finite()
            .then(|| self.ahead_variance.sqrt())
    }

    /// `vx + T (ax − b + r vy)` of `sample` from `speed`, `b` the filter's offset.
    fn predicted(&self, speed: f64, ax: f64, sample: &SpeedSample) -> f64 {
        speed
            + sample.sample_time * (ax - self.ax_offset + sample.yaw_rate * sample.lateral_velocity)
    }

    /// The prediction's covariance over one sample, `F P Fᵀ + Q` with `F = [[1, −T], [0, a]]`:
    /// the speed's variance, its covariance with the offset and the offset's variance. `Q` is
    /// [`SpeedSample::prediction_variance`] on the speed, and while `ax` is held `(T σh)²` with
    /// `σh` = [`HELD_AX_STD`], and the offset's process noise on the offset.
    fn prior_covariance(&self, sample: &SpeedSample) -> (f64, f64, f64) {
        let t = sample.sample_time;
        let held = if self.ax_held > 0 {
            (t * HELD_AX_STD).powi(2)
        } else {
            0.0
        };
        let offset = self.ax_offset_variance;
        let speed = self.variance - 2.0 * t * self.speed_offset_covariance
            + t * t * offset
            + sample.prediction_variance()
            + held;
        let process = sample.offset_process();
        let covariance = process.decay * (self.speed_offset_covariance - t * offset);
        (speed, covariance, process.predicted_variance(offset))
    }

    /// The speed's part of [`Self::prior_covariance`].
    fn prior_variance(&self, sample: &SpeedSample) -> f64 {
        self.prior_covariance(sample).0
    }

    /// Takes the prediction `predicted` with its covariance `prior` ([`Self::prior_covariance`])
    /// as the estimate (no measurement).
    fn keep_prior(&mut self, predicted: f64, prior: (f64, f64, f64), sample: &SpeedSample) {
        let (speed, covariance, offset) = prior;
        self.value = predicted;
        self.ax_offset *= sample.offset_decay();
        self.variance = speed;
        self.speed_offset_covariance = covariance;
        self.ax_offset_variance = offset;
    }

    /// The measurement update of the speed and, while the car drives straight, the offset, with
    /// gain `K = [kv, kb]` (`kb` = 0 in a corner), Joseph form `(I − K H) P (I − K H)ᵀ + K R Kᵀ`.
    fn correct(
        &mut self,
        predicted: f64,
        prior: (f64, f64, f64),
        innovation: f64,
        sample: &SpeedSample,
    ) {
        let (speed, covariance, offset) = prior;
        let r = sample.measurement_variance;
        let innovation_variance = speed + r;
        let kv = speed / innovation_variance;
        let kb = if sample.yaw_rate.abs() < STRAIGHT_YAW_RATE {
            covariance / innovation_variance
        } else {
            0.0
        };
        self.value = predicted + kv * innovation;
        self.ax_offset = sample.offset_decay() * self.ax_offset + kb * innovation;
        self.variance = (1.0 - kv) * (1.0 - kv) * speed + kv * kv * r;
        self.speed_offset_covariance = (1.0 - kv) * (covariance - kb * speed) + kv * kb * r;
        self.ax_offset_variance = offset - 2.0 * kb * covariance + kb * kb * speed + kb * kb * r;
    }

    /// One sample; returns its status bits (1 no measured speed, 128 gated, 256 restarted
    /// after a lock-out).
    pub fn step(&mut self, sample: &SpeedSample, gate: Option<ChiSquareGate>) -> i32 {
        let bits = self.update(sample, gate);
        if self.filtering() {
            let ahead = self.predicted(self.value, self.ax, sample);
            self.ahead = if Self::plausible(ahead, sample) {
                ahead
            } else {
                self.value
            };
            self.ahead_variance = self.prior_variance(sample);
        }
        bits
    }

    /// The acceleration of this sample's prediction: the measured one, else while filtering
    /// the last one held for up to [`HELD_AX_TIME`] (one all-zero row or a short dropout of
    /// `ax_meas` must not restart the filter from one noisy speed sample); `None` stops it, as
    /// does a measured speed missing for longer than that (the integrated `ax` alone drifts).
    fn acceleration(&mut self, sample: &SpeedSample) -> Option<f64> {
        let longest = (HELD_AX_TIME / sample.sample_time).ceil() as u64;
        if sample.measured.is_finite() {
            self.unmeasured = 0;
        } else if self.unmeasured >= longest {
            return None;
        } else {
            self.unmeasured += 1;
        }
        if let Some(ax) = sample.ax {
            self.ax_held = 0;
            return Some(ax);
        }
        if self.filtering() && self.ax.is_finite() && self.ax_held < longest {
            self.ax_held += 1;
            return Some(self.ax);
        }
        None
    }

    /// The measurement update of one sample (after the prediction from the last one).
    fn update(&mut self, sample: &SpeedSample, gate: Option<ChiSquareGate>) -> i32 {
        let Some(ax) = self.acceleration(sample) else {
            *self = Self::measured(sample.measured);
            return 0;
        };
        if !self.filtering() {
            if !sample.measured.is_finite() {
                return status::ROW_SKIPPED;
            }
            self.restart(sample);
            self.ax = ax;
            return 0;
        }
        let predicted = self.predicted(self.value, ax, sample);
        let prior = self.prior_covariance(sample);
        self.ax = ax;
        if !sample.measured.is_finite() {
            self.keep_prior(predicted, prior, sample);
            return status::ROW_SKIPPED;
        }
        let innovation = sample.measured - predicted;
        let innovation_variance = prior.0 + sample.measurement_variance;
        if let Some(gate) = gate {
            if !gate.admits(innovation, innovation_variance) {
                self.rejected += 1;
                if self.rejected >= gate.readmit_samples {
                    self.restart(sample);
                    return status::ROW_GATED | status::SENSOR_READMITTED;
                }
                self.keep_prior(predicted, prior, sample);
                self.restart_if_implausible(sample);
                return status::ROW_GATED;
            }
        }
        self.correct(predicted, prior, innovation, sample);
        self.rejected = 0;
        self.restart_if_implausible(sample);
        0
    }

    /// `min_speed ≤ speed ≤ 2 z + 10 m/s`, `z` the measured speed
    /// ([`Self::restart_if_implausible`]); without one, finite and at least `min_speed`.
    fn plausible(speed: f64, sample: &SpeedSample) -> bool {
        let highest = if sample.measured.is_finite() {
            2.0 * sample.measured + 10.0
        } else {
            f64::INFINITY
        };
        speed.is_finite() && (sample.min_speed..=highest).contains(&speed)
    }

    /// From the measured speed with its variance (the acceleration kept, and the offset with its
    /// variance where the filter ran, else the offset's prior: 0 with `ax_offset_std²`).
    fn restart(&mut self, sample: &SpeedSample) {
        let (ax_offset, ax_offset_variance) = if self.ax_offset_variance.is_finite() {
            (self.ax_offset, self.ax_offset_variance)
        } else {
            (0.0, sample.offset_variance)
        };
        *self = Self {
            variance: sample.measurement_variance,
            ax: self.ax,
            ax_offset,
            ax_offset_variance,
            ..Self::measured(sample.measured)
        };
    }

    /// Model B divides by the speed: an estimate that is not finite, fell below `min_speed`
    /// (the measured speed is above it) or rose above twice the measured speed plus 10 m/s (the
    /// plausibility bound of the wheel speeds; a wild `r vy` of a lateral estimate that lost
    /// itself) restarts from the measurement.
    fn restart_if_implausible(&mut self, sample: &SpeedSample) {
        let finite = self.variance.is_finite()
            && self.ax_offset.is_finite()
            && self.ax_offset_variance.is_finite();
        if !finite {
            self.ax_offset_variance = f64::NAN;
        }
        if !(Self::plausible(self.value, sample) && finite) {
            self.restart(sample);
        }
    }

    /// The filter as part of the FMU state.
    pub fn write(&self, writer: &mut StateWriter) {
        writer.f64(self.value);
        writer.f64(self.variance);
        writer.u64(self.rejected);
        writer.f64(self.ahead);
        writer.f64(self.ahead_variance);
        writer.f64(self.ax);
        writer.u64(self.ax_held);
        writer.u64(self.unmeasured);
        writer.f64(self.ax_offset);
        writer.f64(self.ax_offset_variance);
        writer.f64(self.speed_offset_covariance);
    }

    /// The filter [`Self::write`] wrote.
    pub fn read(reader: &mut StateReader<'_>) -> Result<Self, StateError> {
        Ok(Self {
            value: reader.f64("speed")?,
            variance: reader.f64("speed variance")?,
            rejected: reader.u64("speed samples gated")?,
            ahead: reader.f64("predicted speed")?,
            ahead_variance: reader.f64("predicted speed variance")?,
            ax: reader.f64("speed filter's acceleration")?,
            ax_held: reader.u64("samples with ax held")?,
            unmeasured: reader.u64("samples without a measured speed")?,
            ax_offset: reader.f64("accelerometer offset")?,
            ax_offset_variance: reader.f64("accelerometer offset variance")?,
            speed_offset_covariance: reader.f64("speed-offset covariance")?,
        })
    }
}
