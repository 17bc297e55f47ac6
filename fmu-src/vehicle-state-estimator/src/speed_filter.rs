//! Model B's speed (issue 12 point 1). Model B takes the speed as an input (001: eqs 6-11), and
//! it used to take the measured speed as it came: the sensor's noise went straight into its
//! `vx_est` and into its lateral dynamics. With a measured longitudinal acceleration the speed
//! is now the estimate of a scalar Kalman filter on the longitudinal kinematics of a rigid body
//! in the body frame, `dvx/dt = ax + r vy` (ISO 8855; the relation model A's speed anchor uses,
//! `SpeedAnchoredModel`), explicit Euler over one sample:
//!
//! `vx⁻ = vx + T (ax + r vy)`, `P⁻ = P + q`; with the measured speed `z` (variance `R`):
//! `K = P⁻ / (P⁻ + R)`, `vx = vx⁻ + K (z − vx⁻)`, `P = (1 − K) P⁻`
//!
//! (000: 4.64-4.75, the LKF in one dimension). `q` is `process_noise_std_vx²`: the integrated
//! accelerometer's error over a sample (its bias from pitch and road grade included). The
//! measured speed is tested by the FMU's chi-square gate, `(z − vx⁻)² ≤ gate_threshold
//! (P⁻ + R)`: a rejected sample keeps the prediction (status 128); rejected for `readmit_time`
//! in a row, the filter restarts from the measured speed (status 256), so a real step cannot
//! lock it out. Without a measured `ax` (or without `use_speed_measurements`, as the seed
//! scenarios set) the speed is the measured one, as seed 001 takes it.
//!
//! The filtered speed `vx` of a sample is model B's input for that sample; what the FMU reports
//! (`vx_est`, `vx_std`) is, like its other outputs, the estimate for the next sample instant:
//! `vx + T (ax + r vy)` with variance `P + q`.

use crate::status;

/// The filter's state; `variance` NaN while the speed is taken as measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedFilter {
    /// The speed model B runs at, m/s.
    pub value: f64,
    /// `P`, (m/s)²; NaN while not filtering (no `ax`).
    pub variance: f64,
    /// Measured speeds rejected in a row by the gate.
    pub rejected: u64,
    /// The one-step prediction `vx + T (ax + r vy)` and its variance `P + q` (the outputs);
    /// the measured speed and NaN while not filtering.
    pub ahead: f64,
    pub ahead_variance: f64,
}

/// The gate of the measured speed: the FMU's `gate_threshold` and `readmit_time` in samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedGate {
    pub threshold: f64,
    pub readmit_samples: u64,
}

/// What one sample gives the filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedSample {
    /// The measured speed (`vx_meas`, else the wheels' rolling speed), at least `min_speed`.
    pub measured: f64,
    /// `R` of `measured`, (m/s)².
    pub measurement_variance: f64,
    /// The measured longitudinal acceleration, m/s², if any.
    pub ax: Option<f64>,
    /// The yaw rate and lateral velocity of the lateral filter's predicted estimate.
    pub yaw_rate: f64,
    pub lateral_velocity: f64,
    /// `T`, s.
    pub sample_time: f64,
    /// `q`, (m/s)² per sample.
    pub process_variance: f64,
    /// The speed below which model B holds (`min_speed`).
    pub min_speed: f64,
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
        }
    }

    /// The standard deviation of the one-step prediction while filtering.
    pub fn std(&self) -> Option<f64> {
        self.ahead_variance
            .is_finite()
            .then(|| self.ahead_variance.sqrt())
    }

    /// `vx + T (ax + r vy)` of `sample` from `speed`.
    fn predicted(speed: f64, ax: f64, sample: &SpeedSample) -> f64 {
        speed + sample.sample_time * (ax + sample.yaw_rate * sample.lateral_velocity)
    }

    /// One sample; returns its status bits (128 gated, 256 restarted after a lock-out).
    pub fn step(&mut self, sample: &SpeedSample, gate: Option<SpeedGate>) -> i32 {
        let bits = self.update(sample, gate);
        if let (Some(ax), true) = (sample.ax, self.variance.is_finite()) {
            let ahead = Self::predicted(self.value, ax, sample);
            self.ahead = if Self::plausible(ahead, sample) {
                ahead
            } else {
                self.value
            };
            self.ahead_variance = self.variance + sample.process_variance;
        }
        bits
    }

    /// The measurement update of one sample (after the prediction from the last one).
    fn update(&mut self, sample: &SpeedSample, gate: Option<SpeedGate>) -> i32 {
        let Some(ax) = sample.ax else {
            *self = Self::measured(sample.measured);
            return 0;
        };
        if !self.variance.is_finite() {
            self.restart(sample);
            return 0;
        }
        let predicted = Self::predicted(self.value, ax, sample);
        let prior = self.variance + sample.process_variance;
        let innovation = sample.measured - predicted;
        let innovation_variance = prior + sample.measurement_variance;
        if let Some(gate) = gate {
            if innovation * innovation > gate.threshold * innovation_variance {
                self.rejected += 1;
                if self.rejected >= gate.readmit_samples {
                    self.restart(sample);
                    return status::ROW_GATED | status::SENSOR_READMITTED;
                }
                self.value = predicted;
                self.variance = prior;
                self.restart_if_implausible(sample);
                return status::ROW_GATED;
            }
        }
        let gain = prior / innovation_variance;
        self.value = predicted + gain * innovation;
        self.variance = (1.0 - gain) * prior;
        self.rejected = 0;
        self.restart_if_implausible(sample);
        0
    }

    /// `min_speed ≤ speed ≤ 2 z + 10 m/s`, `z` the measured speed
    /// ([`Self::restart_if_implausible`]).
    fn plausible(speed: f64, sample: &SpeedSample) -> bool {
        (sample.min_speed..=2.0 * sample.measured + 10.0).contains(&speed)
    }

    /// From the measured speed with its variance.
    fn restart(&mut self, sample: &SpeedSample) {
        *self = Self {
            variance: sample.measurement_variance,
            ..Self::measured(sample.measured)
        };
    }

    /// Model B divides by the speed: an estimate that is not finite, fell below `min_speed`
    /// (the measured speed is above it) or rose above twice the measured speed plus 10 m/s (the
    /// plausibility bound of the wheel speeds; a wild `r vy` of a lateral estimate that lost
    /// itself) restarts from the measurement.
    fn restart_if_implausible(&mut self, sample: &SpeedSample) {
        if !(Self::plausible(self.value, sample) && self.variance.is_finite()) {
            self.restart(sample);
        }
    }
}
