//! Sensor inputs a master never sets: they start at NaN, are read as missing (never as a
//! measurement of a start value), and the first doStep names each of them once in a logged
//! notice (status fmi2OK), so that a mapping left out is seen instead of a silently worse
//! estimate.

use fmi_export::ffi::Fmi2Status;
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel};

use crate::robustness::estimator_with;

const SENSORS: [(&str, u32); 6] = [
    ("yaw_rate_meas", vr::YAW_RATE_MEAS),
    ("ay_meas", vr::AY_MEAS),
    ("omega_front_meas", vr::OMEGA_FRONT_MEAS),
    ("omega_rear_meas", vr::OMEGA_REAR_MEAS),
    ("vx_meas", vr::VX_MEAS),
    ("ax_meas", vr::AX_MEAS),
];

#[test]
fn every_sensor_input_starts_missing() {
    let mut s = estimator_with(EstimatorKind::Ekf as i32, |_| {});
    for (name, reference) in SENSORS {
        let (status, value) = s.get_real(reference);
        assert_eq!(status, Fmi2Status::Ok);
        assert!(
            value.is_nan(),
            "{name} starts at {value}, expected NaN (missing)"
        );
    }
}

#[test]
fn the_first_do_step_warns_once_for_each_sensor_never_set() {
    let mut s = estimator_with(EstimatorKind::Ekf as i32, |s| {
        assert_eq!(
            s.set_integer(vr::MODEL, EstimatorModel::SingleTrackGrip as i32),
            Fmi2Status::Ok
        );
    });
    // The gyro, the accelerometer and the speed are connected; the wheels and ax are not (ax
    // and vx are optional and never warned about).
    for (reference, value) in [
        (vr::YAW_RATE_MEAS, 0.0),
        (vr::AY_MEAS, 0.0),
        (vr::VX_MEAS, 20.0),
    ] {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
    }
    s.log.clear();
    // A notice, not a warning status: importers such as FMI++ stop their clock after a step
    // that answers fmi2Warning.
    assert_eq!(s.do_step(0.0, 0.01), Fmi2Status::Ok);
    let warnings: Vec<String> = s.log.lines().into_iter().map(|line| line.message).collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    for (name, _) in SENSORS {
        let named = warnings[0].contains(&format!("{name} not connected: treated as missing"));
        let connected = ["yaw_rate_meas", "ay_meas", "vx_meas", "ax_meas"].contains(&name);
        assert_eq!(named, !connected, "{name}: {}", warnings[0]);
    }
    for k in 1..100 {
        assert_eq!(s.do_step(f64::from(k) * 0.01, 0.01), Fmi2Status::Ok);
    }
    // Missing wheel speeds are skipped rows, not wheels standing still: the speed stays.
    let (_, vx) = s.get_real(vr::VX_EST);
    assert!((vx - 20.0).abs() < 0.5, "vx_est {vx}");
}

#[test]
fn a_master_that_sets_every_sensor_gets_no_warning() {
    let mut s = estimator_with(EstimatorKind::Ekf as i32, |_| {});
    for (_, reference) in SENSORS {
        assert_eq!(s.set_real(reference, 0.0), Fmi2Status::Ok);
    }
    assert_eq!(s.set_real(vr::VX_MEAS, 20.0), Fmi2Status::Ok);
    assert_eq!(s.do_step(0.0, 0.01), Fmi2Status::Ok);
}
