//! A recording handed back with `Plan::recycle` is reused by the next run: the runs that reuse
//! it must give exactly the values of runs on fresh memory (every cell is written again), also
//! when the next run records a different seed.
//!
//! Needs the packaged FMUs (`cargo run --release -p packaging`) in
//! `fmi_master::runner::default_fmu_dir()`.

use std::path::Path;

use fmi_master::cosim::{ParameterValue, Plan, RunOptions, RunResult};
use fmi_master::runner::scenario_dir;
use fmi_master::runner::Environment;
use fmi_master::scenario::{Scenario, VarRef};

use crate::common::Scratch;

/// The plan of `stop_time` seconds, its FMUs extracted below `out_dir`.
fn plan(stop_time: f64, out_dir: &Path) -> Plan {
    let fmu_dir = crate::common::packaged_fmus();
    let env = Environment {
        fmu_dir,
        out_dir: out_dir.to_path_buf(),
    };
    let mut scenario =
        Scenario::from_file(&scenario_dir().join("seed000_ramp_high_ay.toml")).expect("scenario");
    let keep = ["vehicle", "UKF"];
    scenario.fmus.retain(|f| keep.contains(&f.name.as_str()));
    scenario
        .connections
        .retain(|c| keep.contains(&c.from.as_str()) && keep.contains(&c.to.as_str()));
    scenario.stop_time = Some(stop_time);
    Plan::new(scenario, &env.fmu_dir, &env.work_dir()).expect("plan")
}

fn seeded(seed: i32) -> RunOptions {
    RunOptions {
        overrides: vec![(
            VarRef::parse("vehicle.seed").expect("reference"),
            ParameterValue::Integer(seed),
        )],
        ..RunOptions::default()
    }
}

fn assert_same(a: &RunResult, b: &RunResult, what: &str) {
    assert_eq!(a.columns, b.columns, "{what}");
    assert_eq!(a.data.len(), b.data.len(), "{what}");
    assert_eq!(a.data.rows(), b.data.rows(), "{what}");
    for ((name, x), y) in a.columns.iter().zip(&a.data).zip(&b.data) {
        let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(x), bits(y), "{what}: column {name}");
    }
}

#[test]
fn recycled_recordings_give_the_values_of_fresh_ones() {
    let scratch = Scratch::new("recycle");
    let long = plan(2.0, &scratch.0.join("long"));
    let fresh = |plan: &Plan, seed| plan.run(&seeded(seed), |_| {}).expect("run");

    let first = fresh(&long, 1);
    let first_again = first.clone();
    long.recycle(first);
    // Another seed into the recycled block: nothing of seed 1 may remain.
    let second = fresh(&long, 2);
    assert_same(
        &second,
        &fresh(&plan(2.0, &scratch.0.join("check")), 2),
        "seed 2 after seed 1",
    );
    long.recycle(second);
    assert_same(&fresh(&long, 1), &first_again, "seed 1 again");
}
