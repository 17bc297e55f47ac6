//! Scenario files with mistakes are refused with a message naming the file and the field.

use std::path::Path;

use fmi_master::scenario::{Scenario, ScenarioError};

const GOOD: &str = r#"
name = "t"
step = 0.001
[manoeuvre]
library = "seed000_ramp_high_ay"
[[fmu]]
name = "vehicle"
path = "{fmu_dir}/ReferenceVehicle.fmu"
[[fmu]]
name = "ekf"
path = "{fmu_dir}/VehicleStateEstimator.fmu"
parameters = { estimator = 2 }
[[connection]]
from = "vehicle"
to = "ekf"
[[input]]
signal = "steering_angle"
to = ["*.steering_angle"]
[[score]]
label = "vy"
truth = "vehicle.vy"
estimate = "*.vy_est"
"#;

fn parse(text: &str) -> Result<Scenario, ScenarioError> {
    Scenario::from_str_at(text, Path::new("bad.toml"), Path::new("."))
}

fn error_of(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("scenario was accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_reference_scenario_parses_with_its_manoeuvre_duration() {
    let s = parse(GOOD).expect("valid scenario");
    assert_eq!(s.stop_time().unwrap(), 12.0);
    assert_eq!(s.step_count().unwrap(), 12_000);
    // Points are t0 + n h, not accumulated sums.
    assert_eq!(s.time_of(7_000), 7_000.0 * 0.001);
    assert_eq!(s.fmus.len(), 2);
}

#[test]
fn unknown_field_names_the_file_and_the_key() {
    let e = error_of(&GOOD.replace("step = 0.001", "step = 0.001\nstpe = 2"));
    assert!(e.contains("bad.toml") && e.contains("stpe"), "{e}");
}

#[test]
fn missing_step_is_reported() {
    let e = error_of(&GOOD.replace("step = 0.001", ""));
    assert!(e.contains("bad.toml") && e.contains("step"), "{e}");
}

#[test]
fn non_positive_step_is_refused() {
    let e = error_of(&GOOD.replace("step = 0.001", "step = -0.001"));
    assert!(e.contains("field `step`") && e.contains("positive"), "{e}");
}

#[test]
fn stop_time_must_be_a_whole_number_of_steps() {
    let e = error_of(&GOOD.replace("step = 0.001", "step = 0.007"));
    assert!(
        e.contains("field `step`") && e.contains("whole number"),
        "{e}"
    );
}

#[test]
fn stop_before_start_is_refused() {
    let e = error_of(&GOOD.replace(
        "step = 0.001",
        "step = 0.001\nstart_time = 20.0\nstop_time = 10.0",
    ));
    assert!(e.contains("field `stop_time`"), "{e}");
}

#[test]
fn connection_to_an_unknown_instance_names_the_connection() {
    let e = error_of(&GOOD.replace("to = \"ekf\"", "to = \"ukf\""));
    assert!(e.contains("connection[0].to") && e.contains("ukf"), "{e}");
}

#[test]
fn mixed_connection_forms_are_refused() {
    let e = error_of(&GOOD.replace("to = \"ekf\"", "to = \"ekf.ay_meas\""));
    assert!(e.contains("connection[0]"), "{e}");
}

#[test]
fn unknown_signal_lists_the_channels() {
    let e = error_of(&GOOD.replace("signal = \"steering_angle\"", "signal = \"throttle\""));
    assert!(
        e.contains("input[0].signal") && e.contains("brake_torque"),
        "{e}"
    );
}

#[test]
fn unknown_library_manoeuvre_lists_the_library() {
    let e = error_of(&GOOD.replace("seed000_ramp_high_ay", "moose"));
    assert!(
        e.contains("manoeuvre.library") && e.contains("seed001_wobble"),
        "{e}"
    );
}

#[test]
fn closed_loop_manoeuvre_needs_feedback() {
    let e = error_of(&GOOD.replace("seed000_ramp_high_ay", "seed001_double_lane_change"));
    assert!(e.contains("manoeuvre.feedback"), "{e}");
}

#[test]
fn duplicate_instance_names_are_refused() {
    let e = error_of(&GOOD.replace("name = \"ekf\"", "name = \"vehicle\""));
    assert!(e.contains("fmu[1].name") && e.contains("twice"), "{e}");
}

#[test]
fn instance_names_must_not_contain_dots() {
    let e = error_of(&GOOD.replace("name = \"ekf\"", "name = \"e.kf\""));
    assert!(e.contains("fmu[1].name"), "{e}");
}

#[test]
fn score_truth_must_name_an_instance() {
    let e = error_of(&GOOD.replace("truth = \"vehicle.vy\"", "truth = \"car.vy\""));
    assert!(e.contains("score[0].truth") && e.contains("car"), "{e}");
}

#[test]
fn variable_references_need_a_dot() {
    let e = error_of(&GOOD.replace("estimate = \"*.vy_est\"", "estimate = \"vy_est\""));
    assert!(
        e.contains("score[0].estimate") && e.contains("instance.variable"),
        "{e}"
    );
}

#[test]
fn custom_manoeuvre_fields_are_checked() {
    let custom = GOOD.replace(
        "library = \"seed000_ramp_high_ay\"",
        "[manoeuvre.custom]\nkind = \"step_steer\"\ntime = 1.0\nangle = 0.1\nrise_time = -1.0\ninitial_speed = 10.0\nduration = 3.0",
    );
    let e = error_of(&custom);
    assert!(
        e.contains("field `manoeuvre`") && e.contains("rise_time"),
        "{e}"
    );
    let typo = custom.replace("rise_time = -1.0", "rise_tim = 0.1");
    let e = error_of(&typo);
    assert!(e.contains("bad.toml") && e.contains("rise_tim"), "{e}");
}

#[test]
fn unreadable_file_names_the_path() {
    let e = Scenario::from_file(Path::new("/nonexistent/scenario.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent/scenario.toml"), "{e}");
}

#[test]
fn every_shipped_scenario_parses() {
    let dir = fmi_master::runner::scenario_dir();
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            Scenario::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
            count += 1;
        }
    }
    assert!(count >= 12, "found only {count} scenarios");
}
