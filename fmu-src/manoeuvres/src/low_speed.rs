//! A low-speed handling course as a test driver drives one on a proving ground: pulling away from
//! standstill while steering up, tight corners at walking and town speeds, a slalom, a faster
//! bend, braking to a stop with the wheels turned, holding at standstill and pulling away again.
//!
//! Where the kinematics rule and an estimator's dynamic model does not: at 3-13 m/s with
//! road-wheel angles up to 20 deg the car's sideslip is mostly the kinematic
//! `atan(lr/L · tan δ)` (about 10 deg at 20 deg), and below `min_speed` the filters hand over
//! to the kinematics. The driver follows a list of waypoints in time: the road-wheel angle is
//! blended between them (a raised cosine, so the steering rate stays finite), the target speed
//! is interpolated linearly and held by a speed controller that drives and brakes; at a target
//! of zero and below [`HOLD_SPEED`] it holds the car with a constant brake torque, as a driver
//! standing on the pedal.

use serde::Deserialize;

/// Below this speed, m/s, a target of zero is held with [`LowSpeedCourse::hold_brake`].
pub const HOLD_SPEED: f64 = 0.5;

/// One waypoint of the course: at `time` the driver aims at `speed` with the road-wheel angle
/// `angle`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Waypoint {
    /// s from the start.
    pub time: f64,
    /// Target speed, m/s (>= 0).
    pub speed: f64,
    /// Road-wheel angle, rad, positive left.
    pub angle: f64,
}

/// The course: waypoints in time, a speed controller and the brake torque that holds the car.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LowSpeedCourse {
    /// In increasing time; the first at 0 s. Before the first and after the last the first's and
    /// the last's values hold.
    pub waypoints: Vec<Waypoint>,
    /// Drive torque per m/s of speed below the target, N·m per m/s.
    pub speed_gain: f64,
    /// Brake torque per m/s of speed above the target, N·m per m/s.
    pub brake_gain: f64,
    /// Largest drive torque, N·m.
    pub max_drive_torque: f64,
    /// Largest brake torque, and the one that holds the car at standstill, N·m.
    pub hold_brake: f64,
    pub duration: f64,
}

impl LowSpeedCourse {
    /// The waypoints around `t` and the share of the way from the first to the second.
    fn segment(&self, t: f64) -> (Waypoint, Waypoint, f64) {
        let points = &self.waypoints;
        let last = points[points.len() - 1];
        if t <= points[0].time {
            return (points[0], points[0], 0.0);
        }
        match points.windows(2).find(|w| t < w[1].time) {
            Some(w) => {
                let share = (t - w[0].time) / (w[1].time - w[0].time);
                (w[0], w[1], share)
            }
            None => (last, last, 0.0),
        }
    }

    /// Road-wheel angle at `t`, rad: a raised-cosine blend between the waypoints.
    pub fn steering(&self, t: f64) -> f64 {
        let (from, to, share) = self.segment(t);
        let blend = 0.5 * (1.0 - (std::f64::consts::PI * share).cos());
        from.angle + (to.angle - from.angle) * blend
    }

    /// Target speed at `t`, m/s: linear between the waypoints.
    pub fn target_speed(&self, t: f64) -> f64 {
        let (from, to, share) = self.segment(t);
        from.speed + (to.speed - from.speed) * share
    }

    /// `(drive_torque, brake_torque)` the driver applies at `t` when the car moves at `speed`:
    /// proportional to the speed error, driving or braking (never both, both >= 0); at a target
    /// of zero the car is held below [`HOLD_SPEED`].
    pub fn pedals(&self, t: f64, speed: f64) -> (f64, f64) {
        let target = self.target_speed(t);
        if target <= 0.0 && speed.abs() < HOLD_SPEED {
            return (0.0, self.hold_brake);
        }
        let error = target - speed;
        if error >= 0.0 {
            ((self.speed_gain * error).min(self.max_drive_torque), 0.0)
        } else {
            (0.0, (self.brake_gain * -error).min(self.hold_brake))
        }
    }

    /// The largest road-wheel angle of the course, rad.
    pub fn largest_angle(&self) -> f64 {
        self.waypoints
            .iter()
            .fold(0.0, |largest, w| largest.max(w.angle.abs()))
    }

    /// The number of stops (a waypoint of zero speed after one of a positive speed).
    pub fn stops(&self) -> usize {
        self.waypoints
            .windows(2)
            .filter(|w| w[0].speed > 0.0 && w[1].speed <= 0.0)
            .count()
    }

    /// Check the waypoints and gains; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        let Some(first) = self.waypoints.first() else {
            return Err("waypoints must not be empty".into());
        };
        if first.time != 0.0 {
            return Err(format!("waypoints[0].time must be 0, got {}", first.time));
        }
        for (i, w) in self.waypoints.iter().enumerate() {
            if !(w.speed.is_finite() && w.speed >= 0.0 && w.angle.is_finite()) {
                return Err(format!(
                    "waypoints[{i}]: speed must be >= 0 and angle finite, got {} m/s, {} rad",
                    w.speed, w.angle
                ));
            }
        }
        for (i, w) in self.waypoints.windows(2).enumerate() {
            if w[1].time.partial_cmp(&w[0].time) != Some(std::cmp::Ordering::Greater) {
                return Err(format!(
                    "waypoints[{}].time must be after waypoints[{i}].time, got {} after {}",
                    i + 1,
                    w[1].time,
                    w[0].time
                ));
            }
        }
        for (field, value) in [
            ("speed_gain", self.speed_gain),
            ("brake_gain", self.brake_gain),
            ("max_drive_torque", self.max_drive_torque),
            ("hold_brake", self.hold_brake),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("{field} must be a positive number, got {value}"));
            }
        }
        Ok(())
    }
}

/// The library's course: 45 s on a proving ground, waypoints `(time s, speed m/s, road-wheel
/// angle deg)`. Speeds 3-13 m/s between three starts from standstill and three stops; road-wheel
/// angles up to 20 deg; steering up while pulling away, a steady tight corner at 5.5 m/s, a
/// slalom at 8 m/s, a bend at 13 m/s (about 5 m/s² on a 2.6-2.9 m wheelbase), a walking-pace
/// corner at full lock, and stops with the wheels turned.
pub fn library_course() -> LowSpeedCourse {
    const POINTS: [(f64, f64, f64); 24] = [
        (0.0, 0.0, 0.0),
        (1.5, 0.0, 0.0),
        // pulling away while steering up
        (3.5, 3.0, 18.0),
        (5.0, 5.0, 18.0),
        (6.5, 6.0, 0.0),
        // a steady tight corner to the right, then a stop with the wheels turned, held
        (8.0, 5.5, -15.0),
        (10.5, 5.5, -15.0),
        (12.5, 0.0, -5.0),
        (14.0, 0.0, 0.0),
        // pulling away straight, a slalom
        (16.5, 8.0, 0.0),
        (18.0, 8.0, 10.0),
        (19.5, 8.0, -10.0),
        (21.0, 8.0, 10.0),
        (22.5, 10.0, 0.0),
        // a faster bend
        (24.5, 13.0, 0.0),
        (26.0, 13.0, 5.0),
        (28.5, 13.0, 5.0),
        (30.0, 10.0, 0.0),
        // walking pace at full lock, a stop with the wheels turned, held
        (32.5, 3.0, 20.0),
        (34.5, 3.0, 20.0),
        (36.0, 0.0, 10.0),
        (38.0, 0.0, 10.0),
        // pulling away into a turn the other way, the last stop
        (41.0, 4.0, -10.0),
        (44.0, 0.0, 0.0),
    ];
    LowSpeedCourse {
        waypoints: POINTS
            .iter()
            .map(|&(time, speed, angle)| Waypoint {
                time,
                speed,
                angle: angle.to_radians(),
            })
            .collect(),
        // 1 m/s of error: about 1.2 m/s² on a 1.3 t car with 0.3 m wheels
        speed_gain: 1500.0,
        brake_gain: 1500.0,
        max_drive_torque: 2500.0,
        hold_brake: 2500.0,
        duration: 45.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_library_course_spans_the_low_speed_regime() {
        let course = library_course();
        course.validate().unwrap();
        let speeds: Vec<f64> = course.waypoints.iter().map(|w| w.speed).collect();
        let moving = speeds.iter().filter(|s| **s > 0.0);
        let lowest = moving.clone().fold(f64::INFINITY, |a, b| a.min(*b));
        let highest = moving.fold(0.0f64, |a, b| a.max(*b));
        assert_eq!((lowest, highest), (3.0, 13.0));
        assert!((course.largest_angle().to_degrees() - 20.0).abs() < 1e-12);
        assert_eq!(course.stops(), 3);
        assert_eq!(course.waypoints[0].speed, 0.0);
    }

    #[test]
    fn the_steering_is_continuous_and_passes_the_waypoints() {
        let course = library_course();
        for w in &course.waypoints {
            assert!((course.steering(w.time) - w.angle).abs() < 1e-12, "{w:?}");
        }
        let dt = 1e-3;
        let largest_rate = (0..45_000)
            .map(|k| (course.steering((k + 1) as f64 * dt) - course.steering(k as f64 * dt)) / dt)
            .fold(0.0f64, |a, b| a.max(b.abs()));
        // the slalom's 20 deg in 1.5 s with a raised cosine: pi/2 * 13.3 deg/s
        assert!(largest_rate.to_degrees() < 25.0, "{largest_rate}");
    }

    #[test]
    fn the_driver_brakes_or_drives_never_both_and_holds_a_standing_car() {
        let course = library_course();
        assert_eq!(course.pedals(1.0, 0.0), (0.0, course.hold_brake));
        let (drive, brake) = course.pedals(5.0, 3.0);
        assert!(drive > 0.0 && brake == 0.0);
        let (drive, brake) = course.pedals(5.0, 7.0);
        assert!(drive == 0.0 && brake > 0.0);
        assert_eq!(course.pedals(37.0, 0.2), (0.0, course.hold_brake));
        for k in 0..4500 {
            let t = k as f64 * 0.01;
            for speed in [0.0, 0.3, 2.0, 5.0, 14.0] {
                let (drive, brake) = course.pedals(t, speed);
                assert!(drive >= 0.0 && brake >= 0.0 && drive * brake == 0.0);
            }
        }
    }

    #[test]
    fn a_course_with_waypoints_out_of_order_is_refused_naming_them() {
        let mut course = library_course();
        course.waypoints[3].time = 1.0;
        let error = course.validate().unwrap_err();
        assert!(error.contains("waypoints[3]"), "{error}");
    }
}
