//! Every seed scenario run through FMI 2.0 and through FMI 3.0 (`Plan::with_version`) on the
//! packaged archives: one library serves both, so every recorded value must be bit-identical.
//! Needs the archives `cargo run --release -p packaging` writes (the test fails naming the
//! command when they are missing).

use std::path::PathBuf;

use super::{FmiVersion, Plan, RunOptions};
use crate::scenario::Scenario;

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Where packaging writes the archives: `$CARGO_TARGET_DIR/fmu` or the workspace's `target/fmu`.
fn fmu_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(target) => workspace().join(target).join("fmu"),
        None => workspace().join("target").join("fmu"),
    }
}

#[test]
fn every_seed_scenario_records_the_same_bits_through_fmi2_and_fmi3() {
    let fmus = fmu_dir();
    for archive in [
        "VehicleStateEstimator-fmi3.fmu",
        "ReferenceVehicle-fmi3.fmu",
    ] {
        assert!(
            fmus.join(archive).is_file(),
            "{} is missing: build the archives with `cargo run --release -p packaging`",
            fmus.join(archive).display()
        );
    }
    let mut scenarios: Vec<PathBuf> = std::fs::read_dir(workspace().join("harness/scenarios"))
        .expect("harness/scenarios")
        .map(|entry| entry.expect("a directory entry").path())
        .filter(|path| {
            let name = path.file_name().unwrap_or_default().to_string_lossy();
            name.starts_with("seed") && name.ends_with(".toml")
        })
        .collect();
    scenarios.sort();
    assert!(scenarios.len() >= 10, "{scenarios:?}");
    let work = tempfile::tempdir().expect("a scratch folder");
    for path in &scenarios {
        let run = |version| {
            let scenario = Scenario::from_file(path).expect("the scenario parses");
            let plan = Plan::with_version(scenario, &fmus, work.path(), version)
                .unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
            assert_eq!(plan.fmi_version(), version);
            plan.run(&RunOptions::default(), |_| {})
                .unwrap_or_else(|e| panic!("{} ({version:?}): {e:#}", path.display()))
        };
        let (fmi2, fmi3) = (run(FmiVersion::Fmi2), run(FmiVersion::Fmi3));
        // The scenario key chooses the same way.
        let mut scenario = Scenario::from_file(path).expect("the scenario parses");
        scenario.fmi_version = 3;
        let plan = Plan::new(scenario, &fmus, work.path()).expect("plans");
        assert_eq!(plan.fmi_version(), FmiVersion::Fmi3);
        assert_eq!(fmi2.columns, fmi3.columns);
        assert_eq!(fmi2.times, fmi3.times);
        for (name, (a, b)) in fmi2
            .columns
            .iter()
            .zip(fmi2.data.iter().zip(fmi3.data.iter()))
        {
            let differs = a
                .iter()
                .zip(b)
                .position(|(x, y)| x.to_bits() != y.to_bits());
            assert_eq!(
                differs,
                None,
                "{}: column {name} differs between FMI 2 and FMI 3",
                path.display()
            );
        }
        eprintln!(
            "{}: {} columns x {} rows bit-identical",
            path.file_name().unwrap_or_default().to_string_lossy(),
            fmi2.columns.len(),
            fmi2.times.len()
        );
    }
}
