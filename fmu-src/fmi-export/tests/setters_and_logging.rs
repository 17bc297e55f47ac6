//! fmi2SetReal/fmi2SetInteger with values out of range, and fmi2SetDebugLogging with unknown
//! categories (a master must learn of what was adjusted, and lose no other value): fmi2Warning with a log line, every other
//! value of the call applied, the instance usable afterwards.

use crate::toy;

use fmi_export::ffi::{Fmi2Status, FMI2_TRUE};
use fmi_export::testing::Slave;
use toy::vr;

fn assert_warned(slave: &Slave, status: Fmi2Status, needles: &[&str]) {
    assert_eq!(status, Fmi2Status::Warning, "{:?}", slave.log.lines());
    let line = slave.log.last().expect("a log line");
    assert_eq!(line.status, Fmi2Status::Warning);
    for needle in needles {
        assert!(
            line.message.contains(needle),
            "{needle:?} in {}",
            line.message
        );
    }
}

#[test]
fn an_out_of_range_real_is_clamped_and_the_other_values_applied() {
    let mut s = toy::slave();
    let status = s.set_reals(&[vr::GAIN, vr::INTERNAL_STEP], &[25.0, 0.01]);
    assert_warned(&s, status, &["'gain'", "25", "clamped to 10"]);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(s.get_real(vr::GAIN).1, 10.0);
    assert_eq!(s.get_real(vr::INTERNAL_STEP).1, 0.01);
    let status = s.set_real(vr::U, -7.5);
    assert_warned(&s, status, &["'u'", "-7.5", "clamped to -5"]);
    assert_eq!(s.do_step(0.0, 0.1), Fmi2Status::Ok);
    assert!((s.get_real(vr::Y).1 - 10.0 * -5.0 * 0.1).abs() < 1e-12);
}

#[test]
fn a_non_finite_input_is_a_missing_sample_and_a_nan_parameter_is_ignored() {
    let mut s = toy::slave();
    let status = s.set_reals(&[vr::GAIN, vr::INTERNAL_STEP], &[f64::NAN, 0.02]);
    assert_warned(&s, status, &["'gain'", "NaN", "keeps its value"]);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(s.get_real(vr::GAIN).1, 1.0);
    assert_eq!(s.get_real(vr::INTERNAL_STEP).1, 0.02);
    for missing in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        s.log.clear();
        assert_eq!(s.set_real(vr::U, missing), Fmi2Status::Ok, "{missing}");
        assert!(s.log.lines().is_empty(), "{:?}", s.log.lines());
        assert_eq!(s.get_real(vr::U).1.to_bits(), missing.to_bits());
    }
}

#[test]
fn integers_are_clamped_and_an_unknown_enumeration_item_is_ignored() {
    let mut s = toy::slave();
    let status = s.set_integer(vr::ORDER, 9);
    assert_warned(&s, status, &["'order'", "9", "clamped to 4"]);
    let status = s.set_integer(vr::MODE, 7);
    assert_warned(&s, status, &["'mode'", "7", "not an item"]);
    assert_eq!(s.set_integer(vr::MODE, 2), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(s.get_integer(vr::ORDER).1, 4);
    assert_eq!(s.get_integer(vr::MODE).1, 2);
}

#[test]
fn misuse_in_a_setter_is_still_an_error_that_applies_nothing() {
    let mut s = toy::slave();
    let status = s.set_reals(&[vr::GAIN, 4242], &[2.0, 1.0]);
    assert_eq!(status, Fmi2Status::Error);
    assert_eq!(s.reset(), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(
        s.get_real(vr::GAIN).1,
        1.0,
        "nothing of the refused call applied"
    );
}

#[test]
fn unknown_log_categories_warn_and_the_known_ones_apply() {
    let mut s = toy::slave();
    // Warnings show while logStatusWarning is on (or logging is off altogether, instance.rs).
    let categories = [
        c"logSingularLinearSystems".as_ptr(),
        c"logEvents".as_ptr(),
        c"logStatusWarning".as_ptr(),
    ];
    let status =
        unsafe { (s.api.set_debug_logging)(s.component, FMI2_TRUE, 3, categories.as_ptr()) };
    assert_warned(&s, status, &["logSingularLinearSystems", "ignored"]);
    assert_eq!(
        s.initialize(0.0),
        Fmi2Status::Ok,
        "the instance stays usable"
    );
    assert!(
        s.log
            .lines()
            .iter()
            .any(|l| l.category == "logEvents" && l.message.contains("fmi2ExitInitializationMode")),
        "logEvents was switched on: {:?}",
        s.log.lines()
    );
    assert_eq!(s.do_step(0.0, 0.01), Fmi2Status::Ok);
}
