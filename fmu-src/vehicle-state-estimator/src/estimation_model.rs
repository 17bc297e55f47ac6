//! The types that cross the boundary between the runner and the estimation models it drives
//! (the trait itself, `runner::EstimationModel`, lives beside the runner whose methods it
//! takes): a sample's measurement and input, the driver input vector, an output sample.

use std::fmt::Debug;

use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::INPUT_DIM;

use crate::model_description::Variables;
use crate::sensors::Measurements;

/// Number of driver inputs: the models' `[steering_angle, drive_torque, brake_torque]`
/// ([`vehicle_models::driver_input`]) and `drive_torque_rear`.
pub const DRIVER_DIM: usize = INPUT_DIM + 1;

/// Position of `drive_torque_rear` in [`InputVector`].
pub const REAR_DRIVE_TORQUE: usize = INPUT_DIM;

/// The driver input `[steering_angle, drive_torque, brake_torque, drive_torque_rear]`.
pub type InputVector = SVector<f64, DRIVER_DIM>;

/// The measurement and filter input of one sample, with the status bits found on the way.
pub struct Sample<const M: usize, const U: usize> {
    pub measurement: SVector<f64, M>,
    pub input: SVector<f64, U>,
    /// The rows the model offers in this sample; a row left out (model A's `vx` row without
    /// `use_speed_measurements` or without `vx_meas`) is neither used nor reported as skipped.
    pub offered: [bool; M],
    pub bits: i32,
}

/// What the outputs after a sample are computed from: the filter's estimate and covariance and
/// the values beside them, copied when the sample is processed.
#[derive(Clone, Copy, Debug)]
pub struct OutputSample<const N: usize, Extra> {
    pub state: SVector<f64, N>,
    pub covariance: SMatrix<f64, N, N>,
    /// The driver input of the sample.
    pub input: InputVector,
    pub extra: Extra,
    pub nis: f64,
    pub rows_used: i32,
    /// The filter held its estimate in this sample (low speed, or waiting for a measured speed).
    pub holding: bool,
    /// What the sensors measured in this sample.
    pub measured: Measurements,
    /// The factor on everything the estimator reports of its uncertainty, `covariance` and the
    /// consider terms: the Luenberger observer's innovation scaling, 1 for the other estimators.
    pub covariance_scale: f64,
    /// The gyro's offset taken off `yaw_rate_meas` in this sample (0 without the learner).
    pub yaw_rate_offset: f64,
    /// The lateral accelerometer's offset and gain error taken off `ay_meas` in this sample (0
    /// without the learner).
    pub ay_calibration: [f64; 2],
}

/// The `ay` row's model error as measurement noise (`ay_model_error` = k): `(k ŷ_ay)²` on row
/// `row`'s variance, `predicted_ay` the model's `ay` at the predicted estimate (evaluated only
/// for `k > 0`); `None` for `k = 0` (the filter's `R` as it is, bit for bit).
///
/// The measured `ay` is the tyre forces over the mass, so it enters the update through the
/// model's tyre law; on another car that law errs by a share of the force, not by a constant
/// (the sensor's noise). That error is the effect of a parameter the filter does not estimate
/// (Schmidt's "consider" parameters; Zanetti & D'Souza, "Recursive implementations of the
/// consider filter", AAS 12-619, 2012), carried here as white noise on the row it enters, with
/// a variance that grows with the predicted `ay`: at small `ay` the sensor dominates, near the
/// limit the model error does, and `ay` no longer pins the lateral states through a wrong tyre
/// law.
pub(crate) fn ay_model_error_noise<const M: usize>(
    v: &Variables,
    row: usize,
    predicted_ay: impl FnOnce() -> f64,
) -> Option<SMatrix<f64, M, M>> {
    if v.ay_model_error == 0.0 {
        return None;
    }
    let deviation = v.ay_model_error * predicted_ay();
    if !(deviation != 0.0 && deviation.is_finite()) {
        return None;
    }
    let mut noise = SMatrix::<f64, M, M>::zeros();
    noise[(row, row)] = deviation * deviation;
    Some(noise)
}
