//! Names that parse but do not resolve against the FMUs' model descriptions are refused by
//! `Plan::new`, each step (load, resolve connections, bind inputs, feedback and recording) with
//! a message naming the scenario field.
//!
//! Needs the packaged FMUs (`cargo run --release -p packaging`) in
//! `fmi_master::runner::default_fmu_dir()`.

use std::path::Path;

use fmi_master::cosim::Plan;
use fmi_master::scenario::Scenario;

use crate::common::{Scratch, GOOD};

fn plan_error(text: &str) -> String {
    let fmu_dir = crate::common::packaged_fmus();
    let work = Scratch::new("plan-errors");
    let scenario = Scenario::from_str_at(text, Path::new("bad.toml"), Path::new("."))
        .unwrap_or_else(|e| panic!("the scenario itself must parse: {e}"));
    match Plan::new(scenario, &fmu_dir, &work.0) {
        Ok(_) => panic!("plan was accepted:\n{text}"),
        Err(e) => format!("{e:#}"),
    }
}

fn assert_names(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(message.contains(part), "{part:?} missing in: {message}");
    }
}

#[test]
fn the_good_scenario_plans() {
    let work = Scratch::new("plan-good");
    let scenario = Scenario::from_str_at(GOOD, Path::new("good.toml"), Path::new(".")).unwrap();
    let plan = Plan::new(scenario, &crate::common::packaged_fmus(), &work.0).unwrap();
    assert_eq!(plan.step_order(), ["vehicle", "ekf"]);
    assert!(plan.columns().contains(&"ekf.vy_est".to_string()));
}

#[test]
fn an_unknown_parameter_is_named_in_the_load_step() {
    let e = plan_error(&GOOD.replace("sample_time = 0.001", "sample_tim = 0.001"));
    assert_names(&e, &["bad.toml", "fmu[1].parameters.sample_tim"]);
}

#[test]
fn connections_resolve_to_outputs_and_inputs() {
    let by_name = GOOD.replace(
        "from = \"vehicle\"\nto = \"ekf\"",
        "from = \"vehicle.no_such_output\"\nto = \"ekf.yaw_rate_meas\"",
    );
    assert_names(
        &plan_error(&by_name),
        &[
            "connection[0].from",
            "'vehicle'",
            "no output named \"no_such_output\"",
        ],
    );
    let twice = format!("{GOOD}[[connection]]\nfrom = \"vehicle\"\nto = \"ekf\"\n");
    assert_names(
        &plan_error(&twice),
        &[
            "connection[1]",
            "of 'ekf' is already driven by",
            "connection[0]",
        ],
    );
}

#[test]
fn manoeuvre_inputs_bind_to_real_inputs_driven_once() {
    let nothing = GOOD.replace("to = [\"vehicle.steering_angle\"]", "to = [\"*.nothing\"]");
    assert_names(
        &plan_error(&nothing),
        &["input[0].to[0]", "names no input or parameter of any FMU"],
    );
    let driven = GOOD.replace(
        "to = [\"vehicle.steering_angle\"]",
        "to = [\"ekf.yaw_rate_meas\"]",
    );
    assert_names(
        &plan_error(&driven),
        &[
            "input[0].to[0]",
            "ekf.yaw_rate_meas is already driven by",
            "connection[0]",
        ],
    );
}

#[test]
fn recorded_and_scored_variables_must_exist() {
    let record = format!("{GOOD}[record]\nvariables = [\"vehicle.nothing\"]\n");
    assert_names(
        &plan_error(&record),
        &[
            "record.variables[0]",
            "\"vehicle.nothing\" matches no variable",
        ],
    );
    let truth = GOOD.replace("truth = \"vehicle.vy\"", "truth = \"vehicle.vy_true\"");
    assert_names(
        &plan_error(&truth),
        &[
            "score[0].truth",
            "FMU 'vehicle' has no variable \"vy_true\"",
        ],
    );
}
