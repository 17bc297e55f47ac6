//! Model mismatch: model A's cornering-stiffness scales identified by EM
//! from a model-B ReferenceVehicle run (a wobble at 80 km/h), scored with the EKF and UKF on
//! held-out manoeuvres (the seed-001 40° step steer and ISO 3888-1 double lane change at 65 km/h),
//! all through the FMUs.
//!
//! The whole pipeline of `run_mismatch` runs here with the shipped study's data, particles and
//! scenarios, but the EM stops after [`EM_CYCLES`] SQUAREM cycles instead of the shipped 20: the
//! EM is nearly all of the study's time (about 50 s of it for 20 cycles on a 2-core machine),
//! and its path is deterministic (fixed random numbers, `fresh_random_numbers: false`), so the
//! shortened run is exactly the first cycles of the shipped one. The shipped study itself, all
//! 20 cycles, runs once per test run in `harness demo`, and tests/harness/test_demo.py asserts
//! the same bounds on its result, so the full EM runs once, not twice.
//!
//! Needs the packaged FMUs (`cargo run --release -p packaging`) in
//! `fmi_master::runner::default_fmu_dir()`; a missing archive fails the test with that command.

use fmi_master::runner::{packaged_fmu_dir, Environment};
use harness::mismatch::{run_mismatch, MismatchStudy};

use crate::scratch::Scratch;

/// SQUAREM cycles of the shortened EM (3 E-steps each; the shipped study allows 20). Measured
/// path of the shipped study (cycle: k_F, k_R): 1: 0.936, 1.033; 2: 0.904, 1.005; 3: 0.893,
/// 0.991; 4: 0.885, 0.980; ... 20: 0.792, 0.845. After 4 cycles every bound below holds with a
/// margin of at least 0.08.
const EM_CYCLES: usize = 4;

#[test]
fn identified_scales_are_scored_on_held_out_manoeuvres() {
    let fmu_dir = packaged_fmu_dir().expect("packaged FMUs");
    let out = Scratch::new("mismatch");
    let mut study = MismatchStudy::shipped();
    study.identification.max_cycles = EM_CYCLES;
    let report = run_mismatch(
        &study,
        &Environment {
            fmu_dir,
            out_dir: out.0.clone(),
        },
    )
    .expect("mismatch study");
    eprintln!("{}", report.summary());

    // The reference vehicle's sensors feed its inputs through in the same step, so the data carry
    // no ay sample of the previous steering input, and the EM with the study's 100
    // particles stops unconverged near k_F 0.79, k_R 0.85 (mismatch.rs, `identification_config`,
    // records why); the demo's finding reads "no". What must hold whatever the EM finds: it moves
    // both scales below 1 (model B's load transfer softens both axles against model A's linear
    // tyre), the front the more, and every held-out run is scored with finite errors.
    // Each bound fails if the EM does not move k_F from its start 1 (front), moves it far past
    // the shipped result (both lower bounds), or softens the rear as much as the front.
    let identification = &report.identification;
    let [front, rear] = [identification.parameters[0], identification.parameters[1]];
    assert!((0.7..0.97).contains(&front), "k_F = {front}");
    assert!((0.75..1.1).contains(&rear), "k_R = {rear}");
    assert!(front < rear, "k_F = {front}, k_R = {rear}");
    assert!(identification.iterations.len() > 1, "EM made no step");

    // Both held-out manoeuvres, both filters. With the seed's tyre (scales 1) model A's EKF and
    // UKF stay within a fraction of a degree of model B's sideslip (measured 0.113 deg on the
    // step steer, 0.023 deg on the lane change); with the identified scales set on the FMUs the
    // runs are scored too (finite errors).
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
