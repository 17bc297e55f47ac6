//! Model mismatch (issue 6, point 5): model A's cornering-stiffness scales identified by EM
//! from a model-B ReferenceVehicle run (a wobble at 80 km/h), scored with the EKF and UKF on
//! held-out manoeuvres (the seed-001 40° step steer and ISO 3888-1 double lane change at 65 km/h),
//! all through the FMUs.
//!
//! Needs the packaged FMUs (`cargo run --release -p packaging`) in
//! `fmi_master::runner::default_fmu_dir()`; a missing archive fails the test with that command.

use fmi_master::runner::default_fmu_dir;
use harness::mismatch::run_shipped;

#[test]
fn identified_scales_are_scored_on_held_out_manoeuvres() {
    let fmu_dir = default_fmu_dir();
    for archive in ["ReferenceVehicle.fmu", "VehicleStateEstimator.fmu"] {
        assert!(
            fmu_dir.join(archive).is_file(),
            "{} missing: build the FMUs with `cargo run --release -p packaging`",
            fmu_dir.join(archive).display()
        );
    }
    let out = std::env::temp_dir().join(format!("harness-mismatch-{}", std::process::id()));
    let report = run_shipped(&fmu_dir, &out).expect("mismatch study");
    let _ = std::fs::remove_dir_all(&out);
    eprintln!("{}", report.summary());

    // Since the reference vehicle's feed-through fix (issue 17 point 1, 20cc07b) the data no
    // longer carry an ay sample of the previous steering input, and the EM with the study's 100
    // particles stops unconverged near k_F 0.79, k_R 0.85 (mismatch.rs, `identification_config`,
    // records why); the demo's finding reads "no". What must hold whatever the EM finds: it moves
    // both scales below 1 (model B's load transfer softens both axles against model A's linear
    // tyre), the front the more, and every held-out run is scored with finite errors.
    let identification = &report.identification;
    let [front, rear] = [identification.parameters[0], identification.parameters[1]];
    assert!((0.7..0.97).contains(&front), "k_F = {front}");
    assert!((0.75..1.1).contains(&rear), "k_R = {rear}");
    assert!(front < rear, "k_F = {front}, k_R = {rear}");
    assert!(identification.iterations.len() > 1, "EM made no step");

    // Both held-out manoeuvres, both filters. With the seed's tyre (scales 1) model A's EKF and
    // UKF stay within a fraction of a degree of model B's sideslip (measured 0.113 deg on the
    // step steer, 0.023 deg on the lane change).
    assert_eq!(report.validation.len(), 4, "{:?}", report.validation);
    for row in &report.validation {
        assert!(
            row.sideslip_rmse_seed.to_degrees() < 0.2 && row.sideslip_rmse_identified.is_finite(),
            "{} {}: sideslip RMSE {:.4} deg with scales 1, {:.4} deg identified",
            row.scenario,
            row.estimator,
            row.sideslip_rmse_seed.to_degrees(),
            row.sideslip_rmse_identified.to_degrees()
        );
    }
}
