//! SSP parameter-value files (`parameter_files = [...]` of an `[[fmu]]`): a car file changes
//! the reference vehicle's behaviour, the scenario's own `parameters` override it, and a name
//! the FMU lacks or a missing file is refused with a message naming it.
//!
//! Needs the packaged FMUs (`cargo run --release -p packaging`) in
//! `fmi_master::runner::default_fmu_dir()`.

use std::path::{Path, PathBuf};

use fmi_master::cosim::{Plan, RunOptions};
use fmi_master::runner::workspace_root;
use fmi_master::scenario::Scenario;

use crate::common::Scratch;

fn cars_dir() -> PathBuf {
    workspace_root().join("fmu-src/reference-vehicle/cars")
}

/// Model 3 (the full vehicle) in a 1 s step steer, with the given parameter files and
/// `parameters` table of the vehicle.
fn step_steer(files: &[PathBuf], parameters: &str) -> String {
    let files: Vec<String> = files.iter().map(|f| format!("{:?}", f)).collect();
    format!(
        r#"
name = "car_file"
step = 0.001
[manoeuvre.custom]
kind = "step_steer"
time = 0.1
angle = 0.03
rise_time = 0.0
initial_speed = 20.0
duration = 1.0
[[fmu]]
name = "vehicle"
path = "{{fmu_dir}}/ReferenceVehicle.fmu"
parameter_files = [{}]
parameters = {{ {parameters} }}
[[input]]
signal = "steering_angle"
to = ["vehicle.steering_angle"]
[[input]]
signal = "initial_speed"
to = ["vehicle.vx0"]
[record]
variables = ["vehicle.yaw_rate"]
"#,
        files.join(", ")
    )
}

fn plan(text: &str, work: &Path) -> anyhow::Result<Plan> {
    let fmu_dir = crate::common::packaged_fmus();
    let scenario = Scenario::from_str_at(text, Path::new("cars.toml"), Path::new("."))
        .unwrap_or_else(|e| panic!("the scenario itself must parse: {e}"));
    Plan::new(scenario, &fmu_dir, work)
}

fn final_yaw_rate(text: &str, work: &Path) -> f64 {
    let plan = plan(text, work).unwrap_or_else(|e| panic!("{e:#}"));
    let result = plan.run(&RunOptions::default(), |_| {}).unwrap();
    *result.column("vehicle.yaw_rate").unwrap().last().unwrap()
}

#[test]
fn a_car_file_changes_the_yaw_response_and_parameters_override_it() {
    let scratch = Scratch::new("parameter-files-yaw");
    let car = |name: &str| cars_dir().join(name);
    let seed = final_yaw_rate(&step_steer(&[car("seed_car.ssv")], ""), &scratch.0);
    let van = final_yaw_rate(&step_steer(&[car("vw_vanagon.ssv")], ""), &scratch.0);
    assert!(
        seed.is_finite() && van.is_finite() && seed > 0.0 && van > 0.0,
        "{seed} {van}"
    );
    assert!(
        (seed - van).abs() > 1e-3 * seed.abs(),
        "the Vanagon turns like the seed car: {seed} vs {van}"
    );
    // The scenario's table is applied after the file: the seed car's mass over the Vanagon's
    // file must differ from the Vanagon alone.
    let heavier = final_yaw_rate(
        &step_steer(&[car("vw_vanagon.ssv")], "mass = 3000.0"),
        &scratch.0,
    );
    assert!((heavier - van).abs() > 1e-6, "{heavier} vs {van}");
}

/// The message with which a plan applying a file of `content` (named `file_name`) is refused.
fn refusal(file_name: &str, content: &str) -> String {
    let scratch = Scratch::new(file_name);
    let file = scratch.0.join(file_name);
    std::fs::write(&file, content).unwrap();
    let refused = plan(&step_steer(&[file], ""), &scratch.0).err();
    format!("{:#}", refused.expect("the plan was accepted"))
}

#[test]
fn an_unknown_name_is_refused_naming_file_line_parameter_and_fmu() {
    let message = refusal(
        "typo.ssv",
        "<?xml version=\"1.0\"?>\n<ssv:ParameterSet xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\" version=\"1.0\" name=\"t\">\n<ssv:Parameters>\n\
         <ssv:Parameter name=\"masss\"><ssv:Real value=\"1.0\"/></ssv:Parameter>\n\
         </ssv:Parameters></ssv:ParameterSet>\n",
    );
    for part in [
        "typo.ssv",
        "line 4",
        "\"masss\"",
        "ReferenceVehicle.fmu",
        "parameter_files[0]",
    ] {
        assert!(message.contains(part), "{part:?} missing in: {message}");
    }
}

#[test]
fn an_output_is_refused_as_it_is_no_parameter() {
    let message = refusal(
        "output.ssv",
        "<ssv:ParameterSet><ssv:Parameters>\
         <ssv:Parameter name=\"yaw_rate\"><ssv:Real value=\"1.0\"/></ssv:Parameter>\
         </ssv:Parameters></ssv:ParameterSet>",
    );
    assert!(
        message.contains("\"yaw_rate\"") && message.contains("causality output"),
        "{message}"
    );
}

#[test]
fn a_missing_file_is_named() {
    let scratch = Scratch::new("parameter-files-missing");
    let missing = scratch.0.join("no_such_car.ssv");
    let message = format!(
        "{:#}",
        plan(&step_steer(&[missing], ""), &scratch.0).err().unwrap()
    );
    assert!(
        message.contains("no_such_car.ssv") && message.contains("cannot read"),
        "{message}"
    );
}

/// A scenario selects an Enumeration value by its item name from the modelDescription, with
/// the same result as its number; an unknown item is refused with the field and the items.
#[test]
fn an_enumeration_is_set_by_its_item_name() {
    let scratch = Scratch::new("parameter-files-enumeration");
    let car = [cars_dir().join("seed_car.ssv")];
    let by_number = final_yaw_rate(&step_steer(&car, "model = 2"), &scratch.0);
    let by_name = final_yaw_rate(
        &step_steer(&car, "model = \"two_track_magic_formula\""),
        &scratch.0,
    );
    assert_eq!(by_name.to_bits(), by_number.to_bits());
    let message = format!(
        "{:#}",
        plan(&step_steer(&car, "model = \"two_track\""), &scratch.0)
            .err()
            .expect("an unknown item is refused")
    );
    for part in [
        "fmu[0].parameters.model",
        "\"two_track\"",
        "two_track_magic_formula",
    ] {
        assert!(message.contains(part), "{part:?} missing in: {message}");
    }
}
