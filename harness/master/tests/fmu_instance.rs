//! [`FmuInstance`] on the packaged reference vehicle: names and types are checked against the
//! variable table before anything reaches the FMU, a call the FMU refuses quotes what it
//! logged, and a run through the instance steps and reads outputs.
//!
//! Needs the packaged FMUs (`cargo run --release -p packaging`).

use fmi_master::fmu::LoadedFmu;
use fmi_master::instance::{FmiVersion, FmuInstance, InstanceError, ParameterValue};

use crate::common::{packaged_fmus, Scratch};

fn vehicle(scratch: &Scratch) -> LoadedFmu {
    let path = packaged_fmus().join("ReferenceVehicle.fmu");
    LoadedFmu::load(&path, &scratch.0).unwrap_or_else(|e| panic!("{e}"))
}

fn instance<'a>(fmu: &'a LoadedFmu, name: &str) -> FmuInstance<'a> {
    FmuInstance::new(fmu, name, FmiVersion::Fmi2).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn names_and_types_are_checked_against_the_variable_table() {
    let scratch = Scratch::new("fmu-instance-names");
    let fmu = vehicle(&scratch);
    let mut vehicle = instance(&fmu, "instance-names");
    let refused = |outcome: Result<(), InstanceError>| match outcome {
        Err(e) => e.to_string(),
        Ok(()) => panic!("accepted"),
    };
    let unknown = refused(vehicle.set_parameter("vx_0", &ParameterValue::Real(20.0)));
    assert!(
        unknown.starts_with("no parameter or input named \"vx_0\"; it has abs_enabled, ")
            && unknown.contains("vx0"),
        "{unknown}"
    );
    let output = refused(vehicle.set_parameter("yaw_rate", &ParameterValue::Real(0.0)));
    assert!(output.contains("named \"yaw_rate\""), "{output}");
    assert_eq!(
        refused(vehicle.set_parameter("noise", &ParameterValue::Integer(1))),
        "\"noise\" is a Boolean variable; Integer(1) does not fit"
    );
    assert_eq!(
        refused(vehicle.set_parameter("vx0", &ParameterValue::Integer(20))),
        "\"vx0\" is a Real variable; Integer(20) does not fit"
    );
    let input = vehicle.real_input("vx").map(drop);
    let input = refused(input);
    assert!(
        input.starts_with("no Real input named \"vx\"; it has brake_torque, drive_torque, "),
        "{input}"
    );
    // An Enumeration takes its item's number; a Boolean a Boolean.
    vehicle
        .set_parameter("model", &ParameterValue::Integer(1))
        .unwrap_or_else(|e| panic!("{e}"));
    vehicle
        .set_parameter("noise", &ParameterValue::Boolean(false))
        .unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn a_step_before_initialisation_is_refused_with_the_fmus_words() {
    let scratch = Scratch::new("fmu-instance-refused");
    let fmu = vehicle(&scratch);
    let mut vehicle = instance(&fmu, "instance-refused");
    let error = match vehicle.do_step(0.0, 0.01) {
        Err(e @ InstanceError::Call { .. }) => e.to_string(),
        other => panic!("expected a refused call, got {other:?}"),
    };
    assert!(
        error.starts_with("fmi2DoStep(t = 0 s, h = 0.01 s) failed (Error); the FMU logged: "),
        "{error}"
    );
}

#[test]
fn an_instance_runs_from_parameters_to_steps_and_outputs() {
    let scratch = Scratch::new("fmu-instance-run");
    let fmu = vehicle(&scratch);
    let mut vehicle = instance(&fmu, "instance-run");
    vehicle
        .set_parameter("vx0", &ParameterValue::Real(20.0))
        .unwrap_or_else(|e| panic!("{e}"));
    let steering = [vehicle.real_input("steering_angle").unwrap()];
    let vx = [fmu.variable("vx").unwrap().value_reference];
    let mut value = [f64::NAN];
    vehicle.enter_initialization_mode(0.0, 1.0).unwrap();
    vehicle.set_reals(&steering, &[0.0]).unwrap();
    vehicle.exit_initialization_mode().unwrap();
    vehicle.get_reals(&vx, &mut value).unwrap();
    assert_eq!(value, [20.0]);
    for n in 0..10 {
        let t = f64::from(n) * 0.01;
        let outcome = vehicle.do_step(t, 0.01).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(outcome, fmi_master::instance::StepOutcome::Ok);
    }
    vehicle.get_reals(&vx, &mut value).unwrap();
    assert!(
        value[0] > 19.0 && value[0] <= 20.0,
        "vx after 0.1 s: {value:?}"
    );
}
