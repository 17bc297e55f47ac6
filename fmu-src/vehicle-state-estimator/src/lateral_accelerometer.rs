//! The lateral accelerometer's offset and gain, learned where the car's lateral acceleration is
//! known without the filter.
//!
//! A series-production `ay` sensor sits in the body: it reads the lateral acceleration plus an
//! offset (the sensor's own, tenths of a m/s²) and, as the body rolls by `φ` in a corner, the
//! share of gravity `g sin φ` (ISO 8855 specific force). With the roll proportional to the
//! lateral acceleration (the roll gradient, 4-7°/g on passenger cars) the reading is about
//! `(1 + e) ay` with a gain error `e = g dφ/day` of 0.07-0.13. Every model here takes `ay_meas` as
//! the tyres' force over the mass; the grip model, which learns its axles' grip from it, took a
//! gain error of 0.13 (the ReferenceVehicle's `gravity_in_accelerometers`) as a force its yaw
//! rate cannot explain: its campaign error on the full vehicle went up sixfold, and an offset of
//! 0.2 m/s² tripled it (fmu-src/vehicle-state-estimator/README.md, "The lateral accelerometer's
//! offset and gain").
//!
//! So the runner keeps a Kalman filter of `x = [b, e]` ahead of every estimator, both
//! first-order Gauss-Markov processes about 0 (stds `ay_offset_std` and `ay_gain_std`,
//! correlation time [`AY_CALIBRATION_TIME_CONSTANT`]; Brown and Hwang, §2.9), measured by
//! `ay_meas = b + (1 + e) a` wherever the car is in a quasi-steady state and its lateral
//! acceleration is the kinematic `a = r vx` (ISO 8855: `ay = dvy/dt + r vx`, with `dvy/dt` ≈ 0
//! while steering and yaw rate hold still; [`QuasiSteady`]): `z − (1 + e) a = b` driving
//! straight ([`STRAIGHT_ACCELERATION`]), and where the gain is learned `z − a = [1, a] x` in a
//! steady corner ([`GAIN_ACCELERATION`]). `r` is the gyro corrected by its own
//! learner (`yaw_rate_offset`), `vx` the measured speed. The estimators get
//! `(ay_meas − b) / (1 + e)`. On the grip model the filter estimates the gain itself (its
//! `ay_gain` state, `EstimationModel::ESTIMATES_AY_GAIN`), and this learner keeps `e` at 0 and
//! learns the offset only: learned here, in quasi-steady corners only, the gain came too late
//! for the grip the filter had learned in the step before (fmu-src/vehicle-state-estimator/
//! README.md, "The accelerometer gain in the grip filter").
//!
//! The reference's error: the gyro's noise times the speed, and what is left of `dvy/dt`
//! in a quasi-steady state ([`QUASI_STEADY_STD`], correlated over [`QUASI_STEADY_TIME`], as white
//! noise of the same low-frequency density `2 τ σ² / T` per sample). An innovation beyond
//! [`GATE_SIGMAS`] standard deviations, an all-zero row and a speed below [`MIN_SPEED`] teach
//! nothing.
//!
//! What it cannot tell apart: a road's cross slope reads as an offset while the car drives
//! straight on it (the tyres then do carry `m g sin γ`), so the straight's reference carries
//! the crossfall of roads as its error ([`ROAD_CROSSFALL_ACCELERATION`]) and the offset is
//! learned over minutes; a roll that lags the lateral acceleration leaves its transient in the
//! corrected `ay`.

use fmi_export::{StateError, StateReader, StateWriter};
use nalgebra::{Matrix2, Vector2};

use crate::gauss_markov::{white_equivalent, GaussMarkov};
use crate::model_description::Variables;

/// Correlation time of the offset and the gain, s: a sensor's offset drifts with temperature
/// over minutes; the roll gradient changes with the load.
pub const AY_CALIBRATION_TIME_CONSTANT: f64 = 600.0;

/// The measured speed below which nothing is learned, m/s: the kinematic `r vx` is small there
/// and the gyro's offset error weighs more.
pub const MIN_SPEED: f64 = 5.0;

/// The time constant of the low-pass steering angle and yaw rate the quasi-steady test compares
/// the current ones with, s: about a car's yaw response time.
pub const QUASI_STEADY_FILTER_TIME: f64 = 0.3;

/// Quasi-steady: the road-wheel angle within this of its low-pass value, rad (at a steering
/// ratio of 16, 2° at the steering wheel; a slow ramp of 3°/s at the wheel stays within it).
pub const QUASI_STEADY_STEERING: f64 = 0.002;

/// Quasi-steady: the yaw rate within this of its low-pass value, rad/s.
pub const QUASI_STEADY_YAW_RATE: f64 = 0.02;

/// What is left of `dvy/dt` in a quasi-steady state, one standard deviation, m/s², and how long
/// it is correlated, s.
pub const QUASI_STEADY_STD: f64 = 0.1;
pub const QUASI_STEADY_TIME: f64 = 0.5;

/// What a road's cross slope adds to `ay_meas` driving straight (the tyres carry it, `r vx`
/// does not see it), one standard deviation, m/s², and how long it is correlated, s: roads
/// drain by a crossfall of about 2.5 % (`g` · 0.025) that changes from one stretch to the next,
/// so a sensor's offset takes minutes of straight driving to tell from it. Without it the
/// learner took each straight's crossfall for the offset (the MBDS recording: it swung between
/// 0 and 0.2 m/s² within a lap). A corner's bank is not modelled here: the corner update learns
/// the gain (opt-in, `ay_gain_std`), its regressor `r vx` at least [`GAIN_ACCELERATION`].
pub const ROAD_CROSSFALL_ACCELERATION: f64 = 0.25;
pub const ROAD_CROSSFALL_TIME: f64 = 5.0;

/// The gate on the innovation, in standard deviations.
pub const GATE_SIGMAS: f64 = 5.0;

/// Below this kinematic lateral acceleration `|r vx|` the car counts as driving straight and
/// only the offset is updated (the gain held, its variance carried as `Pee a²`), m/s².
pub const STRAIGHT_ACCELERATION: f64 = 0.5;

/// From this `|r vx|` on the gain is updated, and the offset with it, m/s²; without a gain to
/// learn (`ay_gain_std` 0) a corner teaches nothing: there the offset took up what the
/// kinematic reference misses near the limit (on the example log's slow steer to the limit it
/// wandered between +0.02 and −0.03 m/s², and the grip model's sideslip went 0.37° → 0.47°).
/// Below it the gyro's noise in `r vx`
/// (0.06 m/s² at 20 m/s) is a sizeable part of the regressor, and since the same noise is in the
/// innovation the gain was biased towards −1 (errors in variables): −0.04 after 5 s of straight
/// driving where the sensor had no gain error.
pub const GAIN_ACCELERATION: f64 = 2.0;

/// The learner's fixed settings, from the parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Settings {
    /// The processes of the offset and of the gain error (stationary variances `ay_offset_std²`,
    /// (m/s²)², and `ay_gain_std²`; `τ` = [`AY_CALIBRATION_TIME_CONSTANT`]).
    offset: GaussMarkov,
    gain: GaussMarkov,
    /// `ay_gain_std` is not 0.
    learns_gain: bool,
    /// `measurement_noise_std_yaw_rate²`.
    yaw_rate_variance: f64,
    /// The low-pass filters' factor per sample, `1 − exp(−T/τf)`.
    smoothing: f64,
    /// `T`, s.
    sample_time: f64,
}

/// Whether the car is in a quasi-steady state: the steering angle and the yaw rate against
/// their low-pass values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuasiSteady {
    steering: f64,
    yaw_rate: f64,
}

impl QuasiSteady {
    /// Takes this sample's values into the low-pass values; returns whether the car was
    /// quasi-steady (both within their limits of the values before).
    fn step(&mut self, steering: f64, yaw_rate: f64, smoothing: f64) -> bool {
        if !self.steering.is_finite() || !self.yaw_rate.is_finite() {
            *self = Self { steering, yaw_rate };
            return false;
        }
        let steady = (steering - self.steering).abs() < QUASI_STEADY_STEERING
            && (yaw_rate - self.yaw_rate).abs() < QUASI_STEADY_YAW_RATE;
        self.steering += smoothing * (steering - self.steering);
        self.yaw_rate += smoothing * (yaw_rate - self.yaw_rate);
        steady
    }
}

/// What one sample gives the learner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AySample {
    /// `ay_meas`, m/s², and the yaw rate corrected by its offset, rad/s (NaN: missing).
    pub ay: f64,
    pub yaw_rate: f64,
    /// Every sensor reads exactly 0 (a dropout).
    pub all_zero: bool,
    /// The road-wheel angle, rad.
    pub steering: f64,
    /// The measured speed, m/s, if any.
    pub speed: Option<f64>,
    /// The accelerometer's noise variance as the filter uses it, (m/s²)²: learned from the data
    /// where `learn_measurement_noise` (never below `measurement_noise_std_ay²`), else the
    /// parameter's. A vibrating accelerometer tested against its data-sheet noise would move
    /// the offset with every vibration (the MBDS recording's laps 2-6 with
    /// wheel speeds: the offset swung from −0.25 to 0.36 m/s², and the grip EKF's sideslip was
    /// 0.60° with the data-sheet noise, 0.54° without the offset learned, 0.58° with the noise
    /// learned).
    pub ay_variance: f64,
}

/// The learner: its settings, its estimate `[b, e]` with covariance, and the quasi-steady test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LateralAccelerometer {
    settings: Settings,
    /// `[b, e]`: the offset, m/s², and the gain error.
    pub estimate: Vector2<f64>,
    pub covariance: Matrix2<f64>,
    steady: QuasiSteady,
}

impl LateralAccelerometer {
    /// The learner at the prior, `None` when `ay_offset_std` and the gain's std are both 0 (`ay`
    /// taken as it comes). The gain's std is `ay_gain_std` where `learns_gain` (the model's
    /// filter does not estimate the gain itself), else 0.
    pub fn from_parameters(v: &Variables, learns_gain: bool) -> Result<Option<Self>, String> {
        for (name, std) in [
            ("ay_offset_std", v.ay_offset_std),
            ("ay_gain_std", v.ay_gain_std),
        ] {
            if !(std.is_finite() && std >= 0.0) {
                return Err(format!(
                    "parameter {name} = {std}; expected a finite value >= 0 (0: not learned)"
                ));
            }
        }
        let gain_std = if learns_gain { v.ay_gain_std } else { 0.0 };
        if v.ay_offset_std == 0.0 && gain_std == 0.0 {
            return Ok(None);
        }
        let stationary = Vector2::new(v.ay_offset_std.powi(2), gain_std.powi(2));
        let process =
            |variance| GaussMarkov::new(variance, v.sample_time, AY_CALIBRATION_TIME_CONSTANT);
        let settings = Settings {
            offset: process(stationary[0]),
            gain: process(stationary[1]),
            learns_gain: gain_std > 0.0,
            yaw_rate_variance: v.measurement_noise_std_yaw_rate.powi(2),
            smoothing: 1.0 - (-v.sample_time / QUASI_STEADY_FILTER_TIME).exp(),
            sample_time: v.sample_time,
        };
        Ok(Some(Self {
            settings,
            estimate: Vector2::zeros(),
            covariance: Matrix2::from_diagonal(&stationary),
            steady: QuasiSteady {
                steering: f64::NAN,
                yaw_rate: f64::NAN,
            },
        }))
    }

    /// `tuned`'s settings with this estimate (a tunable parameter changed).
    pub fn retuned(&self, tuned: Self) -> Self {
        Self {
            settings: tuned.settings,
            ..*self
        }
    }

    /// `ay_meas` as the car's lateral acceleration, `(ay − b) / (1 + e)`.
    pub fn corrected(&self, ay: f64) -> f64 {
        (ay - self.estimate[0]) / (1.0 + self.estimate[1])
    }

    /// One sample: the prediction, then the update where the car is quasi-steady.
    pub fn step(&mut self, sample: &AySample) {
        let s = self.settings;
        // Both processes share `τ`, hence `a`.
        let a = s.offset.decay;
        self.estimate *= a;
        let process = Vector2::new(s.offset.process_variance, s.gain.process_variance);
        self.covariance = self.covariance * (a * a) + Matrix2::from_diagonal(&process);
        let steady = self
            .steady
            .step(sample.steering, sample.yaw_rate, s.smoothing);
        let Some(speed) = sample.speed.filter(|speed| speed.abs() >= MIN_SPEED) else {
            return;
        };
        if !(steady && sample.ay.is_finite() && !sample.all_zero) {
            return;
        }
        let kinematic = sample.yaw_rate * speed;
        let mut noise = sample.ay_variance
            + speed * speed * s.yaw_rate_variance
            + white_equivalent(QUASI_STEADY_TIME * QUASI_STEADY_STD.powi(2), s.sample_time);
        let observation = if kinematic.abs() >= GAIN_ACCELERATION && s.learns_gain {
            Vector2::new(1.0, kinematic)
        } else if kinematic.abs() < STRAIGHT_ACCELERATION {
            noise += self.covariance[(1, 1)] * kinematic * kinematic
                + white_equivalent(
                    ROAD_CROSSFALL_TIME * ROAD_CROSSFALL_ACCELERATION.powi(2),
                    s.sample_time,
                );
            Vector2::new(1.0, 0.0)
        } else {
            return;
        };
        let innovation = sample.ay - kinematic * (1.0 + self.estimate[1]) - self.estimate[0];
        let spread = self.covariance * observation;
        let innovation_variance = observation.dot(&spread) + noise;
        if innovation * innovation > GATE_SIGMAS * GATE_SIGMAS * innovation_variance {
            return;
        }
        // The Kalman update in Joseph form (000: 4.64-4.75).
        let gain = spread / innovation_variance;
        self.estimate += gain * innovation;
        let keep = Matrix2::identity() - gain * observation.transpose();
        self.covariance =
            keep * self.covariance * keep.transpose() + gain * gain.transpose() * noise;
    }

    /// The learner as part of the FMU state.
    pub fn write(&self, writer: &mut StateWriter) {
        writer.f64s(self.estimate.as_slice());
        writer.f64s(self.covariance.as_slice());
        writer.f64(self.steady.steering);
        writer.f64(self.steady.yaw_rate);
    }

    /// The learner [`Self::write`] wrote.
    pub fn read(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        reader.f64s_into(
            self.estimate.as_mut_slice(),
            "lateral accelerometer offset and gain",
        )?;
        reader.f64s_into(
            self.covariance.as_mut_slice(),
            "lateral accelerometer covariance",
        )?;
        self.steady.steering = reader.f64("low-pass steering angle")?;
        self.steady.yaw_rate = reader.f64("low-pass yaw rate")?;
        Ok(())
    }
}
