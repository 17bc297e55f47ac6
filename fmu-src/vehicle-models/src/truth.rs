//! The "true" motion quantities a reference vehicle reports, the same for models A and B.

use serde::{Deserialize, Serialize};

/// Truth quantities of a reference vehicle (SPEC §8). For the two-track model B the axle values
/// (wheel speeds, slip angles, slips) are the mean of the left and right wheel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VehicleTruth {
    /// Longitudinal CoG velocity in the body frame, m/s.
    pub longitudinal_velocity: f64,
    /// Lateral CoG velocity in the body frame, m/s (positive left).
    pub lateral_velocity: f64,
    /// Yaw rate, rad/s (positive left turn).
    pub yaw_rate: f64,
    /// Front wheel angular speed, rad/s.
    pub omega_front: f64,
    /// Rear wheel angular speed, rad/s.
    pub omega_rear: f64,
    /// Sideslip angle `atan2(vy, vx)`, rad.
    pub sideslip: f64,
    /// Lateral acceleration `v̇y + vx r` (000: 5.40), m/s².
    pub lateral_acceleration: f64,
    /// Longitudinal acceleration `v̇x − vy r` (000: 5.41), m/s².
    pub longitudinal_acceleration: f64,
    /// Front slip angle, rad.
    pub slip_angle_front: f64,
    /// Rear slip angle, rad.
    pub slip_angle_rear: f64,
    /// Front longitudinal slip.
    pub slip_front: f64,
    /// Rear longitudinal slip.
    pub slip_rear: f64,
}
