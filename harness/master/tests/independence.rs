//! The master is general: it must not link any estimator, vehicle model or FMU crate of this
//! workspace, so it runs any FMU. Its manifest is read as TOML and every dependency table is
//! checked against the workspace's own crates, so adding one makes this test fail.

use std::path::Path;

/// Every package of the workspace that is not part of the master itself.
const FORBIDDEN: [&str; 8] = [
    "estimation",
    "vehicle-models",
    "vehicle-state-estimator",
    "reference-vehicle",
    "fmi-export",
    "model-description",
    "packaging",
    "harness",
];

/// The workspace crates the master may take: the manoeuvre signals (no model, no FMI).
const ALLOWED_WORKSPACE_CRATES: [&str; 1] = ["manoeuvres"];

/// `[table] package` of every dependency the manifest must not have, and how many it has.
fn refused_dependencies(manifest: &str) -> (Vec<String>, usize) {
    let parsed: toml::Table = toml::from_str(manifest).unwrap();
    let mut refused = Vec::new();
    let mut count = 0;
    for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
        let Some(dependencies) = parsed.get(table).and_then(toml::Value::as_table) else {
            continue;
        };
        for (name, spec) in dependencies {
            count += 1;
            let package = spec
                .get("package")
                .and_then(toml::Value::as_str)
                .unwrap_or(name);
            let by_path = spec.get("path").is_some();
            if FORBIDDEN.contains(&package)
                || (by_path && !ALLOWED_WORKSPACE_CRATES.contains(&package))
            {
                refused.push(format!("[{table}] {package}"));
            }
        }
    }
    (refused, count)
}

#[test]
fn the_master_depends_on_no_model_estimator_or_fmu_crate() {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let (refused, count) = refused_dependencies(&std::fs::read_to_string(&manifest).unwrap());
    assert!(
        refused.is_empty(),
        "{} lists {refused:?}: the master must stay free of the workspace's models, estimators \
         and FMU crates",
        manifest.display()
    );
    assert!(
        count >= 5,
        "found only {count} dependencies in {}",
        manifest.display()
    );
}

#[test]
fn the_check_refuses_an_estimator_renamed_or_by_path() {
    let manifest = r#"
[dependencies]
serde = "1"
manoeuvres = { path = "../../fmu-src/manoeuvres" }
filters = { path = "../../fmu-src/estimation", package = "estimation" }
[dev-dependencies]
models = { path = "../../fmu-src/somewhere-else" }
"#;
    let (refused, count) = refused_dependencies(manifest);
    assert_eq!(count, 4);
    assert_eq!(
        refused,
        ["[dependencies] estimation", "[dev-dependencies] models"]
    );
}
