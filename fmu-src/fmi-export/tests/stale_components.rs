//! Calls with a component that is no live instance: freed already, or never one. The standard
//! leaves them undefined (FMI 2.0.4, 2.1.5); a master makes them anyway. FMI++ 2.1's
//! `FMUCoSimulation::terminate()` calls fmi2Terminate and fmi2FreeInstance and keeps the pointer,
//! and its destructor calls both again: with our FMUs that aborted the process (a length read
//! from the freed instance). Each such call answers fmi2Error, fmi2FreeInstance ignores it, and
//! an instance created in between is not touched (`fmi_export::live`).

use crate::toy;

use fmi_export::ffi::{Fmi2Component, Fmi2Status, FMI2_TRUE};
use toy::vr;

#[test]
fn a_freed_component_answers_error_and_its_second_free_is_ignored() {
    let mut first = toy::slave();
    assert_eq!(first.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(first.do_step(0.0, 0.1), Fmi2Status::Ok);
    let (api, stale) = (first.api, first.component);
    // FMI++'s terminate(): both calls, the pointer kept.
    assert_eq!(first.terminate(), Fmi2Status::Ok);
    // SAFETY: the component is live here; freed once by this call.
    unsafe { (api.free_instance)(stale) };
    // The next object is constructed before the old one's destructor runs.
    let mut second = toy::slave();
    assert_ne!(
        second.component, stale,
        "a freed component's address is not reused at once"
    );
    // The destructor: both calls again, and any other call with the stale component.
    let mut value = 0.0;
    // SAFETY: fmi-export checks the component before using it; the pointers are valid.
    unsafe {
        assert_eq!((api.terminate)(stale), Fmi2Status::Error);
        assert_eq!(
            (api.get_real)(stale, &vr::Y, 1, &mut value),
            Fmi2Status::Error
        );
        assert_eq!((api.set_real)(stale, &vr::U, 1, &1.0), Fmi2Status::Error);
        assert_eq!((api.do_step)(stale, 0.1, 0.1, FMI2_TRUE), Fmi2Status::Error);
        assert_eq!((api.reset)(stale), Fmi2Status::Error);
        (api.free_instance)(stale);
    }
    assert_eq!(value, 0.0);
    // The second instance is untouched: it runs, and nothing was logged to it but its own.
    assert_eq!(second.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(second.set_real(vr::U, 1.0), Fmi2Status::Ok);
    assert_eq!(second.do_step(0.0, 0.1), Fmi2Status::Ok);
    assert!(second
        .log
        .lines()
        .iter()
        .all(|line| line.status == Fmi2Status::Ok));
    // Dropping `first` frees its component a third time: ignored as well.
    drop(first);
    assert_eq!(second.do_step(0.1, 0.1), Fmi2Status::Ok);
}

/// Handles are not reused (`fmi_export::live::HANDLE_COUNT` of them before the first comes
/// back): after a thousand instances and FMU states created and freed, the first freed component
/// still answers fmi2Error and none of the later ones was it. (The first form of the list kept a
/// freed address for 64 frees only; the allocator then handed it out again, and a stale call
/// reached the new instance.)
#[test]
fn a_freed_component_stays_stale_after_a_thousand_more_instances() {
    let first = toy::slave();
    let (api, stale) = (first.api, first.component);
    drop(first);
    for _ in 0..1000 {
        let mut later = toy::slave();
        assert_ne!(later.component, stale);
        assert_eq!(later.initialize(0.0), Fmi2Status::Ok);
        let (status, mut state) = later.get_state();
        assert_eq!(status, Fmi2Status::Ok);
        assert_ne!(state_pointer(&state) as Fmi2Component, stale);
        assert_eq!(later.free_state(&mut state), Fmi2Status::Ok);
    }
    let live = toy::slave();
    // SAFETY: fmi-export checks the component before using it.
    unsafe {
        assert_eq!((api.terminate)(stale), Fmi2Status::Error);
        assert_eq!((api.do_step)(stale, 0.0, 0.1, FMI2_TRUE), Fmi2Status::Error);
        (api.free_instance)(stale);
    }
    assert!(live.log.lines().is_empty());
}

#[test]
fn a_component_that_was_never_an_instance_answers_error_and_is_not_written() {
    let api = fmi_export::fmi2_api_of!(crate::toy);
    let mut memory = [0u8; 256];
    let foreign = memory.as_mut_ptr() as Fmi2Component;
    // SAFETY: fmi-export checks the component before using it.
    unsafe {
        assert_eq!((api.terminate)(foreign), Fmi2Status::Error);
        assert_eq!(
            (api.do_step)(foreign, 0.0, 0.1, FMI2_TRUE),
            Fmi2Status::Error
        );
        (api.free_instance)(foreign);
    }
    assert!(memory.iter().all(|&byte| byte == 0));
}

/// FMU states are handles of the same list: a freed state (fmpy's `freeFMUstate` called twice,
/// or a copy kept after fmi2FreeFMUstate set the master's pointer to NULL), or a component
/// passed as a state, answers fmi2Error with a log line instead of being read or freed again.
#[test]
fn a_freed_or_foreign_fmu_state_answers_error_with_a_message() {
    let mut s = toy::slave();
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let (status, mut state) = s.get_state();
    assert_eq!(status, Fmi2Status::Ok);
    let (api, component) = (s.api, s.component);
    let mut copy = state_pointer(&state);
    assert_eq!(s.free_state(&mut state), Fmi2Status::Ok);
    assert!(state.is_null());
    let mut size = 0usize;
    // SAFETY: fmi-export checks the state before using it; the other pointers are valid.
    unsafe {
        assert_eq!((api.set_fmu_state)(component, copy), Fmi2Status::Error);
        assert_eq!(s.reset(), Fmi2Status::Ok);
        assert_eq!(
            (api.serialized_fmu_state_size)(component, copy, &mut size),
            Fmi2Status::Error
        );
        assert_eq!(s.reset(), Fmi2Status::Ok);
        assert_eq!(
            (api.free_fmu_state)(component, &mut copy),
            Fmi2Status::Error
        );
        assert_eq!(s.reset(), Fmi2Status::Ok);
        let mut foreign = component as fmi_export::ffi::Fmi2FmuState;
        assert_eq!((api.set_fmu_state)(component, foreign), Fmi2Status::Error);
        assert_eq!(s.reset(), Fmi2Status::Ok);
        assert_eq!(
            (api.free_fmu_state)(component, &mut foreign),
            Fmi2Status::Error
        );
    }
    assert!(s
        .log
        .lines()
        .iter()
        .any(|line| line.message.contains("not an FMU state of this FMU")));
    // The instance itself is intact.
    assert_eq!(s.reset(), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(s.do_step(0.0, 0.1), Fmi2Status::Ok);
}

/// The raw pointer of a state, as a master keeps it.
fn state_pointer(state: &fmi_export::testing::FmuState) -> fmi_export::ffi::Fmi2FmuState {
    state.raw()
}
