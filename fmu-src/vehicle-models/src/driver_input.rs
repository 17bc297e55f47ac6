//! The driver input shared by models A and B: `u = [steering_angle, drive_torque, brake_torque]`.
//!
//! Conventions every interface of this project uses:
//! - `steering_angle`: road-wheel angle at the front axle, rad, positive to the left (ISO 8855);
//!   the steering-wheel angle is `steering_angle · i_L` (000: table 5.1).
//! - `drive_torque`: total drive torque on the front axle, N·m (front-wheel drive, 000: fig 5.3).
//! - `brake_torque`: **magnitude** (≥ 0) of the total brake torque, N·m, split `ν` front and
//!   `1 − ν` rear, braking the forward-rolling wheels. Seed 000 feeds its `M_B` as a negative
//!   number to brake (000: fig. 5.3 text); the equations use `M_B = −brake_torque`, so the seed's
//!   "M_B ramps to −2000 N·m" is `brake_torque` ramping to +2000 N·m.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

/// Positions in the input vector.
pub mod index {
    /// Road-wheel steering angle, rad.
    pub const STEERING_ANGLE: usize = 0;
    /// Total front drive torque, N·m.
    pub const DRIVE_TORQUE: usize = 1;
    /// Brake torque magnitude (≥ 0), N·m.
    pub const BRAKE_TORQUE: usize = 2;
}

/// Number of inputs.
pub const INPUT_DIM: usize = 3;

/// The input vector `[steering_angle, drive_torque, brake_torque]`.
pub type DriverInputVector = SVector<f64, INPUT_DIM>;

/// The driver input with names (see the module documentation for the conventions).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DriverInput {
    /// Road-wheel steering angle, rad, positive left.
    pub steering_angle: f64,
    /// Total front drive torque, N·m.
    pub drive_torque: f64,
    /// Brake torque magnitude (≥ 0), N·m.
    pub brake_torque: f64,
}

impl DriverInput {
    pub fn to_vector(&self) -> DriverInputVector {
        DriverInputVector::new(self.steering_angle, self.drive_torque, self.brake_torque)
    }

    pub fn from_vector(u: &DriverInputVector) -> Self {
        Self {
            steering_angle: u[index::STEERING_ANGLE],
            drive_torque: u[index::DRIVE_TORQUE],
            brake_torque: u[index::BRAKE_TORQUE],
        }
    }
}

/// The seed's signed brake torque `M_B` (negative brakes, 000: fig. 5.3 text) from the
/// project's brake-torque magnitude.
#[inline(always)]
pub fn seed_brake_torque<S: crate::Scalar>(brake_torque: S) -> S {
    -brake_torque
}
