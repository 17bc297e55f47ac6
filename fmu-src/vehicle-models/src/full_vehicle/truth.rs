//! What the full vehicle reports after a step: everything [`VehicleTruth`] has, per wheel, plus
//! roll, wheel loads and tyre forces.

use serde::{Deserialize, Serialize};

use super::WHEELS;
use crate::truth::VehicleTruth;

/// Wheel positions in the per-wheel arrays.
pub mod wheel_index {
    pub const FRONT_LEFT: usize = 0;
    pub const FRONT_RIGHT: usize = 1;
    pub const REAR_LEFT: usize = 2;
    pub const REAR_RIGHT: usize = 3;
}

/// Truth quantities of the full vehicle after a step. Slips and slip angles are the transient
/// ones the tyre forces were computed from (`κ' = u/σκ`, `α' = atan(v/σα)`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FullVehicleTruth {
    /// Longitudinal CoG velocity in the body frame, m/s.
    pub longitudinal_velocity: f64,
    /// Lateral CoG velocity in the body frame, m/s (positive left).
    pub lateral_velocity: f64,
    /// Yaw rate, rad/s (positive left turn).
    pub yaw_rate: f64,
    /// Sideslip `atan2(vy, vx)`, rad (0 at standstill).
    pub sideslip: f64,
    /// `v̇x − vy r`, m/s², the body-frame acceleration of the CoG.
    pub longitudinal_acceleration: f64,
    /// `v̇y + vx r`, m/s².
    pub lateral_acceleration: f64,
    /// Roll angle of the sprung mass, rad (ISO 8855: positive right side down, as in a left turn).
    pub roll_angle: f64,
    /// Roll rate, rad/s.
    pub roll_rate: f64,
    /// Actual road-wheel angle of the front wheels, rad.
    pub road_wheel_angle: f64,
    /// Wheel speeds `[FL, FR, RL, RR]`, rad/s.
    pub wheel_speed: [f64; WHEELS],
    /// Vertical wheel loads, N (0 for a lifted wheel).
    pub wheel_load: [f64; WHEELS],
    /// Longitudinal slips `κ'`.
    pub slip: [f64; WHEELS],
    /// Slip angles `α'`, rad.
    pub slip_angle: [f64; WHEELS],
    /// Longitudinal tyre forces in the wheel frames, N.
    pub tyre_force_longitudinal: [f64; WHEELS],
    /// Lateral tyre forces in the wheel frames, N.
    pub tyre_force_lateral: [f64; WHEELS],
}

/// Number of values of [`FullVehicleTruth::to_values`].
pub const TRUTH_VALUES: usize = 9 + 6 * WHEELS;

/// Mean of the two wheels of an axle.
fn axle_mean(values: &[f64; WHEELS], left: usize, right: usize) -> f64 {
    0.5 * (values[left] + values[right])
}

impl FullVehicleTruth {
    /// The quantities of the other reference models ([`VehicleTruth`]); axle values are the mean
    /// of the left and right wheel, as model B reports them.
    pub fn vehicle_truth(&self) -> VehicleTruth {
        use wheel_index::*;
        VehicleTruth {
            longitudinal_velocity: self.longitudinal_velocity,
            lateral_velocity: self.lateral_velocity,
            yaw_rate: self.yaw_rate,
            omega_front: axle_mean(&self.wheel_speed, FRONT_LEFT, FRONT_RIGHT),
            omega_rear: axle_mean(&self.wheel_speed, REAR_LEFT, REAR_RIGHT),
            sideslip: self.sideslip,
            lateral_acceleration: self.lateral_acceleration,
            longitudinal_acceleration: self.longitudinal_acceleration,
            slip_angle_front: axle_mean(&self.slip_angle, FRONT_LEFT, FRONT_RIGHT),
            slip_angle_rear: axle_mean(&self.slip_angle, REAR_LEFT, REAR_RIGHT),
            slip_front: axle_mean(&self.slip, FRONT_LEFT, FRONT_RIGHT),
            slip_rear: axle_mean(&self.slip, REAR_LEFT, REAR_RIGHT),
        }
    }

    /// Every field as one flat array (for saving a simulation's state), in declaration order.
    pub fn to_values(&self) -> [f64; TRUTH_VALUES] {
        let mut values = [0.0; TRUTH_VALUES];
        let scalars = [
            self.longitudinal_velocity,
            self.lateral_velocity,
            self.yaw_rate,
            self.sideslip,
            self.longitudinal_acceleration,
            self.lateral_acceleration,
            self.roll_angle,
            self.roll_rate,
            self.road_wheel_angle,
        ];
        let wheels = [
            &self.wheel_speed,
            &self.wheel_load,
            &self.slip,
            &self.slip_angle,
            &self.tyre_force_longitudinal,
            &self.tyre_force_lateral,
        ];
        let per_wheel = wheels.iter().flat_map(|array| array.iter());
        for (value, source) in values.iter_mut().zip(scalars.iter().chain(per_wheel)) {
            *value = *source;
        }
        values
    }

    /// The inverse of [`FullVehicleTruth::to_values`].
    pub fn from_values(values: &[f64; TRUTH_VALUES]) -> Self {
        let wheel = |block: usize| -> [f64; WHEELS] {
            std::array::from_fn(|i| values[9 + block * WHEELS + i])
        };
        Self {
            longitudinal_velocity: values[0],
            lateral_velocity: values[1],
            yaw_rate: values[2],
            sideslip: values[3],
            longitudinal_acceleration: values[4],
            lateral_acceleration: values[5],
            roll_angle: values[6],
            roll_rate: values[7],
            road_wheel_angle: values[8],
            wheel_speed: wheel(0),
            wheel_load: wheel(1),
            slip: wheel(2),
            slip_angle: wheel(3),
            tyre_force_longitudinal: wheel(4),
            tyre_force_lateral: wheel(5),
        }
    }
}
