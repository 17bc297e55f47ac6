//! The work of one fmi2DoStep is bounded (so no call blocks a master for minutes) and an internal step size that
//! would make a step loop without bound is refused at initialisation: the toy takes
//! at most 1000 internal steps per call.

use crate::toy;

use fmi_export::ffi::Fmi2Status;
use toy::vr;

#[test]
fn a_step_within_the_budget_runs_and_one_beyond_is_discarded_with_a_message() {
    let mut s = toy::slave();
    assert_eq!(s.set_real(vr::U, 1.0), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    // 1000 internal steps of 1 ms: the maximum.
    assert_eq!(s.do_step(0.0, 1.0), Fmi2Status::Ok);
    let y = s.get_real(vr::Y).1;
    assert!((y - 1.0).abs() < 1e-9, "{y}");
    let status = s.do_step(1.0, 1e6);
    assert_eq!(status, Fmi2Status::Discard);
    let line = s.log.last().expect("a log line");
    assert!(
        line.message.contains("more than the 1000") && line.message.contains("at most 1e0 s"),
        "{}",
        line.message
    );
    assert_eq!(s.get_real(vr::Y).1, y, "the model did not run");
}

#[test]
fn an_internal_step_that_would_loop_is_refused_at_initialisation() {
    for size in [1e-300, 1e-12, 0.0] {
        let mut s = toy::slave();
        assert_eq!(s.set_real(vr::INTERNAL_STEP, size), Fmi2Status::Ok);
        assert_eq!(s.initialize(0.0), Fmi2Status::Error, "{size}");
        let line = s.log.last().expect("a log line");
        assert!(
            line.message.contains("internal step of"),
            "{}",
            line.message
        );
    }
}
