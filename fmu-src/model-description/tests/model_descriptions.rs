//! The project's two model descriptions pass, and each kind of defect is rejected with a message
//! that names the file, the line and the variable and says what was expected.

use model_description::{parse_file, parse_str, BaseType, Causality, VariableValue};

const FILES: [&str; 2] = ["ReferenceVehicle", "VehicleStateEstimator"];

fn path(model: &str) -> String {
    format!(
        "{}/../../modelDescription/{model}.xml",
        env!("CARGO_MANIFEST_DIR")
    )
}

fn text(model: &str) -> String {
    std::fs::read_to_string(path(model)).expect("model description readable")
}

#[test]
fn both_model_descriptions_are_valid() {
    for model in FILES {
        let description = parse_file(path(model)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(description.co_simulation.model_identifier, model);
        assert!(
            description
                .co_simulation
                .can_handle_variable_communication_step_size
        );
        assert!(
            !description
                .co_simulation
                .can_be_instantiated_only_once_per_process
        );
        assert!(description.co_simulation.can_get_and_set_fmu_state);
        assert!(description.co_simulation.can_serialize_fmu_state);
        assert!(description.guid.starts_with('{'));
    }
}

#[test]
fn the_shared_interface_names_are_present_with_the_same_shape_on_both_sides() {
    let reference = parse_file(path("ReferenceVehicle")).unwrap();
    let estimator = parse_file(path("VehicleStateEstimator")).unwrap();
    for input in ["steering_angle", "drive_torque", "brake_torque"] {
        for description in [&reference, &estimator] {
            let variable = description.variable(input).expect(input);
            assert_eq!(variable.causality, Causality::Input, "{input}");
        }
    }
    for truth in [
        "vx",
        "vy",
        "yaw_rate",
        "omega_front",
        "omega_rear",
        "sideslip",
        "ay",
        "ax",
        "slip_angle_front",
        "slip_angle_rear",
        "slip_front",
        "slip_rear",
    ] {
        assert_eq!(
            reference.variable(truth).expect(truth).causality,
            Causality::Output
        );
    }
    // The sensor signals connect by name: output of the reference, input of the estimator, same unit.
    for sensor in [
        "yaw_rate_meas",
        "ay_meas",
        "omega_front_meas",
        "omega_rear_meas",
        "ax_meas",
        "vx_meas",
    ] {
        let out = reference.variable(sensor).expect(sensor);
        let inp = estimator.variable(sensor).expect(sensor);
        assert_eq!(out.causality, Causality::Output);
        assert_eq!(inp.causality, Causality::Input);
        let unit = |v: &VariableValue| match v {
            VariableValue::Real { unit, .. } => unit.clone(),
            _ => None,
        };
        assert_eq!(unit(&out.value), unit(&inp.value), "{sensor}");
    }
    for output in [
        "vx_est",
        "vy_est",
        "yaw_rate_est",
        "omega_front_est",
        "omega_rear_est",
        "sideslip_est",
        "ay_est",
        "slip_angle_front_est",
        "slip_angle_rear_est",
        "slip_front_est",
        "slip_rear_est",
        "vx_std",
        "vy_std",
        "yaw_rate_std",
        "omega_front_std",
        "omega_rear_std",
        "sideslip_std",
        "nis",
        "status",
    ] {
        assert_eq!(
            estimator.variable(output).expect(output).causality,
            Causality::Output
        );
    }
    for parameter in [
        "estimator",
        "model",
        "sample_time",
        "particle_count",
        "seed",
    ] {
        assert_eq!(
            estimator.variable(parameter).expect(parameter).causality,
            Causality::Parameter
        );
    }
    for parameter in ["model", "seed", "noise", "vx0", "integration_step"] {
        assert_eq!(
            reference.variable(parameter).expect(parameter).causality,
            Causality::Parameter
        );
    }
    assert_eq!(
        reference.variable("noise").unwrap().base_type(),
        BaseType::Boolean
    );
    let brake = reference.variable("brake_torque").unwrap();
    assert!(brake
        .description
        .as_deref()
        .unwrap()
        .contains("M_B = -brake_torque"));
}

/// Applies `edit` to the reference vehicle's XML and returns the error message.
fn rejected(from: &str, to: &str) -> String {
    let original = text("ReferenceVehicle");
    assert!(
        original.contains(from),
        "test set-up: '{from}' not in the XML"
    );
    let edited = original.replacen(from, to, 1);
    match parse_str(&edited, "edited.xml") {
        Ok(_) => panic!("the edit '{from}' -> '{to}' was accepted"),
        Err(error) => error.to_string(),
    }
}

#[test]
fn a_wrong_unit_is_named() {
    let message = rejected(
        r#"<Real unit="m/s" displayUnit="km/h"/>"#,
        r#"<Real unit="m/sec" displayUnit="km/h"/>"#,
    );
    assert!(message.starts_with("edited.xml:"), "{message}");
    assert!(
        message.contains("variable 'vx' (valueReference 10)"),
        "{message}"
    );
    assert!(message.contains("unit 'm/sec' is not defined"), "{message}");
}

#[test]
fn a_missing_unit_is_rejected() {
    let message = rejected(
        r#"<Real unit="m/s2"/>
    </ScalarVariable>
    <ScalarVariable name="ax""#,
        r#"<Real/>
    </ScalarVariable>
    <ScalarVariable name="ax""#,
    );
    assert!(message.contains("variable 'ay'"), "{message}");
    assert!(message.contains("without a unit"), "{message}");
}

#[test]
fn annotations_inside_a_variable_are_rejected_because_the_fmi_crate_rejects_them() {
    let message = rejected(
        r#"<Real unit="m/s" displayUnit="km/h"/>"#,
        r#"<Real unit="m/s" displayUnit="km/h"/><Annotations/>"#,
    );
    assert!(message.contains("variable 'vx'"), "{message}");
    assert!(message.contains("Annotations"), "{message}");
}

#[test]
fn duplicate_value_references_are_rejected() {
    let message = rejected(r#"valueReference="11""#, r#"valueReference="10""#);
    assert!(
        message.contains("variable 'vy' (valueReference 10)"),
        "{message}"
    );
    assert!(message.contains("already used by"), "{message}");
}

#[test]
fn start_outside_min_max_is_rejected() {
    let message = rejected(
        r#"min="0" max="80" start="18""#,
        r#"min="0" max="80" start="-0.5""#,
    );
    assert!(message.contains("variable 'vx0'"), "{message}");
    assert!(message.contains("below min"), "{message}");
}

#[test]
fn a_nan_start_is_missing_for_a_real_input_and_a_typo_elsewhere() {
    let message = rejected(
        r#"min="0" max="80" start="18""#,
        r#"min="0" max="80" start="NaN""#,
    );
    assert!(message.contains("variable 'vx0'"), "{message}");
    assert!(message.contains("start is NaN"), "{message}");
    let estimator = text("VehicleStateEstimator");
    assert!(
        estimator.contains(r#"<Real unit="rad/s" displayUnit="deg/s" start="NaN"/>"#),
        "the estimator's sensor inputs start at NaN (missing)"
    );
    parse_str(&estimator, "VehicleStateEstimator.xml").expect("NaN starts of inputs accepted");
}

#[test]
fn an_output_missing_from_the_model_structure_is_rejected() {
    let message = rejected(r#"<Unknown index="7" dependencies=""/>"#, "");
    assert!(message.contains("<ModelStructure><Outputs>"), "{message}");
    assert!(message.contains("missing: [7 (vx)]"), "{message}");
}

#[test]
fn an_output_with_a_start_value_is_rejected() {
    let message = rejected(r#"<Real unit="m/s"/>"#, r#"<Real unit="m/s" start="0"/>"#);
    assert!(message.contains("variable 'vy'"), "{message}");
    assert!(message.contains("initial is calculated"), "{message}");
}

#[test]
fn an_unknown_attribute_is_rejected_with_the_expected_ones() {
    let message = rejected(
        r#"causality="parameter" variability="fixed"
      description="Vehicle model"#,
        r#"causality="parameter" variability="fixed" canHandleMultipleSetPerTimeInstant="true"
      description="Vehicle model"#,
    );
    assert!(
        message.contains("canHandleMultipleSetPerTimeInstant"),
        "{message}"
    );
    assert!(message.contains("expected one of"), "{message}");
}

#[test]
fn an_enumeration_start_must_be_an_item() {
    let message = rejected(
        r#"<Enumeration declaredType="VehicleModel" start="1"/>"#,
        r#"<Enumeration declaredType="VehicleModel" start="4"/>"#,
    );
    assert!(message.contains("variable 'model'"), "{message}");
    assert!(message.contains("1 (single_track_hsri)"), "{message}");
}

#[test]
fn a_parameter_without_start_is_rejected() {
    let message = rejected(r#"min="0" start="1"/>"#, r#"min="0"/>"#);
    assert!(message.contains("variable 'seed'"), "{message}");
    assert!(message.contains("no start value"), "{message}");
}

#[test]
fn syntax_errors_name_the_line() {
    let original = text("ReferenceVehicle");
    let edited = original.replacen("</ModelVariables>", "</ModelVariable>", 1);
    let message = parse_str(&edited, "broken.xml").unwrap_err().to_string();
    assert!(message.starts_with("broken.xml:"), "{message}");
    assert!(message.contains("XML syntax"), "{message}");
}

#[test]
fn a_missing_file_is_named() {
    let message = parse_file("/nonexistent/modelDescription.xml")
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("/nonexistent/modelDescription.xml"),
        "{message}"
    );
}

#[test]
fn generated_code_holds_the_guid_the_value_references_and_the_start_values() {
    let description = parse_file(path("ReferenceVehicle")).unwrap();
    let code = model_description::generate_rust(&description, "ReferenceVehicle.xml").unwrap();
    assert!(code.contains(&format!("pub const GUID: &str = {:?};", description.guid)));
    assert!(code.contains("pub const STEERING_ANGLE: u32 = 1;"));
    assert!(code.contains("    SingleTrackHsri = 1,"));
    assert!(
        !code.contains("pub mod vehicle_model"),
        "one Rust form of the items: the enum"
    );
    assert!(code.contains(&format!(
        "vx0: f64::from_bits({:#018x}) /* 18.0 */,",
        18.0f64.to_bits()
    )));
    assert!(code.contains("noise: true,"));
    assert!(code.contains("seed: 1_i32,"));
    assert!(code.contains(
        "name: \"model\", value_reference: 100, value_type: ::fmi_export::ValueType::Integer"
    ));
    assert!(code.contains("allowed_values: &[1, 2]"));
}
