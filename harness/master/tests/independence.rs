//! The master is general: it must not link any estimator, vehicle model or FMU crate of this
//! workspace (issue 11, point 1). Its manifest is read as TOML and every dependency table is
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

#[test]
fn the_master_depends_on_no_model_estimator_or_fmu_crate() {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let parsed: toml::Table = toml::from_str(&text).unwrap();
    let mut checked = 0;
    for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
        let Some(dependencies) = parsed.get(table).and_then(toml::Value::as_table) else {
            continue;
        };
        for (name, spec) in dependencies {
            checked += 1;
            let package = spec
                .get("package")
                .and_then(toml::Value::as_str)
                .unwrap_or(name);
            assert!(
                !FORBIDDEN.contains(&package),
                "{} lists `{package}` under [{table}]: the master must stay free of the \
                 workspace's models, estimators and FMU crates",
                manifest.display()
            );
            let path = spec.get("path").and_then(toml::Value::as_str);
            assert!(
                path.is_none() || ALLOWED_WORKSPACE_CRATES.contains(&package),
                "{} lists `{name}` by path ({path:?}) under [{table}]: the master takes no \
                 workspace crate",
                manifest.display()
            );
        }
    }
    assert!(
        checked >= 5,
        "found only {checked} dependencies in {}",
        manifest.display()
    );
}
