//! What the integration tests share: the estimator's car parameters from a model-A [`Chassis`]
//! and the sensor inputs in one order.

use fmi_export::ffi::Fmi2Status;
use fmi_export::testing::Slave;
use vehicle_models::Chassis;
use VehicleStateEstimator::model_description::vr;

#[allow(dead_code)] // not every test file uses it
/// Sets the FMU's vehicle parameters to `car` (the steering ratio has no FMU parameter).
pub fn set_car(s: &mut Slave, car: &Chassis) {
    let parameters = [
        (vr::MASS, car.mass),
        (vr::YAW_INERTIA, car.yaw_inertia),
        (vr::COG_TO_FRONT_AXLE, car.cog_to_front_axle),
        (vr::COG_TO_REAR_AXLE, car.cog_to_rear_axle),
        (vr::WHEEL_INERTIA_FRONT, car.front_wheel_inertia),
        (vr::WHEEL_INERTIA_REAR, car.rear_wheel_inertia),
        (vr::WHEEL_RADIUS_FRONT, car.front_wheel_radius),
        (vr::WHEEL_RADIUS_REAR, car.rear_wheel_radius),
        (vr::WHEEL_LOAD_FRONT, car.front_wheel_load),
        (vr::WHEEL_LOAD_REAR, car.rear_wheel_load),
        (vr::BRAKE_DISTRIBUTION_FRONT, car.brake_split_front),
    ];
    for (reference, value) in parameters {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok, "{reference}");
    }
}

/// The sensor inputs `[yaw_rate, ay, omega_front, omega_rear, ax, vx]`.
#[allow(dead_code)] // not every test file uses it
pub const SENSORS: [u32; 6] = [
    vr::YAW_RATE_MEAS,
    vr::AY_MEAS,
    vr::OMEGA_FRONT_MEAS,
    vr::OMEGA_REAR_MEAS,
    vr::AX_MEAS,
    vr::VX_MEAS,
];
