//! What several of this crate's tests share.

use ReferenceVehicle::model_description::vr;

/// Every noise standard deviation: the process noise, then the sensors' white noise.
pub const NOISE_LEVELS: [u32; 11] = [
    vr::PROCESS_NOISE_STD_VX,
    vr::PROCESS_NOISE_STD_VY,
    vr::PROCESS_NOISE_STD_YAW_RATE,
    vr::PROCESS_NOISE_STD_OMEGA_FRONT,
    vr::PROCESS_NOISE_STD_OMEGA_REAR,
    vr::NOISE_STD_YAW_RATE_MEAS,
    vr::NOISE_STD_AY_MEAS,
    vr::NOISE_STD_OMEGA_FRONT_MEAS,
    vr::NOISE_STD_OMEGA_REAR_MEAS,
    vr::NOISE_STD_AX_MEAS,
    vr::NOISE_STD_VX_MEAS,
];
