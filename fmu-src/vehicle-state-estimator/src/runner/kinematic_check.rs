//! Whether the sideslip estimate moves as the kinematics say the car's does (status bit 32768).
//!
//! The lateral velocity of the centre of gravity changes as `dvy/dt = ay − r vx` (ISO 8855,
//! rigid body in the body frame), with `ay` and `r` measured and `vx` the measured speed: over the
//! last [`CHECK_TIME`] that integrates to a change `Δvy_kin` that needs no model. The filter's
//! own `vy = vx tan β` changed by `Δvy_est` over the same time. Where the two differ by more than
//! the lateral speed of [`CHECK_SIDESLIP`] at the current speed, the estimate has left the car's
//! motion while the sensors still follow it: a spin, where the sideslip runs to tens of degrees
//! within a second while the yaw rate and `ay` the filter predicts stay close to the measured
//! ones (its innovations, and so bit 8192, say nothing there), or a model that does not follow
//! the car. The check changes nothing the filter estimates.
//!
//! What the integration itself gets wrong over half a second stays well below the limit: an
//! accelerometer vibrating by 3 m/s² RMS at 100 Hz, about 0.6° at 20 m/s; an offset of 0.2 m/s²,
//! 0.3°; the gravity of a body's roll read by a body-fixed sensor (a gain error of 0.1 at
//! 8 m/s²), 1.1°.
//!
//! Measured (`harness population`, 12 draws of each campaign car on its manoeuvres, the
//! default grip EKF): 13 of the 36 runs in which the car spun are flagged, none of the 144
//! others; of the spun runs' samples whose error is above 3 std and 2°, 5.5 % are flagged (the
//! onset of the spin: once the car slides sideways its speed falls below [`CHECK_MIN_SPEED`] or
//! both changes settle while the error stays), 14 % by this bit or bit 8192. Offline, with the
//! true sideslip change in place of the kinematic one, 24 of 36 runs and 86 % of those samples
//! would be. Never on the campaigns' runs nor on the MBDS recording (laps 2-6); model B on MBDS
//! in 0.6 % of the samples; the seeds' unprotected EKF in its glitch and outage runs.

use std::collections::VecDeque;

use fmi_export::{StateError, StateReader, StateWriter};

/// The time over which the two changes are compared, s: a spin's sideslip grows by tens of
/// degrees in it, a lane change's by a few.
pub(super) const CHECK_TIME: f64 = 0.5;

/// The sideslip angle whose lateral speed at the current speed the two changes may differ by,
/// rad (5°).
pub(super) const CHECK_SIDESLIP: f64 = 0.087;

/// The speed below which the check rests, m/s: at walking pace `r vx` is small against the
/// accelerometer's noise, and the low-speed regime holds the sideslip to the kinematic one.
const CHECK_MIN_SPEED: f64 = 5.0;

/// The check's window: per sample the disagreement `vy_est − ∫(ay − r vx) dt`, the integral
/// taken since the window was last emptied, so that the difference of two entries is the
/// difference of the two changes between them and no sum is taken per sample (allocated once,
/// at the window's length).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct KinematicCheck {
    disagreements: VecDeque<f64>,
    /// `∫(ay − r vx) dt` since the window was last emptied, m/s.
    kinematic_vy: f64,
    length: usize,
    sample_time: f64,
}

impl KinematicCheck {
    pub(super) fn new(sample_time: f64) -> Self {
        let length = ((CHECK_TIME / sample_time).round() as usize).max(2);
        Self {
            disagreements: VecDeque::with_capacity(length + 1),
            kinematic_vy: 0.0,
            length,
            sample_time,
        }
    }

    /// Takes one sample (the measured `ay`, yaw rate and speed, the filter's sideslip after its
    /// update); returns whether the estimate's change of `vy` over the full window is off the
    /// kinematic one by more than the limit. A sample without the measurements, or below
    /// [`CHECK_MIN_SPEED`], empties the window.
    pub(super) fn observe(&mut self, ay: f64, yaw_rate: f64, speed: f64, sideslip: f64) -> bool {
        let vy = speed * sideslip.tan();
        let change = (ay - yaw_rate * speed) * self.sample_time;
        if !(change.is_finite() && vy.is_finite()) || speed < CHECK_MIN_SPEED {
            self.disagreements.clear();
            self.kinematic_vy = 0.0;
            return false;
        }
        // The first sample's change led up to its vy: the integral starts after it.
        if !self.disagreements.is_empty() {
            self.kinematic_vy += change;
        }
        if self.disagreements.len() == self.length + 1 {
            self.disagreements.pop_front();
        }
        self.disagreements.push_back(vy - self.kinematic_vy);
        match (self.disagreements.front(), self.disagreements.back()) {
            (Some(first), Some(last)) if self.disagreements.len() == self.length + 1 => {
                (last - first).abs() > speed * CHECK_SIDESLIP.tan()
            }
            _ => false,
        }
    }

    pub(super) fn write(&self, writer: &mut StateWriter) {
        writer.f64(self.kinematic_vy);
        writer.u64(self.disagreements.len() as u64);
        for &disagreement in &self.disagreements {
            writer.f64(disagreement);
        }
    }

    pub(super) fn read(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        self.kinematic_vy = reader.f64("kinematic check's integral of vy")?;
        let count = reader.u64("kinematic check entries")? as usize;
        if count > self.length + 1 {
            return Err(StateError::new(format!(
                "kinematic check of {count} entries; expected at most {}",
                self.length + 1
            )));
        }
        self.disagreements.clear();
        for _ in 0..count {
            self.disagreements
                .push_back(reader.f64("kinematic check's disagreement")?);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: f64 = 0.01;

    /// A filter that follows the car (its vy grows as `ay − r vx` integrates) is not flagged; one
    /// whose vy stays while the kinematics say the car slides out is, once the window is full.
    #[test]
    fn only_an_estimate_that_leaves_the_kinematics_is_flagged() {
        let (speed, yaw_rate) = (20.0, 0.5);
        let ay = yaw_rate * speed + 4.0; // vy grows by 4 m/s² (a spin's start)
        let mut following = KinematicCheck::new(T);
        let mut stuck = KinematicCheck::new(T);
        let mut flagged = (0, 0);
        for k in 0..100 {
            let vy = 4.0 * T * f64::from(k);
            flagged.0 += usize::from(following.observe(ay, yaw_rate, speed, (vy / speed).atan()));
            flagged.1 += usize::from(stuck.observe(ay, yaw_rate, speed, 0.0));
        }
        assert_eq!(flagged.0, 0);
        // 0.5 s at 4 m/s² is 2 m/s, above 20 m/s · tan 5° = 1.75 m/s: from the 51st sample on
        assert_eq!(flagged.1, 50);
    }

    #[test]
    fn missing_measurements_and_walking_pace_empty_the_window() {
        let mut check = KinematicCheck::new(T);
        for _ in 0..60 {
            check.observe(14.0, 0.5, 20.0, 0.0);
        }
        assert!(check.observe(14.0, 0.5, 20.0, 0.0));
        assert!(!check.observe(f64::NAN, 0.5, 20.0, 0.0));
        assert!(!check.observe(14.0, 0.5, 20.0, 0.0));
        assert!(!check.observe(14.0, 0.5, 2.0, 0.0));
    }
}
