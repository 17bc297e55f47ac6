//! The findings of seed 000, chapter 7, at library level (no FMI): truth from model A with the
//! noise of SPEC §7, estimators from this crate.

use crate::seed000_support;

use estimation::kalman::{
    ExtendedKalmanFilter, LinearKalmanFilter, SigmaPoints, UnscentedKalmanFilter,
};
use estimation::models::single_track::{seed_operating_point, SingleTrackEstimationModel};
use estimation::registry::{self, EstimatorChoice};
use seed000_support::{reference_run, rmse, run_filter, seed_initial_estimate};
use vehicle_models::manoeuvre::{SeedManoeuvre, SEED_MANOEUVRE_DURATION};
use vehicle_models::single_track::state_index::{VX, VY};

const SEED: u64 = 2026;

fn lkf(sample_time: f64) -> LinearKalmanFilter<SingleTrackEstimationModel, 5, 4, 3> {
    let (x0, u0) = seed_operating_point();
    LinearKalmanFilter::new(
        SingleTrackEstimationModel::seed_000(sample_time).unwrap(),
        &x0,
        &u0,
        &seed_initial_estimate(),
    )
    .unwrap()
}

fn ekf(sample_time: f64) -> ExtendedKalmanFilter<SingleTrackEstimationModel, 5, 4, 3> {
    ExtendedKalmanFilter::new(
        SingleTrackEstimationModel::seed_000(sample_time).unwrap(),
        &seed_initial_estimate(),
    )
    .unwrap()
}

fn ukf(sample_time: f64) -> UnscentedKalmanFilter<SingleTrackEstimationModel, 5, 4, 3> {
    UnscentedKalmanFilter::new(
        SingleTrackEstimationModel::seed_000(sample_time).unwrap(),
        SigmaPoints::Symmetric,
        &seed_initial_estimate(),
    )
    .unwrap()
}

#[test]
fn high_ay_ramp_lkf_is_far_off_in_vy_while_ekf_and_ukf_agree() {
    let t = 1e-3;
    let reference = reference_run(SeedManoeuvre::HighRamp, t, SEED);
    let lkf_estimates = run_filter(&mut lkf(t), &reference);
    let ekf_estimates = run_filter(&mut ekf(t), &reference);
    let ukf_estimates = run_filter(&mut ukf(t), &reference);
    let end = SEED_MANOEUVRE_DURATION + 1.0;
    let lkf_vy = rmse(&reference, &lkf_estimates, VY, 0.0, end);
    let ekf_vy = rmse(&reference, &ekf_estimates, VY, 0.0, end);
    let ukf_vy = rmse(&reference, &ukf_estimates, VY, 0.0, end);
    let ekf_ukf_difference = (ekf_estimates
        .iter()
        .zip(&ukf_estimates)
        .map(|(e, u)| (e[VY] - u[VY]).powi(2))
        .sum::<f64>()
        / ekf_estimates.len() as f64)
        .sqrt();
    println!(
        "high ramp, T = 1 ms: vy RMSE LKF {lkf_vy:.3e}, EKF {ekf_vy:.3e}, UKF {ukf_vy:.3e}, \
         RMS(EKF - UKF) {ekf_ukf_difference:.3e} m/s"
    );
    // 000 ch. 7.2: "LKF far off in vy; EKF ≈ UKF ≈ truth".
    assert!(lkf_vy >= 100.0 * ekf_vy, "LKF {lkf_vy} vs EKF {ekf_vy}");
    // EKF and UKF agree closely: their difference is small against their own error.
    assert!(ekf_ukf_difference < 0.1 * ekf_vy.max(ukf_vy));
    assert!((ekf_vy - ukf_vy).abs() < 0.1 * ekf_vy);
}

#[test]
fn lkf_error_grows_once_braking_starts() {
    let t = 1e-3;
    let braking = reference_run(SeedManoeuvre::HighRampBraking, t, SEED);
    let lkf_estimates = run_filter(&mut lkf(t), &braking);
    let ekf_estimates = run_filter(&mut ekf(t), &braking);
    // Same manoeuvre without braking, same noise sequence: before 9 s both runs are identical.
    let no_braking = reference_run(SeedManoeuvre::HighRamp, t, SEED);
    let lkf_no_braking = run_filter(&mut lkf(t), &no_braking);
    let end = SEED_MANOEUVRE_DURATION + 1.0;
    for (name, index) in [("vx", VX), ("vy", VY)] {
        let before = rmse(&braking, &lkf_estimates, index, 6.0, 9.0);
        let after = rmse(&braking, &lkf_estimates, index, 9.0, end);
        let after_without = rmse(&no_braking, &lkf_no_braking, index, 9.0, end);
        let ekf_after = rmse(&braking, &ekf_estimates, index, 9.0, end);
        println!(
            "braking, LKF {name} RMSE 6-9 s {before:.3e}, 9-12 s {after:.3e} (without braking {after_without:.3e}); EKF 9-12 s {ekf_after:.3e}"
        );
    }
    // 000 §7.2.1: compared with the same ramp without braking (fig. 7.12 vs 7.8), the LKF
    // deviates more from about 9 s on, in vy and in the longitudinal quantities. The EKF stays
    // close to the truth.
    let vy_after = rmse(&braking, &lkf_estimates, VY, 9.0, end);
    let vy_after_without = rmse(&no_braking, &lkf_no_braking, VY, 9.0, end);
    assert!(
        vy_after > 1.3 * vy_after_without,
        "{vy_after} vs {vy_after_without}"
    );
    let vx_after = rmse(&braking, &lkf_estimates, VX, 9.0, end);
    let vx_after_without = rmse(&no_braking, &lkf_no_braking, VX, 9.0, end);
    assert!(
        vx_after > 5.0 * vx_after_without,
        "{vx_after} vs {vx_after_without}"
    );
    assert!(rmse(&braking, &ekf_estimates, VY, 9.0, end) < 0.01 * vy_after);
}

#[test]
fn every_estimator_kind_runs_on_model_a_without_issues() {
    // Every estimator of the registry but the particle filter (tests/particle_filter.rs), at
    // 10 ms, on the braking manoeuvre.
    let t = 1e-2;
    let reference = reference_run(SeedManoeuvre::HighRampBraking, t, SEED);
    let model = SingleTrackEstimationModel::seed_000(t).unwrap();
    let settings = model.seed_settings();
    for &choice in EstimatorChoice::ALL {
        if choice == EstimatorChoice::ParticleFilter {
            continue;
        }
        let name = choice.name();
        let mut filter =
            registry::build(model.clone(), choice, &settings, &seed_initial_estimate()).unwrap();
        let estimates = run_filter(&mut filter, &reference);
        assert!(
            estimates.iter().all(|x| x.iter().all(|v| v.is_finite())),
            "{name}"
        );
        let vx = rmse(&reference, &estimates, VX, 0.0, 13.0);
        println!(
            "{name}: vx RMSE {vx:.3e}, vy RMSE {:.3e}",
            rmse(&reference, &estimates, VY, 0.0, 13.0)
        );
    }
}
