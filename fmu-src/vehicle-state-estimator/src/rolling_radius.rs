//! The wheels' effective rolling radii, learned where the measured speed gives them.
//!
//! A tyre's effective rolling radius is not its nominal one: inflation pressure, tread wear,
//! wheel load and speed move it by 1-3 % (Pacejka, Tire and Vehicle Dynamics, 3rd ed. 2012,
//! §7.2.2, the effective rolling radius; Gillespie, Fundamentals of Vehicle Dynamics, 1992,
//! ch. 10), so a free-rolling wheel's `ω r` differs from the car's speed by that much. The
//! models read the difference as longitudinal slip, and a tyre model with combined slip
//! (model A's HSRI tyre, 000: 5.70) gives a slipping wheel less side force, so a radius error of
//! 3.6 % on each axle made model A's sideslip twice the car's in every fast corner of the MBDS
//! track recording (laps 2-6: 1.86° where zero sideslip scores 1.82°). An electronic stability
//! control learns each wheel's rolling circumference while the car drives straight without
//! traction (van Zanten, "Bosch ESP Systems: 5 Years of Experience", SAE 2000-01-1633, the
//! sensor monitoring); the runner does the same ahead of every estimator, where a measured
//! speed independent of the wheels is there (`vx_meas`, as read by the model).
//!
//! Per axle the relative radius error `ρ` (the wheel rolls as if its radius were `r (1 + ρ)`) is
//! a scalar Kalman filter: a first-order Gauss-Markov process about 0 of stationary std
//! `wheel_radius_std` and correlation time [`RADIUS_TIME_CONSTANT`] (Brown and Hwang,
//! Introduction to Random Signals and Applied Kalman Filtering, 4th ed. 2012, §2.9), updated
//! with `z = v_wheel / (ω r) − 1` where the wheel rolls freely ([`free_rolling`]): `v_wheel` the
//! wheel centre's speed along the wheel from the measured speed, `vx cos δ + lf r sin δ` in
//! front and `vx` at the rear (the lateral velocity's share, `vy sin δ`, is below 0.1 % at the
//! steering angles taken). The estimators get `ω (1 + ρ)`, the wheel's speed as if it rolled on
//! its nominal radius.

use fmi_export::{StateError, StateReader, StateWriter};

use crate::gauss_markov::{white_equivalent, GaussMarkov, ScalarEstimate};
use crate::model_description::Variables;

/// Correlation time of a radius error, s: a tyre's pressure and temperature settle over
/// minutes of driving.
pub const RADIUS_TIME_CONSTANT: f64 = 600.0;

/// The measured speed from which a wheel is taken as a reference, m/s: above it a wheel
/// speed's quantisation and noise stay below 0.1 % of the speed.
pub const MIN_LEARNING_SPEED: f64 = 5.0;

/// The largest `|ax_meas|` of a free-rolling wheel, m/s²: a driven wheel's slip at this
/// traction is about 0.1-0.2 % (a passenger-car tyre's longitudinal slip stiffness of 15-20
/// times its load), well below the radius errors learned.
pub const FREE_ROLLING_AX: f64 = 0.5;

/// The largest road-wheel angle taken, rad (1.1°), and the largest `|ay_meas|`, m/s²: the
/// car drives nearly straight, so the front wheel's speed along it is the measured speed's
/// projection and no wheel slips sideways.
pub const STRAIGHT_STEERING: f64 = 0.02;
pub const STRAIGHT_AY: f64 = 2.0;

/// The slip a free-rolling wheel still has (rolling resistance, the traction the
/// [`FREE_ROLLING_AX`] limit allows), as a relative speed error.
pub const FREE_ROLLING_SLIP_STD: f64 = 0.002;

/// How long the reference's error (the measured speed's, the slip's) is correlated, s: a
/// speed sensor's error and a wheel's slip last over a gust or a gradient.
pub const REFERENCE_ERROR_TIME: f64 = 0.5;

/// The gate on the innovation, in standard deviations: a wheel farther from the reference is
/// spinning, locked or glitching.
pub const GATE_SIGMAS: f64 = 5.0;

/// The learner's fixed settings, from the parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Settings {
    /// The error's process: `σρ² = wheel_radius_std²`, `τ` = [`RADIUS_TIME_CONSTANT`].
    process: GaussMarkov,
    /// The nominal radii front and rear, m.
    radius: [f64; 2],
    /// The wheel speeds' noise, front and rear, rad/s.
    wheel_std: [f64; 2],
    /// The measured speed's noise, m/s.
    speed_std: f64,
    /// The centre of gravity to the front axle, m.
    cog_to_front_axle: f64,
    /// `T`, s.
    sample_time: f64,
}

/// The learner of both axles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollingRadius {
    settings: Settings,
    /// `ρ` and its variance, front and rear.
    pub axles: [ScalarEstimate; 2],
}

/// What one sample gives the learner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusSample {
    /// `omega_front_meas`, `omega_rear_meas`, rad/s (NaN: missing).
    pub omega: [f64; 2],
    /// The measured speed `vx_meas` where the model reads it, m/s (NaN: none).
    pub speed: f64,
    /// `ax_meas` and `ay_meas`, m/s², and the gyro's yaw rate, rad/s (NaN: missing).
    pub ax: f64,
    pub ay: f64,
    pub yaw_rate: f64,
    /// The road-wheel angle, rad.
    pub steering: f64,
}

impl RollingRadius {
    /// The learner at the prior (0 with `wheel_radius_std²`), `None` when `wheel_radius_std` is
    /// 0 (the wheels taken at their nominal radii).
    pub fn from_parameters(v: &Variables) -> Result<Option<Self>, String> {
        let std = v.wheel_radius_std;
        if !(std.is_finite() && (0.0..=0.5).contains(&std)) {
            return Err(format!(
                "parameter wheel_radius_std = {std}; expected a relative std from 0 to 0.5 \
                 (0: the wheels taken at their nominal radii)"
            ));
        }
        if std == 0.0 {
            return Ok(None);
        }
        let settings = Settings {
            process: GaussMarkov::new(std * std, v.sample_time, RADIUS_TIME_CONSTANT),
            radius: [v.wheel_radius_front, v.wheel_radius_rear],
            wheel_std: [
                v.measurement_noise_std_omega_front,
                v.measurement_noise_std_omega_rear,
            ],
            speed_std: v.measurement_noise_std_vx,
            cog_to_front_axle: v.cog_to_front_axle,
            sample_time: v.sample_time,
        };
        let prior = ScalarEstimate {
            mean: 0.0,
            variance: std * std,
        };
        Ok(Some(Self {
            settings,
            axles: [prior; 2],
        }))
    }

    /// `tuned`'s settings with this estimate (a tunable parameter changed).
    pub fn retuned(&self, tuned: Self) -> Self {
        Self {
            settings: tuned.settings,
            ..*self
        }
    }

    /// One sample: the prediction, then the update of each axle whose wheel rolls freely.
    pub fn step(&mut self, sample: &RadiusSample) {
        let s = self.settings;
        let references = free_rolling(sample, &s);
        for (axle, estimate) in self.axles.iter_mut().enumerate() {
            let omega = sample.omega[axle];
            let measurement = references[axle]
                .filter(|_| omega.is_finite() && omega > 0.0)
                .map(|reference| {
                    let relative_noise = (s.speed_std / reference).powi(2)
                        + (s.wheel_std[axle] / omega).powi(2)
                        + FREE_ROLLING_SLIP_STD.powi(2);
                    let noise =
                        white_equivalent(REFERENCE_ERROR_TIME * relative_noise, s.sample_time);
                    (reference / (omega * s.radius[axle]) - 1.0, noise)
                });
            estimate.step(&s.process, measurement, GATE_SIGMAS);
        }
    }

    /// The wheel speeds as if they rolled on their nominal radii, `ω (1 + ρ)`.
    pub fn corrected(&self, omega: [f64; 2]) -> [f64; 2] {
        std::array::from_fn(|axle| omega[axle] * (1.0 + self.axles[axle].mean))
    }

    /// The estimate as part of the FMU state.
    pub fn write(&self, writer: &mut StateWriter) {
        for axle in &self.axles {
            writer.f64(axle.mean);
            writer.f64(axle.variance);
        }
    }

    /// The estimate [`Self::write`] wrote.
    pub fn read(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        for axle in &mut self.axles {
            axle.mean = reader.f64("rolling-radius error")?;
            axle.variance = reader.f64("rolling-radius error variance")?;
        }
        Ok(())
    }
}

/// Each wheel centre's speed along its wheel, front and rear, where the wheels roll freely
/// (module docs): a measured speed of at least [`MIN_LEARNING_SPEED`], nearly straight, no
/// traction or braking to speak of.
fn free_rolling(sample: &RadiusSample, s: &Settings) -> [Option<f64>; 2] {
    let rolling_freely = sample.speed.is_finite()
        && sample.speed >= MIN_LEARNING_SPEED
        && sample.ax.abs() <= FREE_ROLLING_AX
        && sample.ay.abs() <= STRAIGHT_AY
        && sample.steering.abs() <= STRAIGHT_STEERING
        && sample.yaw_rate.is_finite();
    if !rolling_freely {
        return [None; 2];
    }
    let (sin, cos) = sample.steering.sin_cos();
    let front = sample.speed * cos + s.cog_to_front_axle * sample.yaw_rate * sin;
    [Some(front), Some(sample.speed)]
}
