//! The manoeuvre library: driver inputs (steering, drive and brake torque) and initial speed,
//! as pure signal definitions (no model, no FMI).
//!
//! Every manoeuvre of the seeds is defined exactly once here ([`library`]); scenario files refer
//! to them by name, the models' tests drive the seed-000 ones through [`seed000`], and the Python
//! tests read [`seed000`]'s numbers from the generated table `seed000_manoeuvres.toml`. The
//! numbers the seeds leave open (where a manoeuvre ends, how fast a "step" rises, the wobble
//! frequency, ...) are chosen here once and listed by [`describe`] in the report.
//!
//! Conventions (SPEC section 2): `steering_angle` is the front road-wheel angle [rad], positive
//! to the left; `steering_wheel_angle = steering_angle * i_L` with `i_L = 14.97` (000: table 5.1);
//! `brake_torque >= 0` is the magnitude of the total braking torque (seed 000's `M_B` is
//! `-brake_torque`, so its "ramp to -2000 N·m" is `+2000` here); torques in N·m, speeds in m/s.

use serde::Deserialize;

pub mod low_speed;
pub mod seed000;

pub use low_speed::LowSpeedCourse;

use seed000::{
    BRAKE_RAMP_DURATION, BRAKE_START_TIME, BRAKE_TORQUE_FINAL, HIGH_RAMP_ANGLE,
    MODERATE_RAMP_ANGLE, SEED_INITIAL_SPEED, SEED_MANOEUVRE_DURATION, STEER_RAMP_RATE,
    STEER_START_TIME, STEP_STEER_ANGLE,
};

/// Steering ratio i_L (000: table 5.1): the one value of the master and the manoeuvres.
pub const STEERING_RATIO: f64 = 14.97;
const DEG: f64 = std::f64::consts::PI / 180.0;
const KMH: f64 = 1.0 / 3.6;
/// Standard gravity g, m/s² (3rd CGPM, 1901): the unit of the FMVSS 126 0.3 g criterion and of
/// signals recorded in g. The models' gravitational acceleration is `vehicle_models::GRAVITY`.
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// A signal a manoeuvre provides. Scenario `[[input]]` entries name these.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Front road-wheel angle [rad].
    SteeringAngle,
    /// Steering-wheel angle [rad] = steering_angle * i_L.
    SteeringWheelAngle,
    /// Drive torque at the driven (front) axle [N·m].
    DriveTorque,
    /// Braking torque magnitude [N·m], >= 0.
    BrakeTorque,
    /// Initial longitudinal speed [m/s] (constant; usually bound to a parameter).
    InitialSpeed,
}

impl Channel {
    pub const ALL: [Channel; 5] = [
        Channel::SteeringAngle,
        Channel::SteeringWheelAngle,
        Channel::DriveTorque,
        Channel::BrakeTorque,
        Channel::InitialSpeed,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Channel::SteeringAngle => "steering_angle",
            Channel::SteeringWheelAngle => "steering_wheel_angle",
            Channel::DriveTorque => "drive_torque",
            Channel::BrakeTorque => "brake_torque",
            Channel::InitialSpeed => "initial_speed",
        }
    }

    pub fn from_name(name: &str) -> Option<Channel> {
        Channel::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// A steering ramp (seed 000, ch. 7.1/7.2): 0 until `start_time`, then `rate` up to `final_angle`,
/// hold; optionally a brake ramp (ch. 7.2.1).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteerRamp {
    pub start_time: f64,
    /// Road-wheel steering rate [rad/s].
    pub rate: f64,
    /// Road-wheel angle held after the ramp [rad].
    pub final_angle: f64,
    pub initial_speed: f64,
    pub duration: f64,
    #[serde(default)]
    pub brake: Option<BrakeRamp>,
}

/// Brake torque: 0 until `start_time`, linear to `torque` within `ramp_duration`, held until
/// `end_time`, 0 afterwards.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrakeRamp {
    pub start_time: f64,
    pub ramp_duration: f64,
    /// Braking torque magnitude [N·m] (>= 0).
    pub torque: f64,
    pub end_time: f64,
}

/// A steering step: 0 until `time`, then linear to `angle` within `rise_time` (0 = ideal step).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepSteer {
    pub time: f64,
    /// Road-wheel angle after the step [rad].
    pub angle: f64,
    pub rise_time: f64,
    pub initial_speed: f64,
    pub duration: f64,
}

/// One sine period of the steering wheel with different amplitudes for the left and right lobe
/// (seed 001 "Anpendeln": 150 deg left, then 225 deg right).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wobble {
    pub start_time: f64,
    pub frequency: f64,
    /// Steering-wheel amplitude of the first (left) half period [rad].
    pub left_amplitude: f64,
    /// Steering-wheel amplitude of the second (right) half period [rad].
    pub right_amplitude: f64,
    pub initial_speed: f64,
    pub duration: f64,
}

/// FMVSS 126 slowly increasing steer: steering wheel ramps at `rate` from `start_time`; a speed
/// controller holds `initial_speed` (needs feedback).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlowlyIncreasingSteer {
    pub start_time: f64,
    /// Steering-wheel rate [rad/s].
    pub rate: f64,
    pub initial_speed: f64,
    pub duration: f64,
    /// Speed controller gain [N·m per m/s].
    pub speed_gain: f64,
}

/// FMVSS 126 sine with dwell: steering wheel `A sin(2 pi f t)`; at the second peak (3/4 period)
/// the angle is held for `dwell`, then the sine completes its period.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SineWithDwell {
    pub start_time: f64,
    pub frequency: f64,
    pub dwell: f64,
    /// Steering-wheel amplitude [rad]. The scenario may instead derive it from a slowly
    /// increasing steer run (`[manoeuvre.amplitude_from_sis]`).
    pub amplitude: f64,
    pub initial_speed: f64,
    pub duration: f64,
}

/// The standard whose course a [`DoubleLaneChange`] lays out; the geometry itself is in the
/// section lengths and the offset, this names it in the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LaneChangeCourse {
    /// ISO 3888-1 (severe lane change, the "double lane change").
    #[default]
    Iso3888Part1,
    /// ISO 3888-2 (obstacle avoidance, the "Elchtest"/moose test).
    Iso3888Part2,
}

impl LaneChangeCourse {
    pub fn label(self) -> &'static str {
        match self {
            LaneChangeCourse::Iso3888Part1 => "ISO 3888-1",
            LaneChangeCourse::Iso3888Part2 => "ISO 3888-2",
        }
    }
}

/// Double lane change (ISO 3888-1 or -2 course) driven by a path-following (pure pursuit) driver.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DoubleLaneChange {
    /// Which standard the course follows (default ISO 3888-1).
    #[serde(default)]
    pub course: LaneChangeCourse,
    pub initial_speed: f64,
    /// Distance driven straight before the course starts [m].
    pub approach: f64,
    /// Lateral offset of the centre line of the second lane [m].
    pub lateral_offset: f64,
    /// Section lengths along x [m]: entry lane, transition, offset lane, transition.
    pub entry_length: f64,
    pub first_transition: f64,
    pub offset_length: f64,
    pub second_transition: f64,
    /// Lateral offset of the exit lane's centre line [m] (0 for ISO 3888-1, where the exit lane
    /// continues the entry lane).
    #[serde(default)]
    pub exit_offset: f64,
    /// Preview time of the driver [s]: look-ahead distance = speed * preview_time.
    pub preview_time: f64,
    /// Wheelbase used by the driver's steering law [m].
    pub wheelbase: f64,
    /// Largest road-wheel angle the driver applies [rad].
    pub max_steering_angle: f64,
    /// Speed controller gain [N·m per m/s] (drive torque only, no braking).
    pub speed_gain: f64,
    pub duration: f64,
}

/// A manoeuvre definition. TOML: `kind = "steer_ramp"` plus the fields of that kind.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Manoeuvre {
    SteerRamp(SteerRamp),
    StepSteer(StepSteer),
    Wobble(Wobble),
    SlowlyIncreasingSteer(SlowlyIncreasingSteer),
    SineWithDwell(SineWithDwell),
    DoubleLaneChange(DoubleLaneChange),
    LowSpeedCourse(LowSpeedCourse),
}

/// Names of the library manoeuvres, in report order.
pub const LIBRARY: [&str; 12] = [
    "seed000_ramp_moderate_ay",
    "seed000_ramp_high_ay",
    "seed000_ramp_high_ay_braking",
    "seed000_step_steer_2deg",
    "seed001_step_steer_40deg",
    "seed001_double_lane_change",
    "seed001_moose_test",
    "seed001_wobble",
    "fmvss126_slowly_increasing_steer",
    "fmvss126_sine_with_dwell",
    "straight_coasting",
    "low_speed_handling_course",
];

/// The library manoeuvre called `name`, or None.
pub fn library(name: &str) -> Option<Manoeuvre> {
    // Seed 000, ch. 7: all start at vx = 18 m/s; the seed's figures end at 12 s (the brake is
    // held "until 12 s"), so every ramp runs 12 s.
    let seed000_speed = SEED_INITIAL_SPEED;
    let ramp = |final_angle: f64, brake: Option<BrakeRamp>| {
        Manoeuvre::SteerRamp(SteerRamp {
            start_time: STEER_START_TIME,
            rate: STEER_RAMP_RATE,
            final_angle,
            initial_speed: seed000_speed,
            duration: SEED_MANOEUVRE_DURATION,
            brake,
        })
    };
    Some(match name {
        // 000 ch. 7.1: 0 until 4 s, +0.07 rad/s up to 0.035 rad, hold.
        "seed000_ramp_moderate_ay" => ramp(MODERATE_RAMP_ANGLE, None),
        // 000 ch. 7.2: same slope up to 0.122 rad.
        "seed000_ramp_high_ay" => ramp(HIGH_RAMP_ANGLE, None),
        // 000 ch. 7.2.1: brake 0 until 9 s, ramp to 2000 N·m within 2 s, hold to 12 s.
        "seed000_ramp_high_ay_braking" => ramp(
            HIGH_RAMP_ANGLE,
            Some(BrakeRamp {
                start_time: BRAKE_START_TIME,
                ramp_duration: BRAKE_RAMP_DURATION,
                torque: BRAKE_TORQUE_FINAL,
                end_time: SEED_MANOEUVRE_DURATION,
            }),
        ),
        // 000 ch. 7.3: "synthetic" step 0 -> 2 deg at about 4 s: an ideal step at 4 s. The
        // co-simulated step runs 8 s (4 s of steady state); seed000::SEED_MANOEUVRE_DURATION
        // is the model tests' horizon.
        "seed000_step_steer_2deg" => Manoeuvre::StepSteer(StepSteer {
            time: STEER_START_TIME,
            angle: STEP_STEER_ANGLE,
            rise_time: 0.0,
            initial_speed: seed000_speed,
            duration: 8.0,
        }),
        // 001: 40 deg steering-wheel step at 65 km/h. A real step needs a steering rate; we use
        // 400 deg/s at the wheel (0.1 s rise, ISO 7401 asks for 200-500 deg/s).
        "seed001_step_steer_40deg" => Manoeuvre::StepSteer(StepSteer {
            time: 1.0,
            angle: 40.0 * DEG / STEERING_RATIO,
            rise_time: 0.1,
            initial_speed: 65.0 * KMH,
            duration: 5.0,
        }),
        // 001: double lane change at 65 km/h along the ISO 3888-1 course (sections 15, 30, 25,
        // 25 m, lateral offset 3.5 m), 1 s of approach.
        "seed001_double_lane_change" => Manoeuvre::DoubleLaneChange(DoubleLaneChange {
            course: LaneChangeCourse::Iso3888Part1,
            initial_speed: 65.0 * KMH,
            approach: 65.0 * KMH,
            lateral_offset: 3.5,
            entry_length: 15.0,
            first_transition: 30.0,
            offset_length: 25.0,
            second_transition: 25.0,
            exit_offset: 0.0,
            preview_time: 0.6,
            // lF + lR of the seed-000 car (000: table 5.1).
            wheelbase: 1.4346 + 1.4831,
            max_steering_angle: 0.5,
            speed_gain: 400.0,
            duration: 9.0,
        }),
        // 001: one sine of rising amplitude, 150 deg left then 225 deg right (steering wheel)
        // at 80 km/h. The seed gives no frequency: 0.5 Hz (1 s per lobe).
        // 001 calls its lane change an "Elchtest" (moose test) with large sideslip: that is
        // the ISO 3888-2 obstacle-avoidance course, much tighter than ISO 3888-1. Sections
        // 12, 13.5, 11, 12.5 m (exit lane 12 m); lane 1 is 1.1 b + 0.25 m wide, lane 3 b + 1 m,
        // and lane 3 starts 1 m beyond lane 1's left edge, so the centre lines are
        // (1.1 b + 0.25) / 2 + 1 + (b + 1) / 2 apart; b = 1.75 m (vehicle width; model B's track
        // is 1.5 m). The exit lane (1.3 b + 0.25 m wide, right edge on lane 1's) is centred
        // (1.3 b + 0.25 - 1.1 b - 0.25) / 2 = 0.1 b left of lane 1's centre line. Preview 0.45 s: of 0.25-0.6 s the one that keeps the
        // body of the model-B car (4.6 m x b) inside lanes 1 and 3 with the widest margin at
        // 65 km/h (6 and 10 cm); recovering from the swing back it leaves the exit lane by up
        // to 0.2 m, which a centre-line pure-pursuit driver does not avoid. Peak ay 9.2 m/s²,
        // peak sideslip 2°: the high-sideslip manoeuvre seed 001 describes.
        "seed001_moose_test" => {
            let width = 1.75;
            Manoeuvre::DoubleLaneChange(DoubleLaneChange {
                course: LaneChangeCourse::Iso3888Part2,
                initial_speed: 65.0 * KMH,
                approach: 65.0 * KMH,
                lateral_offset: 0.5 * (1.1 * width + 0.25) + 1.0 + 0.5 * (width + 1.0),
                entry_length: 12.0,
                first_transition: 13.5,
                offset_length: 11.0,
                second_transition: 12.5,
                exit_offset: 0.1 * width,
                preview_time: 0.45,
                wheelbase: 1.4346 + 1.4831,
                max_steering_angle: 0.5,
                speed_gain: 400.0,
                duration: 7.0,
            })
        }
        "seed001_wobble" => Manoeuvre::Wobble(Wobble {
            start_time: 1.0,
            frequency: 0.5,
            left_amplitude: 150.0 * DEG,
            right_amplitude: 225.0 * DEG,
            initial_speed: 80.0 * KMH,
            duration: 6.0,
        }),
        // FMVSS 126 S7.5: 80 km/h, steering wheel 13.5 deg/s; run until well past 0.3 g.
        "fmvss126_slowly_increasing_steer" => {
            Manoeuvre::SlowlyIncreasingSteer(SlowlyIncreasingSteer {
                start_time: 1.0,
                rate: 13.5 * DEG,
                initial_speed: 80.0 * KMH,
                duration: 9.0,
                speed_gain: 400.0,
            })
        }
        // FMVSS 126 S7.6: 0.7 Hz, 500 ms dwell, at 80 km/h (coasting). The amplitude placeholder
        // (5 x the 0.3 g angle of a typical car) is replaced when the scenario names a slowly
        // increasing steer run in [manoeuvre.amplitude_from_sis].
        "fmvss126_sine_with_dwell" => Manoeuvre::SineWithDwell(SineWithDwell {
            start_time: 1.0,
            frequency: 0.7,
            dwell: 0.5,
            amplitude: 100.0 * DEG,
            initial_speed: 80.0 * KMH,
            duration: 5.0,
        }),
        // No input at all (tests, smoke runs).
        "straight_coasting" => Manoeuvre::StepSteer(StepSteer {
            time: 0.0,
            angle: 0.0,
            rise_time: 0.0,
            initial_speed: seed000_speed,
            duration: 2.0,
        }),
        "low_speed_handling_course" => Manoeuvre::LowSpeedCourse(low_speed::library_course()),
        _ => return None,
    })
}

impl Manoeuvre {
    pub fn duration(&self) -> f64 {
        match self {
            Manoeuvre::SteerRamp(m) => m.duration,
            Manoeuvre::StepSteer(m) => m.duration,
            Manoeuvre::Wobble(m) => m.duration,
            Manoeuvre::SlowlyIncreasingSteer(m) => m.duration,
            Manoeuvre::SineWithDwell(m) => m.duration,
            Manoeuvre::DoubleLaneChange(m) => m.duration,
            Manoeuvre::LowSpeedCourse(m) => m.duration,
        }
    }

    pub fn initial_speed(&self) -> f64 {
        match self {
            Manoeuvre::SteerRamp(m) => m.initial_speed,
            Manoeuvre::StepSteer(m) => m.initial_speed,
            Manoeuvre::Wobble(m) => m.initial_speed,
            Manoeuvre::SlowlyIncreasingSteer(m) => m.initial_speed,
            Manoeuvre::SineWithDwell(m) => m.initial_speed,
            Manoeuvre::DoubleLaneChange(m) => m.initial_speed,
            Manoeuvre::LowSpeedCourse(m) => m.waypoints.first().map_or(0.0, |w| w.speed),
        }
    }

    /// True when the manoeuvre needs the vehicle's motion (driver or speed controller).
    pub fn needs_feedback(&self) -> bool {
        matches!(
            self,
            Manoeuvre::DoubleLaneChange(_)
                | Manoeuvre::SlowlyIncreasingSteer(_)
                | Manoeuvre::LowSpeedCourse(_)
        )
    }

    /// Check physical sense of the numbers; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{field} must be a positive number, got {v}"))
            }
        };
        let non_negative = |field: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{field} must be >= 0, got {v}"))
            }
        };
        positive("duration", self.duration())?;
        non_negative("initial_speed", self.initial_speed())?;
        match self {
            Manoeuvre::SteerRamp(m) => {
                non_negative("start_time", m.start_time)?;
                positive("rate", m.rate.abs())?;
                if let Some(b) = &m.brake {
                    non_negative("brake.start_time", b.start_time)?;
                    non_negative("brake.ramp_duration", b.ramp_duration)?;
                    non_negative("brake.torque", b.torque)?;
                    if b.end_time < b.start_time + b.ramp_duration {
                        return Err("brake.end_time must not precede the end of the ramp".into());
                    }
                }
            }
            Manoeuvre::StepSteer(m) => {
                non_negative("time", m.time)?;
                non_negative("rise_time", m.rise_time)?;
            }
            Manoeuvre::Wobble(m) => {
                non_negative("start_time", m.start_time)?;
                positive("frequency", m.frequency)?;
            }
            Manoeuvre::SlowlyIncreasingSteer(m) => {
                non_negative("start_time", m.start_time)?;
                positive("rate", m.rate)?;
                non_negative("speed_gain", m.speed_gain)?;
            }
            Manoeuvre::SineWithDwell(m) => {
                non_negative("start_time", m.start_time)?;
                positive("frequency", m.frequency)?;
                non_negative("dwell", m.dwell)?;
            }
            Manoeuvre::DoubleLaneChange(m) => {
                non_negative("approach", m.approach)?;
                positive("preview_time", m.preview_time)?;
                positive("wheelbase", m.wheelbase)?;
                positive("max_steering_angle", m.max_steering_angle)?;
                positive("first_transition", m.first_transition)?;
                positive("second_transition", m.second_transition)?;
                non_negative("speed_gain", m.speed_gain)?;
            }
            Manoeuvre::LowSpeedCourse(m) => m.validate()?,
        }
        Ok(())
    }

    /// Open-loop road-wheel steering angle [rad] at time `t` (None for closed-loop manoeuvres).
    pub fn open_loop_steering(&self, t: f64) -> Option<f64> {
        Some(match self {
            Manoeuvre::SteerRamp(m) => {
                if t <= m.start_time {
                    0.0
                } else {
                    let angle = m.rate * (t - m.start_time);
                    if m.final_angle >= 0.0 {
                        angle.min(m.final_angle)
                    } else {
                        (-angle.abs()).max(m.final_angle)
                    }
                }
            }
            Manoeuvre::StepSteer(m) => {
                if t < m.time {
                    0.0
                } else if m.rise_time <= 0.0 || t >= m.time + m.rise_time {
                    m.angle
                } else {
                    m.angle * (t - m.time) / m.rise_time
                }
            }
            Manoeuvre::Wobble(m) => {
                let tau = t - m.start_time;
                let period = 1.0 / m.frequency;
                if tau <= 0.0 || tau >= period {
                    0.0
                } else {
                    let s = (2.0 * std::f64::consts::PI * m.frequency * tau).sin();
                    let amplitude = if tau < 0.5 * period {
                        m.left_amplitude
                    } else {
                        m.right_amplitude
                    };
                    amplitude * s / STEERING_RATIO
                }
            }
            Manoeuvre::SlowlyIncreasingSteer(m) => {
                (m.rate * (t - m.start_time).max(0.0)) / STEERING_RATIO
            }
            Manoeuvre::SineWithDwell(m) => sine_with_dwell_wheel(m, t) / STEERING_RATIO,
            Manoeuvre::LowSpeedCourse(m) => m.steering(t),
            Manoeuvre::DoubleLaneChange(_) => return None,
        })
    }

    /// Open-loop brake torque magnitude [N·m] at time `t`.
    pub fn brake_torque(&self, t: f64) -> f64 {
        match self {
            Manoeuvre::SteerRamp(SteerRamp { brake: Some(b), .. }) => {
                if t <= b.start_time || t > b.end_time {
                    0.0
                } else if b.ramp_duration <= 0.0 || t >= b.start_time + b.ramp_duration {
                    b.torque
                } else {
                    b.torque * (t - b.start_time) / b.ramp_duration
                }
            }
            _ => 0.0,
        }
    }

    /// Lateral position [m] of the course centre line at longitudinal position `x` (double lane
    /// change only; x = 0 where the vehicle starts).
    pub fn path_lateral_position(&self, x: f64) -> Option<f64> {
        let Manoeuvre::DoubleLaneChange(m) = self else {
            return None;
        };
        let s = x - m.approach - m.entry_length;
        let offset_start = m.first_transition;
        let back_start = offset_start + m.offset_length;
        // Cosine transitions: continuous lateral position and heading.
        let blend = |u: f64| 0.5 * (1.0 - (std::f64::consts::PI * u.clamp(0.0, 1.0)).cos());
        Some(if s <= 0.0 {
            0.0
        } else if s < offset_start {
            m.lateral_offset * blend(s / m.first_transition)
        } else if s < back_start {
            m.lateral_offset
        } else {
            m.lateral_offset
                + (m.exit_offset - m.lateral_offset) * blend((s - back_start) / m.second_transition)
        })
    }
}

/// FMVSS 126 sine with dwell steering-wheel angle [rad].
fn sine_with_dwell_wheel(m: &SineWithDwell, t: f64) -> f64 {
    let tau = t - m.start_time;
    let period = 1.0 / m.frequency;
    let omega = 2.0 * std::f64::consts::PI * m.frequency;
    let dwell_start = 0.75 * period;
    if tau <= 0.0 {
        0.0
    } else if tau < dwell_start {
        m.amplitude * (omega * tau).sin()
    } else if tau < dwell_start + m.dwell {
        -m.amplitude
    } else if tau < period + m.dwell {
        m.amplitude * (omega * (tau - m.dwell)).sin()
    } else {
        0.0
    }
}

/// Vehicle motion a closed-loop manoeuvre observes at a communication point.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct VehicleMotion {
    pub longitudinal_velocity: f64,
    pub lateral_velocity: f64,
    pub yaw_rate: f64,
}

/// The driver's view of the vehicle's position, integrated by the master from the reference's
/// body-frame velocities and yaw rate (trapezoidal rule between communication points).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}

/// One run's instance of a manoeuvre: stateless for open-loop manoeuvres, holds the integrated
/// pose for closed-loop ones. Create one per run (and per thread).
#[derive(Debug, Clone)]
pub struct ManoeuvreRun {
    manoeuvre: Manoeuvre,
    pose: Pose,
    last: Option<(f64, VehicleMotion)>,
    steering: f64,
    drive_torque: f64,
    /// The brake of a closed-loop driver that brakes (the low-speed course); None: the
    /// manoeuvre's open-loop brake.
    brake_torque: Option<f64>,
}

impl ManoeuvreRun {
    pub fn new(manoeuvre: Manoeuvre) -> Self {
        ManoeuvreRun {
            manoeuvre,
            pose: Pose::default(),
            last: None,
            steering: 0.0,
            drive_torque: 0.0,
            brake_torque: None,
        }
    }

    pub fn manoeuvre(&self) -> &Manoeuvre {
        &self.manoeuvre
    }

    pub fn pose(&self) -> Pose {
        self.pose
    }

    /// Advance to communication point `t`. `motion` is the vehicle's motion at `t` (closed-loop
    /// manoeuvres only; the master reads it before setting the inputs of `t`).
    pub fn update(&mut self, t: f64, motion: Option<VehicleMotion>) {
        if let Some(motion) = motion {
            if let Some((t_last, last)) = self.last {
                let dt = t - t_last;
                let heading_rate = 0.5 * (last.yaw_rate + motion.yaw_rate);
                let yaw_mid = self.pose.yaw + 0.5 * dt * heading_rate;
                let vx = 0.5 * (last.longitudinal_velocity + motion.longitudinal_velocity);
                let vy = 0.5 * (last.lateral_velocity + motion.lateral_velocity);
                self.pose.x += dt * (vx * yaw_mid.cos() - vy * yaw_mid.sin());
                self.pose.y += dt * (vx * yaw_mid.sin() + vy * yaw_mid.cos());
                self.pose.yaw += dt * heading_rate;
            }
            self.last = Some((t, motion));
        }
        let speed_now = motion.map(|m| m.longitudinal_velocity);
        match &self.manoeuvre {
            Manoeuvre::DoubleLaneChange(m) => {
                let speed = speed_now.unwrap_or(m.initial_speed).max(1.0);
                // Pure-pursuit driver: aim at the course point one preview distance ahead.
                let look_ahead = (speed * m.preview_time).max(3.0);
                let target_x = self.pose.x + look_ahead;
                let target_y = self
                    .manoeuvre
                    .path_lateral_position(target_x)
                    .unwrap_or(0.0);
                let bearing =
                    (target_y - self.pose.y).atan2(target_x - self.pose.x) - self.pose.yaw;
                let steering = (2.0 * m.wheelbase * bearing.sin() / look_ahead).atan();
                self.steering = steering.clamp(-m.max_steering_angle, m.max_steering_angle);
                self.drive_torque = (m.speed_gain * (m.initial_speed - speed)).max(0.0);
            }
            Manoeuvre::SlowlyIncreasingSteer(m) => {
                self.steering = self.manoeuvre.open_loop_steering(t).unwrap_or(0.0);
                let speed = speed_now.unwrap_or(m.initial_speed);
                self.drive_torque = (m.speed_gain * (m.initial_speed - speed)).max(0.0);
            }
            Manoeuvre::LowSpeedCourse(m) => {
                self.steering = m.steering(t);
                let speed = speed_now.unwrap_or_else(|| m.target_speed(t));
                let (drive, brake) = m.pedals(t, speed);
                self.drive_torque = drive;
                self.brake_torque = Some(brake);
            }
            other => {
                self.steering = other.open_loop_steering(t).unwrap_or(0.0);
                self.drive_torque = 0.0;
            }
        }
    }

    /// Value of `channel` at the communication point last passed to [`update`](Self::update).
    pub fn value(&self, channel: Channel, t: f64) -> f64 {
        match channel {
            Channel::SteeringAngle => self.steering,
            Channel::SteeringWheelAngle => self.steering * STEERING_RATIO,
            Channel::DriveTorque => self.drive_torque,
            Channel::BrakeTorque => self
                .brake_torque
                .unwrap_or_else(|| self.manoeuvre.brake_torque(t)),
            Channel::InitialSpeed => self.manoeuvre.initial_speed(),
        }
    }
}

/// One line per library manoeuvre for the report: the numbers this project chose.
pub fn describe(name: &str) -> Option<String> {
    let m = library(name)?;
    let deg = |rad: f64| rad / DEG;
    let kmh = |v: f64| v / KMH;
    Some(match &m {
        Manoeuvre::SteerRamp(r) => {
            let mut s = format!(
                "road-wheel angle 0 until {:.1} s, then {:.3} rad/s up to {:.3} rad ({:.2} deg, \
                 reached at {:.3} s), held; start {:.1} m/s, no drive torque, run {:.1} s",
                r.start_time,
                r.rate,
                r.final_angle,
                deg(r.final_angle),
                r.start_time + r.final_angle / r.rate,
                r.initial_speed,
                r.duration
            );
            if let Some(b) = &r.brake {
                s += &format!(
                    "; brake torque 0 until {:.1} s, linear to {:.0} N·m within {:.1} s, held \
                     to {:.1} s (seed 000 writes M_B = -{:.0} N·m)",
                    b.start_time, b.torque, b.ramp_duration, b.end_time, b.torque
                );
            }
            s
        }
        Manoeuvre::StepSteer(s) => format!(
            "road-wheel angle 0 -> {:.3} deg ({:.1} deg at the steering wheel) at {:.1} s, rise \
             time {:.2} s; start {:.2} m/s ({:.0} km/h), coasting, run {:.1} s",
            deg(s.angle),
            deg(s.angle) * STEERING_RATIO,
            s.time,
            s.rise_time,
            s.initial_speed,
            kmh(s.initial_speed),
            s.duration
        ),
        Manoeuvre::Wobble(w) => format!(
            "one steering-wheel sine period of {:.2} Hz from {:.1} s: {:.0} deg left, then \
             {:.0} deg right (road wheel {:.2} / {:.2} deg); start {:.0} km/h, coasting, run \
             {:.1} s",
            w.frequency,
            w.start_time,
            deg(w.left_amplitude),
            deg(w.right_amplitude),
            deg(w.left_amplitude) / STEERING_RATIO,
            deg(w.right_amplitude) / STEERING_RATIO,
            kmh(w.initial_speed),
            w.duration
        ),
        Manoeuvre::SlowlyIncreasingSteer(s) => format!(
            "steering wheel ramps at {:.1} deg/s from {:.1} s; speed held at {:.0} km/h by a \
             drive-torque controller ({:.0} N·m per m/s); run {:.1} s",
            deg(s.rate),
            s.start_time,
            kmh(s.initial_speed),
            s.speed_gain,
            s.duration
        ),
        Manoeuvre::SineWithDwell(s) => format!(
            "steering wheel A sin(2 pi {:.1} Hz t) from {:.1} s, held at -A for {:.0} ms at the \
             3/4-period peak, then completed; A = scale x the steering-wheel angle at which the \
             slowly increasing steer reaches 0.3 g; start {:.0} km/h, coasting, run {:.1} s",
            s.frequency,
            s.start_time,
            s.dwell * 1000.0,
            kmh(s.initial_speed),
            s.duration
        ),
        Manoeuvre::DoubleLaneChange(d) => format!(
            "{} course after {:.1} m of approach: entry lane {:.0} m, transition {:.0} m \
             to a lateral offset of {:.2} m, offset lane {:.0} m, transition {:.0} m to the \
             exit lane at {:.2} m; \
             cosine-shaped centre line; pure-pursuit driver with {:.2} s preview, wheelbase \
             {:.4} m, |delta| <= {:.2} rad; speed held at {:.0} km/h by drive torque \
             ({:.0} N·m per m/s); position integrated by the master from vx, vy, yaw rate; run \
             {:.1} s",
            d.course.label(),
            d.approach,
            d.entry_length,
            d.first_transition,
            d.lateral_offset,
            d.offset_length,
            d.second_transition,
            d.exit_offset,
            d.preview_time,
            d.wheelbase,
            d.max_steering_angle,
            kmh(d.initial_speed),
            d.speed_gain,
            d.duration
        ),
        Manoeuvre::LowSpeedCourse(c) => format!(
            "low-speed handling course of {} waypoints in {:.0} s: target speeds 0-{:.0} m/s with {} \
             stops held by {:.0} N·m of brake and starts from standstill, road-wheel angles up to \
             {:.0} deg blended by a raised cosine; speed held by drive and brake torque ({:.0} / \
             {:.0} N·m per m/s, drive at most {:.0} N·m)",
            c.waypoints.len(),
            c.duration,
            c.waypoints.iter().fold(0.0f64, |a, w| a.max(w.speed)),
            c.stops(),
            c.hold_brake,
            deg(c.largest_angle()),
            c.speed_gain,
            c.brake_gain,
            c.max_drive_torque
        ),
    })
}
