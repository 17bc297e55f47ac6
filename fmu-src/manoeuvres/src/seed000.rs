//! The four seed-000 manoeuvres (000: ch. 7; SPEC §7) for the model and filter tests that drive
//! a model directly, without co-simulation. Each is the library manoeuvre of the same name
//! ([`crate::library`]); the numbers below are the ones the library is built from.
//!
//! Durations the seed leaves open are the project's choice and defined here once: every
//! manoeuvre lasts [`SEED_MANOEUVRE_DURATION`] = 12 s (the braking manoeuvre "holds to 12 s",
//! 000: fig. 7.11 text; the others use the same horizon), and the step steer steps at 4.0 s
//! ("nach etwa 4 Sekunden", 000: ch. 7 intro). The vehicle starts at `vx = 18 m/s`,
//! `ωF = ωR = 60 rad/s` (000: ch. 7 intro), i.e. freely rolling with `r_w = 0.3 m`.

use nalgebra::Vector3;
use serde::Serialize;

use crate::{library, Manoeuvre};

/// Length of every seed-000 manoeuvre, s.
pub const SEED_MANOEUVRE_DURATION: f64 = 12.0;
/// Initial longitudinal speed of the seed-000 manoeuvres, m/s (000: ch. 7 intro).
pub const SEED_INITIAL_SPEED: f64 = 18.0;
/// Initial wheel speeds of the seed-000 manoeuvres, rad/s (000: ch. 7 intro).
pub const SEED_INITIAL_WHEEL_SPEED: f64 = 60.0;
/// Time at which the steering ramps and the step start, s (000: fig. 7.1, 7.18).
pub const STEER_START_TIME: f64 = 4.0;
/// Steering ramp rate, rad/s (000: 7.1 "0.07 rad/s bzw. 4 Grad/s").
pub const STEER_RAMP_RATE: f64 = 0.07;
/// End value of the moderate ramp, rad (000: 7.1, 2°).
pub const MODERATE_RAMP_ANGLE: f64 = 0.035;
/// End value of the high ramp, rad (000: 7.2, "ca. 0.122 rad bzw. 7 Grad").
pub const HIGH_RAMP_ANGLE: f64 = 0.122;
/// Step-steer angle, rad (000: fig. 7.18, 2°).
pub const STEP_STEER_ANGLE: f64 = 2.0 * crate::DEG;
/// Start of the brake ramp, s (000: fig. 7.11).
pub const BRAKE_START_TIME: f64 = 9.0;
/// Duration of the brake ramp, s (000: fig. 7.11).
pub const BRAKE_RAMP_DURATION: f64 = 2.0;
/// Final brake-torque magnitude, N·m (seed: `M_B = −2000 N·m`, 000: fig. 7.11).
pub const BRAKE_TORQUE_FINAL: f64 = 2000.0;

/// The four seed-000 manoeuvres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeedManoeuvre {
    /// Steering ramp to 0.035 rad, moderate lateral acceleration (000: 7.1).
    ModerateRamp,
    /// Steering ramp to 0.122 rad, high lateral acceleration (000: 7.2).
    HighRamp,
    /// High ramp plus braking from 9 s (000: 7.3).
    HighRampBraking,
    /// Steering step 0 → 2° at 4 s (000: 7.4/7.5, fig. 7.18).
    StepSteer,
}

/// The driver's open-loop signals at one time: what a model takes as its input.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DriverSignals {
    /// Road-wheel steering angle, rad, positive left.
    pub steering_angle: f64,
    /// Drive torque at the driven axle, N·m.
    pub drive_torque: f64,
    /// Brake torque magnitude, N·m, ≥ 0.
    pub brake_torque: f64,
}

impl DriverSignals {
    /// `[steering_angle, drive_torque, brake_torque]`, the models' input vector.
    pub fn to_vector(&self) -> Vector3<f64> {
        Vector3::new(self.steering_angle, self.drive_torque, self.brake_torque)
    }
}

impl SeedManoeuvre {
    /// All four, in the order of seed 000.
    pub const ALL: [SeedManoeuvre; 4] = [
        SeedManoeuvre::ModerateRamp,
        SeedManoeuvre::HighRamp,
        SeedManoeuvre::HighRampBraking,
        SeedManoeuvre::StepSteer,
    ];

    /// Short name for tables.
    pub fn name(&self) -> &'static str {
        match self {
            SeedManoeuvre::ModerateRamp => "moderate ramp",
            SeedManoeuvre::HighRamp => "high ramp",
            SeedManoeuvre::HighRampBraking => "high ramp + braking",
            SeedManoeuvre::StepSteer => "2 deg step steer",
        }
    }

    /// Its name in the library ([`crate::LIBRARY`]).
    pub fn library_name(&self) -> &'static str {
        match self {
            SeedManoeuvre::ModerateRamp => "seed000_ramp_moderate_ay",
            SeedManoeuvre::HighRamp => "seed000_ramp_high_ay",
            SeedManoeuvre::HighRampBraking => "seed000_ramp_high_ay_braking",
            SeedManoeuvre::StepSteer => "seed000_step_steer_2deg",
        }
    }

    /// The library manoeuvre.
    pub fn manoeuvre(&self) -> Manoeuvre {
        library(self.library_name()).expect("every seed-000 manoeuvre is in the library")
    }

    /// Driver signals at time `t` (s). The brake is held beyond the 12 s horizon (a time a
    /// rounding step past it must not release it).
    pub fn input_at(&self, t: f64) -> DriverSignals {
        let manoeuvre = self.manoeuvre();
        DriverSignals {
            steering_angle: manoeuvre.open_loop_steering(t).unwrap_or(0.0),
            drive_torque: 0.0,
            brake_torque: manoeuvre.brake_torque(t.min(SEED_MANOEUVRE_DURATION)),
        }
    }
}

/// The numbers of this module as a table for other languages (the Python tests read
/// `fmu-src/manoeuvres/seed000_manoeuvres.toml`, which a test keeps equal to this).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Seed000Table {
    pub manoeuvre_duration: f64,
    pub initial_speed: f64,
    pub initial_wheel_speed: f64,
    pub steer_start_time: f64,
    pub steer_ramp_rate: f64,
    pub moderate_ramp_angle: f64,
    pub high_ramp_angle: f64,
    pub step_steer_angle: f64,
    pub brake_start_time: f64,
    pub brake_ramp_duration: f64,
    pub brake_torque_final: f64,
}

impl Seed000Table {
    pub const TABLE: Seed000Table = Seed000Table {
        manoeuvre_duration: SEED_MANOEUVRE_DURATION,
        initial_speed: SEED_INITIAL_SPEED,
        initial_wheel_speed: SEED_INITIAL_WHEEL_SPEED,
        steer_start_time: STEER_START_TIME,
        steer_ramp_rate: STEER_RAMP_RATE,
        moderate_ramp_angle: MODERATE_RAMP_ANGLE,
        high_ramp_angle: HIGH_RAMP_ANGLE,
        step_steer_angle: STEP_STEER_ANGLE,
        brake_start_time: BRAKE_START_TIME,
        brake_ramp_duration: BRAKE_RAMP_DURATION,
        brake_torque_final: BRAKE_TORQUE_FINAL,
    };
}
