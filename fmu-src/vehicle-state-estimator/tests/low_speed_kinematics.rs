//! The low-speed regime (`low_speed_kinematics`): at walking pace in a tight corner, with an
//! accelerometer whose signal is mostly the body's vibration, the sideslip follows the steady
//! turn of the measured yaw rate and speed, and the reported std covers the error.

use fmi_export::ffi::Fmi2Status;
use fmi_export::testing::Slave;
use rand_distr::{Distribution, StandardNormal};
use vehicle_models::DriverInputVector;
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel};

use crate::car::SENSORS;
use crate::robustness::{assert_step, estimator_with, Truth, STEP};

/// The accelerometer's vibration, m/s² RMS (the low-speed course's noisy variant uses 3).
const VIBRATION: f64 = 3.0;

/// Sideslip RMSE (deg) and mean NEES of the grip model's EKF over 3-13 s of a car at about
/// 2.5 m/s on 17° of road-wheel angle, with `low_speed_kinematics` as given.
fn tight_corner_at_walking_pace(kinematics: bool) -> (f64, f64) {
    let mut s = estimator_with(EstimatorKind::Ekf as i32, |s: &mut Slave| {
        let model = EstimatorModel::SingleTrackGrip as i32;
        assert_eq!(s.set_integer(vr::MODEL, model), Fmi2Status::Ok);
        assert_eq!(
            s.set_boolean(vr::LOW_SPEED_KINEMATICS, kinematics),
            Fmi2Status::Ok
        );
    });
    let mut truth = Truth::new(2.5, 5);
    let input = DriverInputVector::new(0.3, 30.0, 0.0);
    let (mut squares, mut nees, mut samples) = (0.0, 0.0, 0);
    for k in 0..1300 {
        let t = k as f64 * STEP;
        let mut sensors = truth.sensors(&input);
        let draw: f64 = StandardNormal.sample(&mut truth.rng);
        sensors[1] += VIBRATION * draw;
        assert_eq!(s.set_real(vr::STEERING_ANGLE, input[0]), Fmi2Status::Ok);
        assert_eq!(s.set_reals(&SENSORS, &sensors), Fmi2Status::Ok);
        assert_step(s.do_step(t, STEP), t, &sensors, &s);
        truth.step(&input);
        let [sideslip, std] = s.reals(&[vr::SIDESLIP_EST, vr::SIDESLIP_STD])[..] else {
            unreachable!()
        };
        let speed = truth.state[0];
        assert!(
            (1.5..4.0).contains(&speed),
            "t = {t}: the car drives at {speed} m/s"
        );
        if t >= 3.0 {
            let error = sideslip - truth.state[1].atan2(truth.state[0]);
            squares += error * error;
            nees += (error / std).powi(2);
            samples += 1;
        }
    }
    let n = f64::from(samples);
    ((squares / n).sqrt().to_degrees(), nees / n)
}

#[test]
fn at_walking_pace_the_sideslip_follows_the_steady_turn_through_a_vibrating_accelerometer() {
    let (with, nees) = tight_corner_at_walking_pace(true);
    let (without, _) = tight_corner_at_walking_pace(false);
    println!("sideslip RMSE {with:.3}° (NEES {nees:.2}), without the kinematics {without:.3}°");
    assert!(with < 0.5, "sideslip RMSE {with}°");
    assert!(with < 0.5 * without, "{with}° against {without}° without");
    assert!(nees < 2.0, "NEES {nees}");
}
