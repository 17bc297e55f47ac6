//! The driver inputs of the seed-000 manoeuvres (000: ch. 7; SPEC §7), as functions of time.
//!
//! Durations the seed leaves open are the project's choice and defined here once: every
//! manoeuvre lasts [`SEED_MANOEUVRE_DURATION`] = 12 s (the braking manoeuvre "holds to 12 s",
//! 000: fig. 7.11 text; the others use the same horizon), and the step steer steps at 4.0 s
//! ("nach etwa 4 Sekunden", 000: ch. 7 intro). The vehicle starts at `vx = 18 m/s`,
//! `ωF = ωR = 60 rad/s` (000: ch. 7 intro), i.e. freely rolling with `r_w = 0.3 m`.

use crate::driver_input::DriverInput;

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
pub const STEP_STEER_ANGLE: f64 = 2.0 * std::f64::consts::PI / 180.0;
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

    /// Driver input at time `t` (s).
    pub fn input_at(&self, t: f64) -> DriverInput {
        let ramp = |limit: f64| ((t - STEER_START_TIME).max(0.0) * STEER_RAMP_RATE).min(limit);
        match self {
            SeedManoeuvre::ModerateRamp => DriverInput {
                steering_angle: ramp(MODERATE_RAMP_ANGLE),
                ..DriverInput::default()
            },
            SeedManoeuvre::HighRamp => DriverInput {
                steering_angle: ramp(HIGH_RAMP_ANGLE),
                ..DriverInput::default()
            },
            SeedManoeuvre::HighRampBraking => DriverInput {
                steering_angle: ramp(HIGH_RAMP_ANGLE),
                drive_torque: 0.0,
                brake_torque: ((t - BRAKE_START_TIME).max(0.0) / BRAKE_RAMP_DURATION).min(1.0)
                    * BRAKE_TORQUE_FINAL,
            },
            SeedManoeuvre::StepSteer => DriverInput {
                steering_angle: if t >= STEER_START_TIME {
                    STEP_STEER_ANGLE
                } else {
                    0.0
                },
                ..DriverInput::default()
            },
        }
    }
}
