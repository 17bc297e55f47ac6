//! `harness fmi-versions` on one row of the shipped campaigns (the step steer on the first car's
//! first reference model, every estimator instance): the study's whole path, from the campaign
//! through both FMI versions to its CSV. The full study runs every row (docs/reference/fmi3.md).
//!
//! Needs the packaged FMUs of both versions (`cargo run --release -p packaging`).

use fmi_master::fmu::VariableType;
use fmi_master::runner::{packaged_fmu_dir, scenario_dir, Environment, PACKAGED_FMUS};
use harness::campaigns::{Campaign, DEFAULT_ESTIMATOR, SHIPPED_CAMPAIGNS};
use harness::fmi_versions::{self, CSV_NAME, HEADER};

use crate::scratch::Scratch;

/// The shipped campaigns cut to one row: the step steer on the first car's first reference model.
fn step_steer_on_the_first_car() -> Campaign {
    let mut campaign = Campaign::load(&scenario_dir().join(SHIPPED_CAMPAIGNS)).expect("campaigns");
    campaign.file.cars.truncate(1);
    campaign.file.reference_models.truncate(1);
    campaign.file.manoeuvres.retain(|m| m.name == "step_steer");
    campaign
}

#[test]
fn one_campaign_row_records_the_same_bits_through_fmi2_and_fmi3() {
    let scratch = Scratch::new("fmi_versions");
    let env = Environment {
        fmu_dir: packaged_fmu_dir().expect("packaged FMUs"),
        out_dir: scratch.0.clone(),
    };
    let campaign = step_steer_on_the_first_car();
    let report = fmi_versions::compare_campaign(&campaign, &env)
        .unwrap_or_else(|e| panic!("the study runs: {e:#}"));
    eprintln!("{}", report.summary());
    assert_eq!(report.runs.len(), 1, "{report:?}");
    let run = &report.runs[0];
    assert_eq!(
        (run.car.as_str(), run.manoeuvre.as_str()),
        ("ford_escort", "step_steer")
    );
    // Every output of every estimator instance is compared, not only the campaign's own five.
    let estimator_outputs = campaign
        .estimator_fmu(&env)
        .expect("estimator FMU")
        .variables
        .iter()
        .filter(|v| v.is_output() && v.var_type != VariableType::String)
        .count();
    assert!(
        run.comparison.columns > campaign.estimators.len() * estimator_outputs,
        "{run:?}, {estimator_outputs} outputs per estimator"
    );
    // 5 s at 10 ms, both ends
    assert_eq!(run.comparison.samples, 501, "{run:?}");
    assert_eq!(run.comparison.differing, 0, "{run:?}");
    report.check().expect("nothing differs");
    let csv = report.write(&scratch.0, false).expect("the CSV is written");
    assert_eq!(csv, scratch.0.join(CSV_NAME));
    let text = std::fs::read_to_string(&csv).expect("the CSV reads");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], HEADER.join(","));
    assert_eq!(
        lines[1],
        format!("ford_escort,step_steer,{},501,0,0", run.comparison.columns)
    );
    assert!(
        !scratch.0.join(".runs").exists(),
        "the runs' folder is removed"
    );
}

/// The FMI 3.0 side runs the FMI 3.0 archives: beside the FMI 2.0 archives alone the study stops
/// at its first FMI 3.0 run, naming the `-fmi3.fmu` it looked for (on the step steer with the
/// default estimator alone, to stay fast).
#[test]
fn without_the_fmi3_archives_the_study_names_the_one_missing() {
    let scratch = Scratch::new("fmi_versions_fmi2_only");
    let fmi2_only = scratch.0.join("fmu");
    std::fs::create_dir_all(&fmi2_only).expect("a folder for the FMI 2.0 archives");
    let packaged = packaged_fmu_dir().expect("packaged FMUs");
    for archive in PACKAGED_FMUS {
        std::fs::copy(packaged.join(archive), fmi2_only.join(archive)).expect("copies");
    }
    let env = Environment {
        fmu_dir: fmi2_only,
        out_dir: scratch.0.join("out"),
    };
    let campaign = step_steer_on_the_first_car()
        .with_estimators(&[DEFAULT_ESTIMATOR])
        .expect("the default estimator is in the campaigns");
    let error = format!(
        "{:#}",
        fmi_versions::compare_campaign(&campaign, &env).unwrap_err()
    );
    assert!(error.contains("-fmi3.fmu"), "{error}");
}
