//! Packaging logic on small fixture model descriptions: XML checks, SSP plan and text, zip layout,
//! atomic writes, generated documentation.

use std::path::{Path, PathBuf};

use packaging::archive::{self, Entry, WriteOutcome};
use packaging::description::{self, ModelDescription};
use packaging::{
    documentation, ssp, CheckedDescription, REFERENCE_VEHICLE, VEHICLE_STATE_ESTIMATOR,
};

// The scratch folder of the harness's tests (removed at the end of a test, KEEP_TEST_DIRS=1
// keeps a failing test's): one definition for the workspace's test binaries.
#[path = "../../harness/master/tests/common/scratch.rs"]
mod scratch;

use scratch::Scratch;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

fn fixture_text(id: &str) -> String {
    std::fs::read_to_string(fixtures().join(format!("modelDescription/{id}.xml"))).unwrap()
}

fn parse(id: &str, text: &str) -> ModelDescription {
    description::parse(Path::new(&format!("modelDescription/{id}.xml")), text).unwrap()
}

fn vehicle() -> ModelDescription {
    parse("ReferenceVehicle", &fixture_text("ReferenceVehicle"))
}

fn estimator() -> ModelDescription {
    parse(
        "VehicleStateEstimator",
        &fixture_text("VehicleStateEstimator"),
    )
}

/// Problems of the vehicle fixture after replacing `from` by `to` (which must occur).
fn vehicle_problems_after(from: &str, to: &str) -> Vec<String> {
    let text = fixture_text("ReferenceVehicle");
    assert!(text.contains(from), "fixture does not contain {from:?}");
    let path = Path::new("modelDescription/ReferenceVehicle.xml");
    match description::parse(path, &text.replacen(from, to, 1)) {
        Err(description::Problems(problems)) => problems.iter().map(ToString::to_string).collect(),
        Ok(description) => description::check(&description, "ReferenceVehicle")
            .iter()
            .map(ToString::to_string)
            .collect(),
    }
}

#[test]
fn fixture_descriptions_are_read_completely() {
    let vehicle = vehicle();
    assert_eq!(vehicle.fmi_version, "2.0");
    assert_eq!(vehicle.model_identifier, "ReferenceVehicle");
    assert_eq!(vehicle.guid, "{11111111-2222-3333-4444-555555555555}");
    assert_eq!(vehicle.variables.len(), 8);
    let steering = vehicle.variable("steering_angle").unwrap();
    assert_eq!(steering.causality, "input");
    assert_eq!(steering.variability, "continuous");
    assert_eq!(steering.unit.as_deref(), Some("rad"));
    assert_eq!(steering.display_unit.as_deref(), Some("deg"));
    assert_eq!(steering.start.as_deref(), Some("0"));
    assert_eq!(steering.line, 26);
    let model = vehicle.variable("model").unwrap();
    assert_eq!(model.type_name, "Enumeration");
    assert_eq!(model.declared_type.as_deref(), Some("VehicleModel"));
    let items = &vehicle.simple_type("VehicleModel").unwrap().items;
    assert_eq!(items.len(), 2);
    // Entities in attributes are unescaped.
    assert_eq!(items[0].description.as_deref(), Some("model A <5 states>"));
    assert_eq!(vehicle.structure_outputs, vec![4, 5, 6]);
    assert_eq!(
        vehicle.unit_definition("m/s").unwrap().display_units[0].name,
        "km/h"
    );
    assert_eq!(
        vehicle.co_simulation_attribute("canGetAndSetFMUstate"),
        Some("true")
    );
    assert_eq!(
        vehicle.default_experiment,
        vec![
            ("startTime".to_string(), "0".to_string()),
            ("stopTime".to_string(), "12".to_string()),
            ("stepSize".to_string(), "0.001".to_string())
        ]
    );
    assert!(description::check(&vehicle, "ReferenceVehicle").is_empty());
    assert!(description::check(&estimator(), "VehicleStateEstimator").is_empty());
}

#[test]
fn check_descriptions_accepts_the_fixture_workspace() {
    let checked = packaging::check_descriptions(&fixtures()).unwrap();
    assert_eq!(checked.len(), 2);
    assert_eq!(checked[0].spec, REFERENCE_VEHICLE);
    assert_eq!(checked[1].spec, VEHICLE_STATE_ESTIMATOR);
    // The packaged XML is the file's exact bytes, so the binary's generated GUID still matches.
    assert_eq!(
        checked[0].xml,
        std::fs::read(fixtures().join("modelDescription/ReferenceVehicle.xml")).unwrap()
    );
}

#[test]
fn missing_file_is_named() {
    let scratch = Scratch::new("missing");
    let directory = &scratch.0;
    let error = packaging::check_descriptions(directory)
        .unwrap_err()
        .to_string();
    assert!(error.contains("ReferenceVehicle.xml"), "{error}");
    assert!(error.contains("VehicleStateEstimator.xml"), "{error}");
    assert!(error.contains("cannot read"), "{error}");
}

#[test]
fn syntax_error_names_file_and_line() {
    let text = fixture_text("ReferenceVehicle").replace("</ModelVariables>", "</ModelVariable>");
    let problems = description::parse(Path::new("modelDescription/ReferenceVehicle.xml"), &text)
        .unwrap_err()
        .to_string();
    assert!(
        problems.starts_with("modelDescription/ReferenceVehicle.xml:37: XML syntax"),
        "{problems}"
    );
}

#[test]
fn wrong_root_is_rejected() {
    let error = description::parse(
        Path::new("x.xml"),
        "<fmiModelDescriptio fmiVersion=\"2.0\"/>",
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("expected <fmiModelDescription>"), "{error}");
}

/// Packaging refuses what the model-description crate (the FMU build's own parser) rejects, and
/// passes its message on with file and line; the identifier rule is packaging's own.
#[test]
fn each_rule_reports_its_problem() {
    let cases: [(&str, &str, &str); 8] = [
        (
            "modelIdentifier=\"ReferenceVehicle\"",
            "modelIdentifier=\"RefVehicle\"",
            "modelIdentifier is \"RefVehicle\", expected \"ReferenceVehicle\"",
        ),
        (
            "<Real unit=\"m/s\"/>",
            "<Real/>",
            "ReferenceVehicle.xml:30: variable 'vy' (valueReference 3): Real variable without a unit",
        ),
        (
            "<Real unit=\"m/s2\"/>",
            "<Real unit=\"g\"/>",
            ":32: variable 'ay_meas' (valueReference 5): unit 'g' is not defined",
        ),
        (
            "<Real unit=\"N.m\" start=\"0\"/>",
            "<Real unit=\"N.m\"/>",
            ":28: variable 'drive_torque' (valueReference 1): has no start value",
        ),
        (
            "description=\"Measured yaw rate, positive left\"",
            "",
            ":31: variable 'yaw_rate_meas' (valueReference 4): has no description",
        ),
        (
            "<Unknown index=\"6\"/>\n    </Outputs>",
            "</Outputs>",
            "<ModelStructure><Outputs>: expected exactly the indices",
        ),
        (
            "start=\"0\" max=\"0\"",
            "start=\"5\" max=\"0\"",
            "variable 'brake_torque' (valueReference 2): start 5 is above max 0",
        ),
        (
            "<CoSimulation",
            "<ModelExchange modelIdentifier=\"ReferenceVehicle\"/><CoSimulation",
            ":4: <ModelExchange>: this project's FMUs are Co-Simulation only",
        ),
    ];
    let mut failures = Vec::new();
    for (from, to, expected) in cases {
        let problems = vehicle_problems_after(from, to);
        let named = problems
            .iter()
            .all(|p| p.starts_with("modelDescription/ReferenceVehicle.xml"));
        if problems.is_empty() || !named || !problems.iter().any(|p| p.contains(expected)) {
            failures.push(format!(
                "replacing {from:?} by {to:?}: expected a problem containing {expected:?}, got {problems:?}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn bad_value_reference_fails_parsing_with_the_variable_name() {
    let text =
        fixture_text("ReferenceVehicle").replace("valueReference=\"3\"", "valueReference=\"-3\"");
    let error = description::parse(Path::new("r.xml"), &text)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with("r.xml:30: variable 'vy': attribute 'valueReference' = \"-3\""),
        "{error}"
    );
}

#[test]
fn ssp_plan_connects_outputs_to_inputs_by_name_component_to_component() {
    let plan = ssp::plan(&vehicle(), &estimator()).unwrap();
    let describe: Vec<String> = plan
        .connections
        .iter()
        .map(|c| {
            format!(
                "{}.{} -> {}.{}",
                c.start_element, c.start_connector, c.end_element, c.end_connector
            )
        })
        .collect();
    assert_eq!(
        describe,
        vec![
            "ReferenceVehicle.yaw_rate_meas -> VehicleStateEstimator.yaw_rate_meas",
            "ReferenceVehicle.ay_meas -> VehicleStateEstimator.ay_meas",
        ]
    );
    assert_eq!(
        plan.unconnected_estimator_inputs,
        vec!["vx_meas".to_string()]
    );
    assert_eq!(
        plan.connected_inputs("VehicleStateEstimator"),
        vec!["yaw_rate_meas", "ay_meas"]
    );
}

#[test]
fn ssp_plan_rejects_mismatched_connections() {
    let text = fixture_text("VehicleStateEstimator");
    let unit_mismatch = parse(
        "VehicleStateEstimator",
        &text.replace(
            "<Real unit=\"m/s2\" start=\"0\"/>",
            "<Real unit=\"rad/s\" start=\"0\"/>",
        ),
    );
    let error = ssp::plan(&vehicle(), &unit_mismatch)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("\"ay_meas\" has unit Some(\"m/s2\")"),
        "{error}"
    );

    let type_mismatch = parse(
        "VehicleStateEstimator",
        &text.replace(
            "name=\"ay_meas\" valueReference=\"4\" causality=\"input\" description=\"Measured lateral acceleration\"><Real unit=\"m/s2\" start=\"0\"/>",
            "name=\"ay_meas\" valueReference=\"4\" causality=\"input\" variability=\"discrete\" description=\"x\"><Integer start=\"0\"/>",
        ),
    );
    let error = ssp::plan(&vehicle(), &type_mismatch)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("is Real but VehicleStateEstimator input \"ay_meas\" is Integer"),
        "{error}"
    );

    let no_brake = parse(
        "VehicleStateEstimator",
        &text.replace("name=\"brake_torque\"", "name=\"brake\""),
    );
    let error = ssp::plan(&vehicle(), &no_brake).unwrap_err().to_string();
    assert!(error.contains("has no input \"brake_torque\""), "{error}");
}

#[test]
fn system_structure_lists_connected_inputs_all_outputs_and_units() {
    let (vehicle, estimator) = (vehicle(), estimator());
    let plan = ssp::plan(&vehicle, &estimator).unwrap();
    let ssd = ssp::system_structure(&vehicle, &estimator, &plan, "packaging test").unwrap();
    for expected in [
        "<ssd:SystemStructureDescription xmlns:ssd=\"http://ssp-standard.org/SSP1/SystemStructureDescription\" xmlns:ssc=\"http://ssp-standard.org/SSP1/SystemStructureCommon\" xmlns:osp=\"http://opensimulationplatform.com/SSP/OSPAnnotations\" version=\"1.0\" name=\"VehicleWithEstimator\"",
        "<ssd:Component name=\"ReferenceVehicle\" type=\"application/x-fmu-sharedlibrary\" source=\"resources/ReferenceVehicle.fmu\">",
        "<ssd:Component name=\"VehicleStateEstimator\" type=\"application/x-fmu-sharedlibrary\" source=\"resources/VehicleStateEstimator.fmu\">",
        "<ssd:ParameterBinding type=\"application/x-ssp-parameter-set\" source=\"resources/driver_inputs.ssv\"/>",
        "<ssd:Connector name=\"vy_est\" kind=\"output\"><ssc:Real unit=\"m/s\"/></ssd:Connector>",
        "<ssd:Connector name=\"status\" kind=\"output\"><ssc:Integer/></ssd:Connector>",
        "<ssd:Connection startElement=\"ReferenceVehicle\" startConnector=\"ay_meas\" endElement=\"VehicleStateEstimator\" endConnector=\"ay_meas\"/>",
        "<ssc:Unit name=\"m/s2\"><ssc:BaseUnit m=\"1\" s=\"-2\"/></ssc:Unit>",
        "<ssd:DefaultExperiment startTime=\"0\" stopTime=\"12\">\n    <ssd:Annotations>\n      <ssc:Annotation type=\"com.opensimulationplatform\">\n        <osp:Algorithm>\n          <osp:FixedStepAlgorithm baseStepSize=\"0.001\"/>",
    ] {
        assert!(ssd.contains(expected), "missing {expected:?} in\n{ssd}");
    }
    // Both components bind the driver inputs; libcosim and Ecos need both ends of a connection
    // to be components, so the system has no connectors and no connection lacks a startElement.
    assert_eq!(ssd.matches("<ssd:ParameterBinding ").count(), 2, "{ssd}");
    assert!(
        !ssd.contains("\n    <ssd:Connectors>"),
        "system connectors in\n{ssd}"
    );
    assert_eq!(
        ssd.matches("<ssd:Connection ").count(),
        ssd.matches("<ssd:Connection startElement=").count()
    );
    // An unconnected input has no connector (the driver inputs come from the binding),
    // parameters are not connectors.
    assert!(!ssd.contains("\"vx_meas\""), "{ssd}");
    assert!(!ssd.contains("\"steering_angle\""), "{ssd}");
    assert!(!ssd.contains("name=\"noise\""), "{ssd}");
    // Well-formed XML: every element closes.
    let mut reader = quick_xml::Reader::from_str(&ssd);
    let mut depth = 0i32;
    loop {
        match reader.read_event().unwrap() {
            quick_xml::events::Event::Start(_) => depth += 1,
            quick_xml::events::Event::End(_) => depth -= 1,
            quick_xml::events::Event::Eof => break,
            _ => {}
        }
    }
    assert_eq!(depth, 0);
}

#[test]
fn zip_is_deterministic_and_keeps_layout_and_modes() {
    let entries = vec![
        Entry::file("modelDescription.xml", "<x/>"),
        Entry::executable(
            "binaries/linux64/ReferenceVehicle.so",
            vec![0x7f, b'E', b'L', b'F', 1, 2, 3],
        ),
        Entry::stored("resources/inner.fmu", vec![9u8; 100]),
    ];
    let first = archive::zip_bytes(&entries).unwrap();
    let second = archive::zip_bytes(&entries).unwrap();
    assert_eq!(first, second, "same entries must give the same bytes");
    assert_eq!(
        archive::entry_names(&first).unwrap(),
        vec![
            "modelDescription.xml",
            "binaries/linux64/ReferenceVehicle.so",
            "resources/inner.fmu"
        ]
    );
    assert_eq!(
        archive::read_entry(&first, "modelDescription.xml").unwrap(),
        b"<x/>"
    );
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(&first)).unwrap();
    assert_eq!(
        zip.by_name("binaries/linux64/ReferenceVehicle.so")
            .unwrap()
            .unix_mode(),
        Some(0o100755)
    );
    assert_eq!(
        zip.by_name("modelDescription.xml").unwrap().unix_mode(),
        Some(0o100644)
    );
    assert_eq!(
        zip.by_name("resources/inner.fmu").unwrap().compression(),
        zip::CompressionMethod::Stored
    );
}

#[test]
fn zip_rejects_bad_paths_and_duplicates() {
    for path in ["/abs.xml", "a\\b.xml", "a/../b", "", "a//b", "./a"] {
        assert!(
            archive::zip_bytes(&[Entry::file(path, "x")]).is_err(),
            "path {path:?} must be rejected"
        );
    }
    let error = archive::zip_bytes(&[Entry::file("a", "1"), Entry::file("a", "2")])
        .unwrap_err()
        .to_string();
    assert!(error.contains("appears twice"), "{error}");
}

#[test]
fn atomic_write_replaces_skips_unchanged_and_leaves_no_temporary_file() {
    let scratch = Scratch::new("atomic");
    let directory = &scratch.0;
    let destination = directory.join("sub/out.fmu");
    assert_eq!(
        archive::write_if_changed(&destination, b"one").unwrap(),
        WriteOutcome::Written
    );
    assert_eq!(std::fs::read(&destination).unwrap(), b"one");
    assert_eq!(
        archive::write_if_changed(&destination, b"one").unwrap(),
        WriteOutcome::Unchanged
    );
    assert_eq!(
        archive::write_if_changed(&destination, b"two").unwrap(),
        WriteOutcome::Written
    );
    assert_eq!(std::fs::read(&destination).unwrap(), b"two");
    let leftovers: Vec<_> = std::fs::read_dir(directory.join("sub"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(leftovers, vec!["out.fmu".to_string()]);
}

#[test]
fn failed_atomic_write_keeps_the_old_destination_and_cleans_up() {
    let scratch = Scratch::new("atomic-fail");
    let directory = &scratch.0;
    // A non-empty directory where the archive should go: the final rename must fail.
    let destination = directory.join("blocked.fmu");
    std::fs::create_dir_all(destination.join("keep")).unwrap();
    let error = archive::write_atomically(&destination, b"new").unwrap_err();
    assert!(format!("{error:#}").contains("renaming"), "{error:#}");
    assert!(
        destination.join("keep").is_dir(),
        "the old destination must survive"
    );
    let names: Vec<_> = std::fs::read_dir(directory)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(
        names,
        vec!["blocked.fmu".to_string()],
        "temporary file left behind"
    );
}

fn checked(spec: packaging::FmuSpec, description: ModelDescription) -> CheckedDescription {
    let xml = fixture_text(spec.model_identifier).into_bytes();
    CheckedDescription {
        spec,
        description,
        xml,
    }
}

#[test]
fn fmu_layout_follows_fmi_2() {
    let licenses =
        packaging::license_files(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))).unwrap();
    let entries = packaging::fmu_entries(
        &checked(REFERENCE_VEHICLE, vehicle()),
        "2026-01-02T03:04:05Z",
        b"\x7fELF".to_vec(),
        "<p>prose</p>",
        &licenses,
        &["nalgebra v0.35.0  Apache-2.0".to_string()],
    )
    .unwrap();
    let names: Vec<&str> = entries.iter().map(|e| e.path.as_str()).collect();
    assert_eq!(
        names,
        vec![
            "modelDescription.xml",
            "model.png",
            "binaries/linux64/ReferenceVehicle.so",
            "documentation/index.html",
            "documentation/licenses/LICENSE.txt",
            "documentation/licenses/LICENSE-MIT.txt",
            "documentation/licenses/LICENSE-APACHE.txt",
            "documentation/licenses/THIRD-PARTY.txt",
        ]
    );
    assert!(entries[2].executable);
    let notice = String::from_utf8(entries[7].contents.clone()).unwrap();
    assert!(notice.contains("nalgebra v0.35.0  Apache-2.0"), "{notice}");
    let apache = String::from_utf8(entries[6].contents.clone()).unwrap();
    assert!(apache.contains("Apache License") && apache.contains("Version 2.0"));
}

#[test]
fn ssp_archive_holds_ssd_and_both_fmus() {
    let (vehicle, estimator) = (vehicle(), estimator());
    let (entries, plan) =
        packaging::ssp_entries(&vehicle, &estimator, b"vehicle", b"estimator", &[]).unwrap();
    assert_eq!(plan.connections.len(), 2);
    let names: Vec<&str> = entries.iter().map(|e| e.path.as_str()).collect();
    assert_eq!(
        names,
        vec![
            "SystemStructure.ssd",
            "resources/ReferenceVehicle.fmu",
            "resources/VehicleStateEstimator.fmu",
            "resources/driver_inputs.ssv"
        ]
    );
    assert!(entries[1].stored && entries[2].stored);
    assert_eq!(entries[2].contents, b"estimator");
}

#[test]
fn driver_parameter_set_holds_the_seed_step_steer_angle_as_reals_with_units() {
    let ssv = ssp::driver_parameter_set(&vehicle(), "packaging test").unwrap();
    for expected in [
        "<ssv:ParameterSet xmlns:ssc=\"http://ssp-standard.org/SSP1/SystemStructureCommon\" xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\" version=\"1.0\" name=\"driver inputs\"",
        // 2 degrees (000: fig. 7.18) in radians, printed so that it reads back bit for bit.
        "<ssv:Parameter name=\"steering_angle\"><ssv:Real value=\"0.03490658503988659\" unit=\"rad\"/></ssv:Parameter>",
        "<ssv:Parameter name=\"brake_torque\"><ssv:Real value=\"0.0\" unit=\"N.m\"/></ssv:Parameter>",
    ] {
        assert!(ssv.contains(expected), "missing {expected:?} in\n{ssv}");
    }
    assert!(!ssv.contains("Enumeration") && !ssv.contains("Boolean"));
    let no_drive = parse(
        "ReferenceVehicle",
        &fixture_text("ReferenceVehicle").replace("name=\"drive_torque\"", "name=\"drive\""),
    );
    let error = ssp::driver_parameter_set(&no_drive, "t")
        .unwrap_err()
        .to_string();
    assert!(error.contains("has no input \"drive_torque\""), "{error}");
}

#[test]
fn ssp_archive_ships_the_car_parameter_files_as_resources() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let cars = packaging::car_parameter_files(root).unwrap();
    let names: Vec<&str> = cars.iter().map(|c| c.file_name.as_str()).collect();
    assert_eq!(
        names,
        [
            "bmw_320i.ssv",
            "ford_escort.ssv",
            "seed_car.ssv",
            "vw_vanagon.ssv"
        ]
    );
    let (vehicle, estimator) = (vehicle(), estimator());
    let (entries, _) =
        packaging::ssp_entries(&vehicle, &estimator, b"vehicle", b"estimator", &cars).unwrap();
    let resources: Vec<&str> = entries[4..].iter().map(|e| e.path.as_str()).collect();
    assert_eq!(
        resources,
        [
            "resources/bmw_320i.ssv",
            "resources/ford_escort.ssv",
            "resources/seed_car.ssv",
            "resources/vw_vanagon.ssv"
        ]
    );
    let bmw = String::from_utf8(entries[4].contents.clone()).unwrap();
    assert!(bmw.contains("<ssv:ParameterSet") && bmw.contains("name=\"mass\""));
}

#[test]
fn documentation_is_generated_from_every_variable() {
    // Read from its file: the page's variable reference is generated from the file the
    // description names (model_description::docs, the generator of docs/reference/).
    let vehicle =
        description::read_file(&fixtures().join("modelDescription/ReferenceVehicle.xml")).unwrap();
    let html = documentation::index_html(&vehicle, "<p>The <em>model</em> prose.</p>");
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(
        html.contains("<p>The <em>model</em> prose.</p>"),
        "prose is included verbatim"
    );
    for variable in &vehicle.variables {
        assert!(
            html.contains(&format!("<td><code>{}</code></td>", variable.name)),
            "{} missing",
            variable.name
        );
        assert!(html.contains(variable.description.as_deref().unwrap()));
    }
    assert!(!html.contains("could not be generated"));
    assert!(html.contains("<h2>Inputs (3)</h2>"));
    assert!(html.contains("<h2>Outputs (3)</h2>"));
    assert!(html.contains("<h2>Parameters (2)</h2>"));
    assert!(html.contains("rad (shown in deg)"));
    // Enumeration items are listed and escaped.
    assert!(html.contains(
        "<tr><td>1</td><td><code>single_track_hsri</code></td><td>model A &lt;5 states&gt;</td></tr>"
    ));
    assert!(html.contains("{11111111-2222-3333-4444-555555555555}"));
    assert!(html.contains("<code>canHandleVariableCommunicationStepSize</code> = true"));
    assert!(html.contains("km/h (factor 3.6, offset 0)"));
    assert!(html.contains("<code>logStatusError</code>: errors"));
    assert!(html.contains("href=\"licenses/LICENSE.txt\""));
}

#[test]
fn writing_a_set_stages_everything_before_replacing_anything() {
    let scratch = Scratch::new("set");
    let directory = &scratch.0;
    let first = directory.join("a.fmu");
    let second = directory.join("b.fmu");
    std::fs::write(&first, b"old a").unwrap();
    std::fs::write(&second, b"same b").unwrap();
    let outcomes = archive::write_all_if_changed(&[
        (first.clone(), b"new a".to_vec()),
        (second.clone(), b"same b".to_vec()),
    ])
    .unwrap();
    assert_eq!(
        outcomes,
        vec![WriteOutcome::Written, WriteOutcome::Unchanged]
    );
    assert_eq!(std::fs::read(&first).unwrap(), b"new a");

    // The second destination's directory cannot be created (a file is in the way): staging fails,
    // and the first destination must keep its old content.
    std::fs::write(directory.join("blocker"), b"file").unwrap();
    let error = archive::write_all_if_changed(&[
        (first.clone(), b"newer a".to_vec()),
        (directory.join("blocker/c.fmu"), b"c".to_vec()),
    ])
    .unwrap_err();
    assert!(format!("{error:#}").contains("blocker"), "{error:#}");
    assert_eq!(std::fs::read(&first).unwrap(), b"new a");
    let mut names: Vec<_> = std::fs::read_dir(directory)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        vec!["a.fmu", "b.fmu", "blocker"],
        "temporary files left behind"
    );
}

/// The project's own model descriptions pass, and the SSP connects every sensor signal by name.
#[test]
fn workspace_model_descriptions_connect_every_sensor() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let checked = packaging::check_descriptions(&root).unwrap();
    let plan = ssp::plan(&checked[0].description, &checked[1].description).unwrap();
    for sensor in [
        "yaw_rate_meas",
        "ay_meas",
        "omega_front_meas",
        "omega_rear_meas",
        "ax_meas",
        "vx_meas",
    ] {
        assert!(
            plan.connections
                .iter()
                .any(|c| c.start_element == "ReferenceVehicle"
                    && c.start_connector == sensor
                    && c.end_connector == sensor),
            "{sensor} is not connected"
        );
    }
    // What stays unconnected keeps its start value: inputs with no ReferenceVehicle counterpart
    // (a rear drive torque), never a sensor signal.
    assert!(
        plan.unconnected_estimator_inputs
            .iter()
            .all(|name| !name.ends_with("_meas")),
        "{:?}",
        plan.unconnected_estimator_inputs
    );
    // Every page the archives ship has its prose.
    for c in &checked {
        assert!(packaging::prose_path(&root, c.spec).is_file());
    }
}

#[test]
fn archived_model_description_gains_only_the_generation_time() {
    let repository = fixture_text("ReferenceVehicle");
    let stamped = packaging::generation_time::stamp_model_description(
        repository.as_bytes(),
        "2026-01-02T03:04:05Z",
    )
    .unwrap();
    let stamped = String::from_utf8(stamped).unwrap();
    let attribute = "\n  generationDateAndTime=\"2026-01-02T03:04:05Z\"";
    assert_eq!(stamped.replacen(attribute, "", 1), repository);
    parse("ReferenceVehicle", &stamped);
    let error = packaging::generation_time::stamp_model_description(stamped.as_bytes(), "x")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("already has generationDateAndTime"),
        "{error}"
    );
}

#[test]
fn generation_time_is_utc_iso_8601() {
    use packaging::generation_time::iso8601_utc;
    assert_eq!(iso8601_utc(0), "1970-01-01T00:00:00Z");
    // Values checked with `date -u -d @N +%FT%TZ`.
    assert_eq!(iso8601_utc(951_782_400), "2000-02-29T00:00:00Z");
    assert_eq!(iso8601_utc(1_700_000_000), "2023-11-14T22:13:20Z");
    assert_eq!(iso8601_utc(4_107_542_399), "2100-02-28T23:59:59Z");
    assert_eq!(iso8601_utc(253_402_300_799), "9999-12-31T23:59:59Z");
}

#[test]
fn model_icons_are_deterministic_pngs_that_differ_per_fmu() {
    use packaging::icon::{icon_pixels, model_png, Icon, ICON_SIZE};
    let vehicle = model_png(Icon::ReferenceVehicle).unwrap();
    assert_eq!(vehicle, model_png(Icon::ReferenceVehicle).unwrap());
    assert_eq!(&vehicle[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height big-endian at bytes 16..24.
    assert_eq!(vehicle[16..20], ICON_SIZE.to_be_bytes());
    assert_eq!(vehicle[20..24], ICON_SIZE.to_be_bytes());
    let estimator = model_png(Icon::Estimator).unwrap();
    assert_ne!(vehicle, estimator);
    let pixels = icon_pixels(Icon::Estimator).unwrap();
    let colours: std::collections::BTreeSet<&[u8]> = pixels.chunks(3).collect();
    assert!(colours.len() > 5, "an icon of {} colours", colours.len());
}
