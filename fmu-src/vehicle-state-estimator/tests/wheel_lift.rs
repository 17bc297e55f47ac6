//! Per-axle geometry through the C ABI: model B's geometry parameters and the wheel-load clamp.
//! A light car (700 kg, CoG height 0.7 m, track 1.3 m) measured at 10 m/s² of lateral
//! acceleration lifts its inner front wheel: the estimator runs on (finite outputs, no state
//! reset) and says so with status bit 2048; at 3 m/s² it does not.

use crate::car;

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use vehicle_models::Chassis;
use VehicleStateEstimator::model_description::{vr, EstimatorModel, GUID};
use VehicleStateEstimator::status;

const STEP: f64 = 0.01;

fn light_car_estimator() -> Slave {
    let mut s =
        Slave::instantiate(fmi2_api_of!(VehicleStateEstimator), "lift", GUID).expect("instantiate");
    let mut light = Chassis {
        mass: 700.0,
        ..Chassis::default()
    };
    (light.front_wheel_load, light.rear_wheel_load) =
        light.static_wheel_loads(vehicle_models::GRAVITY);
    car::set_car(&mut s, &light);
    let geometry = [
        (vr::SAMPLE_TIME, STEP),
        (vr::COG_HEIGHT, 0.7),
        (vr::TRACK_WIDTH, 1.3),
    ];
    for (reference, value) in geometry {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
    }
    let model_b = EstimatorModel::TwoTrack3State as i32;
    assert_eq!(s.set_integer(vr::MODEL, model_b), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    s
}

/// Steady cornering at 15 m/s with lateral acceleration `ay`; returns the status bits of the
/// last second and the last estimate of ay.
fn corner(ay: f64) -> (i32, f64) {
    let mut s = light_car_estimator();
    let speed = 15.0;
    let wheel = speed / 0.3;
    // The kinematic (Ackermann) road-wheel angle of that turn, ay l / v², a little more for
    // the understeer.
    let steering = 1.1 * ay * 2.9177 / (speed * speed);
    let mut bits = 0;
    for k in 0..300 {
        let t = k as f64 * STEP;
        let sensors = [ay / speed, ay, wheel, wheel, 0.0, speed];
        assert_eq!(s.set_reals(&car::SENSORS, &sensors), Fmi2Status::Ok);
        assert_eq!(s.set_real(vr::STEERING_ANGLE, steering), Fmi2Status::Ok);
        assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok);
        if k >= 200 {
            bits |= s.get_integer(vr::STATUS).1;
        }
    }
    let estimate = s.reals(&[vr::AY_EST, vr::SIDESLIP_EST, vr::YAW_RATE_EST]);
    assert!(estimate.iter().all(|v| v.is_finite()), "{estimate:?}");
    (bits, estimate[0])
}

#[test]
fn a_light_car_at_10_m_s2_lifts_its_inner_wheel_and_says_so() {
    let (bits, ay) = corner(10.0);
    assert!(ay > 8.0, "ay estimate {ay}");
    assert_ne!(bits & status::WHEEL_LIFTED, 0, "status {bits}");
    assert_eq!(bits & status::STATE_RESET, 0, "status {bits}");
}

#[test]
fn at_3_m_s2_no_wheel_lifts() {
    let (bits, _) = corner(3.0);
    assert_eq!(bits & status::WHEEL_LIFTED, 0, "status {bits}");
}
