//! The FMI 3.0 front end on the toy model, through the exported `fmi3*` symbols: what it refuses
//! (with a log line and fmi3Error, never a crash), the type mapping, the arrays, the
//! dependencies, and that an FMU state serialized through FMI 3 is the FMI 2 frame.

use std::ffi::CString;

use fmi_export::ffi3::*;
use fmi_export::fuzzing3::{record, Fmi3Log};
use fmi_export::CoSimulationModel;

use crate::toy::{self, vr, Toy};

/// An FMI 3 instance of the toy with its log.
struct Fmi3Toy {
    instance: Fmi3Instance,
    log: Box<Fmi3Log>,
}

impl Fmi3Toy {
    fn new() -> Self {
        let log = Box::new(Fmi3Log::default());
        let instance = instantiate(&log, Toy::GUID, 0);
        assert!(!instance.is_null(), "{:?}", log.last());
        Self { instance, log }
    }

    /// Initialises with an internal step of 1/8 s, so that the integrator's sums are exact.
    fn initialise(&self) {
        unsafe {
            assert_eq!(
                toy::fmi3SetFloat64(
                    self.instance,
                    [vr::INTERNAL_STEP].as_ptr(),
                    1,
                    [0.125].as_ptr(),
                    1
                ),
                Fmi3Status::Ok
            );
            assert_eq!(
                toy::fmi3EnterInitializationMode(self.instance, 0, 0.0, 0.0, 0, 0.0),
                Fmi3Status::Ok
            );
            assert_eq!(
                toy::fmi3ExitInitializationMode(self.instance),
                Fmi3Status::Ok
            );
        }
    }

    fn step(&self, t: f64, h: f64) -> (Fmi3Status, f64) {
        let (mut event, mut terminate, mut early, mut last) = (1, 1, 1, f64::NAN);
        let status = unsafe {
            toy::fmi3DoStep(
                self.instance,
                t,
                h,
                1,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last,
            )
        };
        assert_eq!((event, terminate, early), (0, 0, 0));
        (status, last)
    }

    fn floats(&self, references: &[u32], n_values: usize) -> (Fmi3Status, Vec<f64>) {
        let mut values = vec![f64::NAN; n_values];
        let status = unsafe {
            toy::fmi3GetFloat64(
                self.instance,
                references.as_ptr(),
                references.len(),
                values.as_mut_ptr(),
                n_values,
            )
        };
        (status, values)
    }

    fn last_message(&self) -> String {
        self.log
            .last()
            .map(|(_, _, message)| message)
            .unwrap_or_default()
    }
}

impl Drop for Fmi3Toy {
    fn drop(&mut self) {
        unsafe { toy::fmi3FreeInstance(self.instance) };
    }
}

fn instantiate(log: &Fmi3Log, token: &str, event_mode_used: u8) -> Fmi3Instance {
    let token = CString::new(token).unwrap();
    unsafe {
        toy::fmi3InstantiateCoSimulation(
            c"toy3".as_ptr(),
            token.as_ptr(),
            std::ptr::null(),
            0,
            0,
            event_mode_used,
            0,
            std::ptr::null(),
            0,
            log as *const Fmi3Log as Fmi3InstanceEnvironment,
            Some(record),
            None,
        )
    }
}

#[test]
fn instantiation_refuses_a_wrong_token_and_event_mode_with_a_reason() {
    let log = Fmi3Log::default();
    assert!(instantiate(&log, "{other}", 0).is_null());
    assert!(
        log.last().unwrap().2.contains("instantiationToken"),
        "{:?}",
        log.last()
    );
    assert!(instantiate(&log, Toy::GUID, 1).is_null());
    assert!(
        log.last().unwrap().2.contains("hasEventMode"),
        "{:?}",
        log.last()
    );
    let model_exchange = unsafe {
        toy::fmi3InstantiateModelExchange(
            c"me".as_ptr(),
            c"{toy-guid}".as_ptr(),
            std::ptr::null(),
            0,
            0,
            &log as *const Fmi3Log as Fmi3InstanceEnvironment,
            Some(record),
        )
    };
    assert!(model_exchange.is_null());
    assert!(log.last().unwrap().2.contains("Co-Simulation FMU only"));
}

#[test]
fn arrays_and_time_read_in_their_places_and_n_values_is_checked() {
    let toy = Fmi3Toy::new();
    toy.initialise();
    let u = [vr::U];
    assert_eq!(
        unsafe { toy::fmi3SetFloat64(toy.instance, u.as_ptr(), 1, [2.0].as_ptr(), 1) },
        Fmi3Status::Ok
    );
    let (status, last) = toy.step(0.0, 0.5);
    assert_eq!((status, last), (Fmi3Status::Ok, 0.5));
    // y = gain * u * t = 1.0; the table holds y times each element's row-major index.
    let (status, values) = toy.floats(&[vr::TIME, vr::Y_TABLE, vr::Y], 8);
    assert_eq!(status, Fmi3Status::Ok, "{}", toy.last_message());
    assert_eq!(values, [0.5, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 1.0]);
    let (status, _) = toy.floats(&[vr::Y_TABLE], 5);
    assert_eq!(status, Fmi3Status::Error);
    assert!(
        toy.last_message().contains("nValues is 5"),
        "{}",
        toy.last_message()
    );
}

#[test]
fn types_map_as_the_standard_says_and_outputs_cannot_be_set() {
    let toy = Fmi3Toy::new();
    let mut int32 = [0i32; 1];
    let mut int64 = [0i64; 1];
    unsafe {
        // `order` is a plain Integer (Int32); `mode` an enumeration (Int64 in FMI 3).
        assert_eq!(
            toy::fmi3SetInt64(toy.instance, [vr::MODE].as_ptr(), 1, [2i64].as_ptr(), 1),
            Fmi3Status::Ok
        );
        assert_eq!(
            toy::fmi3EnterInitializationMode(toy.instance, 0, 0.0, 0.0, 0, 0.0),
            Fmi3Status::Ok
        );
        assert_eq!(
            toy::fmi3GetInt32(toy.instance, [vr::ORDER].as_ptr(), 1, int32.as_mut_ptr(), 1),
            Fmi3Status::Ok
        );
        assert_eq!(int32, [1]);
        assert_eq!(
            toy::fmi3GetInt64(toy.instance, [vr::MODE].as_ptr(), 1, int64.as_mut_ptr(), 1),
            Fmi3Status::Ok
        );
        assert_eq!(int64, [2]);
        // Any failed call moves the instance to Error; reset it after each.
        assert_eq!(
            toy::fmi3GetInt32(toy.instance, [vr::MODE].as_ptr(), 1, int32.as_mut_ptr(), 1),
            Fmi3Status::Error
        );
        assert!(toy.last_message().contains("no Int32 variable"));
        assert_eq!(toy::fmi3Reset(toy.instance), Fmi3Status::Ok);
        let table = [vr::Y_TABLE];
        assert_eq!(
            toy::fmi3SetFloat64(toy.instance, table.as_ptr(), 1, [0.0; 6].as_ptr(), 6),
            Fmi3Status::Error
        );
        assert!(toy.last_message().contains("cannot be set"));
        assert_eq!(toy::fmi3Reset(toy.instance), Fmi3Status::Ok);
        let mut floats = [0.0f32; 1];
        assert_eq!(
            toy::fmi3GetFloat32(toy.instance, [vr::Y].as_ptr(), 1, floats.as_mut_ptr(), 1),
            Fmi3Status::Error
        );
        assert_eq!(toy::fmi3Reset(toy.instance), Fmi3Status::Ok);
        // Out of range: clamped with a warning, as through FMI 2.
        assert_eq!(
            toy::fmi3SetFloat64(toy.instance, [vr::GAIN].as_ptr(), 1, [50.0].as_ptr(), 1),
            Fmi3Status::Warning
        );
        assert!(
            toy.last_message().contains("clamped to 10"),
            "{}",
            toy.last_message()
        );
    }
}

#[test]
fn undeclared_capabilities_answer_an_error_and_dependencies_follow_the_table() {
    let toy = Fmi3Toy::new();
    unsafe {
        assert_eq!(toy::fmi3EnterEventMode(toy.instance), Fmi3Status::Error);
        assert!(toy.last_message().contains("hasEventMode"));
        assert_eq!(toy::fmi3Reset(toy.instance), Fmi3Status::Ok);
        assert_eq!(toy::fmi3SetTime(toy.instance, 1.0), Fmi3Status::Error);
        assert_eq!(toy::fmi3Reset(toy.instance), Fmi3Status::Ok);
        let mut count = 99usize;
        assert_eq!(
            toy::fmi3GetNumberOfVariableDependencies(toy.instance, vr::Y_TABLE, &mut count),
            Fmi3Status::Ok
        );
        assert_eq!(count, 0);
        assert_eq!(
            toy::fmi3GetNumberOfVariableDependencies(toy.instance, vr::U, &mut count),
            Fmi3Status::Error
        );
        assert!(toy.last_message().contains("not an output"));
        // A stale handle is refused without a log line (it has no logger).
        let lines = toy.log.all().len();
        let foreign = &mut count as *mut usize as Fmi3Instance;
        assert_eq!(toy::fmi3Terminate(foreign), Fmi3Status::Error);
        assert_eq!(toy.log.all().len(), lines);
    }
}

#[test]
fn an_fmu_state_serialized_through_fmi3_restores_through_fmi2() {
    let toy = Fmi3Toy::new();
    toy.initialise();
    unsafe {
        toy::fmi3SetFloat64(toy.instance, [vr::U].as_ptr(), 1, [1.5].as_ptr(), 1);
    }
    toy.step(0.0, 0.25);
    let mut state: Fmi3FmuState = std::ptr::null_mut();
    let mut size = 0usize;
    let bytes = unsafe {
        assert_eq!(
            toy::fmi3GetFMUState(toy.instance, &mut state),
            Fmi3Status::Ok
        );
        assert_eq!(
            toy::fmi3SerializedFMUStateSize(toy.instance, state, &mut size),
            Fmi3Status::Ok
        );
        let mut bytes = vec![0u8; size];
        assert_eq!(
            toy::fmi3SerializeFMUState(toy.instance, state, bytes.as_mut_ptr(), size),
            Fmi3Status::Ok
        );
        assert_eq!(
            toy::fmi3FreeFMUState(toy.instance, &mut state),
            Fmi3Status::Ok
        );
        bytes
    };
    let mut fmi2 = toy::slave();
    let (status, restored) = fmi2.deserialize(&bytes);
    assert_eq!(
        status,
        fmi_export::ffi::Fmi2Status::Ok,
        "{:?}",
        fmi2.log.last()
    );
    assert_eq!(fmi2.set_state(&restored), fmi_export::ffi::Fmi2Status::Ok);
    assert_eq!(fmi2.get_real(vr::Y).1, 0.375);
    assert_eq!(fmi2.do_step(0.25, 0.25), fmi_export::ffi::Fmi2Status::Ok);
    assert_eq!(toy.step(0.25, 0.25).0, Fmi3Status::Ok);
    let (status, y) = toy.floats(&[vr::Y], 1);
    assert_eq!(status, Fmi3Status::Ok);
    assert_eq!(fmi2.get_real(vr::Y).1.to_bits(), y[0].to_bits());
    let mut restored = restored;
    fmi2.free_state(&mut restored);
}
