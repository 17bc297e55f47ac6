//! The gyro's offset, learned where the car's yaw rate is known without the filter.
//!
//! A series-production yaw-rate sensor reads the car's yaw rate plus an offset of a few tenths
//! of a degree per second that drifts with temperature; an electronic stability control
//! compensates it while the car stands and while it drives straight (van Zanten, "Bosch ESP
//! Systems: 5 Years of Experience", SAE 2000-01-1633, the sensor monitoring). Every filter here
//! takes the gyro as the car's yaw rate, and an offset the model cannot explain goes into the
//! sideslip: 0.005 rad/s (0.29°/s) more than doubled the grip model's campaign error (harness
//! robustness with the ReferenceVehicle's `bias_yaw_rate_meas`; fmu-src/vehicle-state-estimator/
//! README.md, "The gyro's offset").
//!
//! So the runner keeps a scalar Kalman filter of the offset `b`, ahead of every estimator and
//! every model: a first-order Gauss-Markov process about 0 of stationary std
//! `yaw_rate_offset_std` and correlation time [`YAW_RATE_OFFSET_TIME_CONSTANT`] (Brown and
//! Hwang, Introduction to Random Signals and Applied Kalman Filtering, 4th ed. 2012, §2.9),
//! `b⁻ = a b`, `P⁻ = a² P + σb² (1 − a²)`, updated with `z = r_meas − r_ref` where a reference
//! yaw rate `r_ref` holds without the filter ([`reference`]):
//!
//! - **creeping or standing** (the measured speed below [`CREEP_SPEED`]): the tyres do not slip
//!   and the yaw rate is the steering geometry's, `r = vx tan δ / l` (Ackermann; Rajamani,
//!   Vehicle Dynamics and Control, 2nd ed., eq. 2.30 with the sideslip's rate 0), exactly 0 at a
//!   stop, taken where it is small ([`CREEP_MAX_YAW_RATE`]);
//! - **driving straight** (road-wheel angle below [`STRAIGHT_STEERING`] and `|ay|` below
//!   [`STRAIGHT_AY`]): the heading of a car on a straight road does not change on average, so
//!   `r_ref = 0` with the driver's small corrections and the road's own bends as the
//!   reference's error ([`STRAIGHT_WANDER_STD`] correlated over [`STRAIGHT_WANDER_TIME`],
//!   [`ROAD_BEND_YAW_RATE`] over [`ROAD_BEND_TIME`], as white noise of the same low-frequency
//!   density, `2 τ σ² / T` per sample): minutes of straight driving teach what a stop teaches
//!   in a second.
//!
//! Elsewhere (in a corner) `b` is predicted only. The estimators get `r_meas − b`. A sample
//! whose innovation lies outside [`GATE_SIGMAS`] standard deviations (a glitch), and one whose
//! sensors all read 0 (a dropout, `Sensors::all_zero`), teaches nothing.

use fmi_export::{StateError, StateReader, StateWriter};

use crate::gauss_markov::{white_equivalent, GaussMarkov, ScalarEstimate};
use crate::model_description::Variables;

/// Correlation time of the gyro's offset, s: it drifts with the sensor's temperature, over
/// minutes (as the accelerometer's, `speed_filter::AX_OFFSET_TIME_CONSTANT`).
pub const YAW_RATE_OFFSET_TIME_CONSTANT: f64 = 600.0;

/// The measured speed below which the yaw rate is the steering geometry's, m/s: walking pace,
/// where a car's lateral acceleration stays below 0.4 m/s² even at full lock and its tyres'
/// slip angles are tenths of a degree.
pub const CREEP_SPEED: f64 = 1.0;

/// The steering geometry's error as a yaw rate while creeping, rad/s (the tyres' slip and the
/// body's motion on its springs): 0.1°/s.
pub const CREEP_REFERENCE_STD: f64 = 0.002;

/// The steering geometry's relative error while creeping: a single track stands for two
/// steered wheels whose angles differ, and a real steering's angle for the road wheels' only
/// up to its elasticity.
pub const CREEP_RELATIVE_ERROR: f64 = 0.1;

/// The largest steering geometry's yaw rate taken as a reference, rad/s: measured on the
/// ReferenceVehicle's full vehicle at 45° of road-wheel angle and under 1 m/s, the single
/// track's `vx tan δ / l` was off by about 0.02 rad/s for over a second, and the offset learned
/// from it ran to −0.014 rad/s where the sensor had none. At this limit the relative error
/// above is at most 0.005 rad/s.
pub const CREEP_MAX_YAW_RATE: f64 = 0.05;

/// The road-wheel angle below which the car counts as driving straight, rad (0.11°, about 2° at
/// the steering wheel): the steering geometry's yaw rate is then below 0.02 rad/s at 25 m/s.
pub const STRAIGHT_STEERING: f64 = 0.002;

/// The measured `|ay|` below which the car counts as driving straight, m/s² (with the
/// accelerometer's noise and a road's cross slope of 2.5 % in it).
pub const STRAIGHT_AY: f64 = 0.5;

/// The yaw rate of a car kept straight by its driver, one standard deviation, rad/s (0.3°/s),
/// and how long it is correlated, s: the small corrections about the road's heading.
pub const STRAIGHT_WANDER_STD: f64 = 0.005;
pub const STRAIGHT_WANDER_TIME: f64 = 0.2;

/// The yaw rate of a straight's own bends, one standard deviation, rad/s, and how long it is
/// correlated, s: a road counted straight by its steering angle and `ay` still curves (a
/// 3 km radius at 30 m/s turns the car at 0.01 rad/s for the 150 m of a bend). Without it the
/// learner took the bends of a real track's straights for an offset: up to 0.006 rad/s on the
/// MBDS recording, whose gyro the heading closes to within 0.0002 rad/s over a lap.
pub const ROAD_BEND_YAW_RATE: f64 = 0.01;
pub const ROAD_BEND_TIME: f64 = 5.0;

/// The gate on the innovation, in standard deviations of `P⁻ + R`: a yaw rate farther from the
/// reference is a glitch or a car that turns where none is expected (a turntable, a ferry).
pub const GATE_SIGMAS: f64 = 5.0;

/// The learner's fixed settings, from the parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Settings {
    /// The offset's process: `σb² = yaw_rate_offset_std²`, `τ` =
    /// [`YAW_RATE_OFFSET_TIME_CONSTANT`].
    process: GaussMarkov,
    /// The gyro's noise variance, `measurement_noise_std_yaw_rate²`.
    gyro_variance: f64,
    /// The axle distance `l`, m.
    wheelbase: f64,
    /// `T`, s.
    sample_time: f64,
}

/// The offset filter: its settings and its estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawRateOffset {
    settings: Settings,
    /// `b`, rad/s.
    pub offset: f64,
    /// `P`, (rad/s)².
    pub variance: f64,
}

impl YawRateOffset {
    /// The learner at the prior (0 with `yaw_rate_offset_std²`), `None` when
    /// `yaw_rate_offset_std` is 0 (the gyro taken as it comes).
    pub fn from_parameters(v: &Variables) -> Result<Option<Self>, String> {
        let std = v.yaw_rate_offset_std;
        if !(std.is_finite() && std >= 0.0) {
            return Err(format!(
                "parameter yaw_rate_offset_std = {std}; expected a finite value >= 0 rad/s (0: the gyro taken as it comes)"
            ));
        }
        if std == 0.0 {
            return Ok(None);
        }
        let settings = Settings {
            process: GaussMarkov::new(std * std, v.sample_time, YAW_RATE_OFFSET_TIME_CONSTANT),
            gyro_variance: v.measurement_noise_std_yaw_rate.powi(2),
            wheelbase: v.cog_to_front_axle + v.cog_to_rear_axle,
            sample_time: v.sample_time,
        };
        Ok(Some(Self {
            settings,
            offset: 0.0,
            variance: std * std,
        }))
    }

    /// `tuned`'s settings with this estimate (a tunable parameter changed).
    pub fn retuned(&self, tuned: Self) -> Self {
        Self {
            settings: tuned.settings,
            ..*self
        }
    }

    /// One sample: the prediction, then the update where [`reference`] gives a yaw rate.
    pub fn step(&mut self, sample: &OffsetSample) {
        let s = &self.settings;
        let measurement = (sample.yaw_rate.is_finite() && !sample.all_zero)
            .then(|| reference(sample, s))
            .flatten()
            .map(|(reference, reference_variance)| {
                (
                    sample.yaw_rate - reference,
                    s.gyro_variance + reference_variance,
                )
            });
        let mut estimate = ScalarEstimate {
            mean: self.offset,
            variance: self.variance,
        };
        estimate.step(&s.process, measurement, GATE_SIGMAS);
        self.offset = estimate.mean;
        self.variance = estimate.variance;
    }

    /// The estimate as part of the FMU state.
    pub fn write(&self, writer: &mut StateWriter) {
        writer.f64(self.offset);
        writer.f64(self.variance);
    }

    /// The estimate [`Self::write`] wrote.
    pub fn read(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        self.offset = reader.f64("yaw-rate offset")?;
        self.variance = reader.f64("yaw-rate offset variance")?;
        Ok(())
    }
}

/// What one sample gives the learner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffsetSample {
    /// `yaw_rate_meas`, rad/s, and `ay_meas`, m/s² (NaN: missing).
    pub yaw_rate: f64,
    pub ay: f64,
    /// Every sensor reads exactly 0 (a dropout; `runner::Sensors::all_zero`).
    pub all_zero: bool,
    /// The road-wheel angle, rad.
    pub steering: f64,
    /// The measured speed, m/s, and its standard deviation (`runner::MeasuredSpeed`), if any.
    pub speed: Option<(f64, f64)>,
}

/// The yaw rate the car has without the filter, with its error variance, where one is known
/// (module docs): the steering geometry's while creeping or standing, 0 while driving straight.
fn reference(sample: &OffsetSample, s: &Settings) -> Option<(f64, f64)> {
    let (speed, speed_std) = sample.speed.filter(|(speed, _)| speed.is_finite())?;
    let per_speed = sample.steering.tan() / s.wheelbase;
    if speed.abs() < CREEP_SPEED {
        let rate = speed * per_speed;
        let variance = (speed_std * per_speed).powi(2)
            + CREEP_REFERENCE_STD.powi(2)
            + (CREEP_RELATIVE_ERROR * rate).powi(2);
        return (rate.abs() <= CREEP_MAX_YAW_RATE).then_some((rate, variance));
    }
    let straight = sample.steering.abs() < STRAIGHT_STEERING && sample.ay.abs() < STRAIGHT_AY;
    straight.then(|| {
        // what the steering geometry's yaw rate, `vx tan δ / l`, leaves unexplained
        let geometry = speed * per_speed;
        let wander = STRAIGHT_WANDER_STD.powi(2) + geometry * geometry;
        let density = STRAIGHT_WANDER_TIME * wander + ROAD_BEND_TIME * ROAD_BEND_YAW_RATE.powi(2);
        (0.0, white_equivalent(density, s.sample_time))
    })
}
