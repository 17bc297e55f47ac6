//! The Luenberger observer on model A's linearisation about straight driving.

use crate::seed000_support;

use estimation::kalman::InitialEstimate;
use estimation::luenberger::{DesignBlock, LuenbergerObserver, ObserverDesign};
use estimation::models::single_track::{seed_operating_point, SingleTrackEstimationModel};
use nalgebra::{Complex, DMatrix};
use seed000_support::{reference_run, rmse, run_filter, seed_initial_estimate};
use vehicle_models::manoeuvre::SeedManoeuvre;
use vehicle_models::single_track::measurement_index::{
    LATERAL_ACCELERATION, YAW_RATE as YAW_RATE_ROW,
};
use vehicle_models::single_track::state_index::{OMEGA_FRONT, OMEGA_REAR, VX, VY, YAW_RATE};

fn observer(
    model: SingleTrackEstimationModel,
    design: &ObserverDesign,
    initial: &InitialEstimate<5>,
) -> LuenbergerObserver<SingleTrackEstimationModel, 5, 4, 3> {
    let (x0, u0) = seed_operating_point();
    LuenbergerObserver::new(model, &x0, &u0, design, initial).unwrap()
}

/// Both lateral states in one block observed through `lateral_output` (through `ay`, the design
/// before the gyro drove the yaw rate), poles `-40 ± 10i 1/s`, and the default's longitudinal
/// block. About straight driving its blocks decouple, so its poles are placed exactly.
fn lateral_block_design(
    model: &SingleTrackEstimationModel,
    lateral_output: usize,
) -> ObserverDesign {
    let mut design = model.default_observer_design();
    let t = model.sample_time();
    let z = |re: f64, im: f64| (Complex::new(re, im) * t).exp();
    design.blocks.splice(
        0..2,
        [DesignBlock {
            states: vec![VY, YAW_RATE],
            output: lateral_output,
            poles: vec![z(-40.0, 10.0), z(-40.0, -10.0)],
        }],
    );
    design
}

fn eigenvalues(matrix: &nalgebra::SMatrix<f64, 5, 5>) -> Vec<Complex<f64>> {
    let key =
        |a: &Complex<f64>, b: &Complex<f64>| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im));
    let mut values: Vec<Complex<f64>> = DMatrix::from_iterator(5, 5, matrix.iter().copied())
        .complex_eigenvalues()
        .iter()
        .copied()
        .collect();
    values.sort_by(key);
    values
}

#[test]
fn a_decoupled_design_places_the_eigenvalues_of_the_model_a_error_dynamics() {
    for t in [1e-3, 1e-2] {
        let model = SingleTrackEstimationModel::seed_000(t).unwrap();
        let design = lateral_block_design(&model, LATERAL_ACCELERATION);
        let o = observer(model, &design, &seed_initial_estimate());
        let actual = eigenvalues(&o.error_dynamics());
        let mut expected = design.poles();
        expected.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        for (a, b) in actual.iter().zip(&expected) {
            assert!((a - b).norm() < 1e-9, "T = {t}: {actual:?} vs {expected:?}");
        }
    }
}

#[test]
fn the_default_design_is_stable_where_its_lateral_blocks_couple() {
    for t in [1e-3, 1e-2] {
        let model = SingleTrackEstimationModel::seed_000(t).unwrap();
        let design = model.default_observer_design();
        let slowest = design.poles().iter().fold(0.0f64, |m, z| m.max(z.norm()));
        let o = observer(model, &design, &seed_initial_estimate());
        // vy and r are coupled through the tyres, so the one-state blocks' poles move; the
        // error map stays at least as fast as the slowest placed pole.
        let actual = eigenvalues(&o.error_dynamics());
        let radius = actual.iter().fold(0.0f64, |m, z| m.max(z.norm()));
        assert!(radius <= slowest * (1.0 + 1e-9), "T = {t}: {actual:?}");
        // Some eigenvalue is none of the placed poles: the coupling moved it.
        let placed: Vec<Complex<f64>> = design.poles();
        assert!(
            actual
                .iter()
                .any(|a| placed.iter().all(|p| (a - p).norm() > 1e-6)),
            "T = {t}: the coupling should move some pole: {actual:?} vs {placed:?}"
        );
    }
}

#[test]
fn observer_tracks_model_a_in_the_linear_range_and_converges_from_a_wrong_start() {
    let t = 1e-2;
    let reference = reference_run(SeedManoeuvre::ModerateRamp, t, 5);
    let model = SingleTrackEstimationModel::seed_000(t).unwrap();
    let design = model.default_observer_design();
    let mut wrong_start = seed_initial_estimate();
    wrong_start.state[VX] += 1.0;
    wrong_start.state[VY] += 0.3;
    let estimates = run_filter(
        &mut observer(model.clone(), &design, &wrong_start),
        &reference,
    );
    // After the transient (slowest pole -30 1/s: e^-30 per second), tracking in the linear range.
    let vy = rmse(&reference, &estimates, VY, 1.0, 13.0);
    let vx = rmse(&reference, &estimates, VX, 1.0, 13.0);
    println!("moderate ramp, Luenberger: vy RMSE {vy:.3e} m/s, vx RMSE {vx:.3e} m/s");
    assert!(vy < 5e-3, "vy RMSE {vy}");
    assert!(vx < 2e-2, "vx RMSE {vx}");
    // Both lateral states through the yaw rate, for comparison, is much worse at vy.
    let yaw_rate_design = lateral_block_design(&model, YAW_RATE_ROW);
    let yaw_rate_based = run_filter(
        &mut observer(model, &yaw_rate_design, &wrong_start),
        &reference,
    );
    let yaw_rate_vy = rmse(&reference, &yaw_rate_based, VY, 1.0, 13.0);
    println!("moderate ramp, Luenberger with (vy, r) through the yaw rate: vy RMSE {yaw_rate_vy:.3e} m/s");
    assert!(yaw_rate_vy > 10.0 * vy);
}

/// The default design starts at any speed the FMU may start at, from walking pace (where model
/// A's discretised lateral dynamics are themselves unstable) to 80 m/s, and its error map is no
/// slower than its slowest placed pole there.
#[test]
fn the_default_design_starts_from_walking_pace_to_80_metres_per_second() {
    for t in [1e-3, 1e-2, 2e-2] {
        let model = SingleTrackEstimationModel::seed_000(t).unwrap();
        let design = model.default_observer_design();
        let slowest = design.poles().iter().fold(0.0f64, |m, z| m.max(z.norm()));
        let (mut operating, input) = seed_operating_point();
        let radius = model.vehicle().vehicle.chassis.front_wheel_radius;
        for speed in [0.3, 1.0, 2.0, 5.0, 20.0, 40.0, 80.0] {
            operating[VX] = speed;
            operating[OMEGA_FRONT] = speed / radius;
            operating[OMEGA_REAR] = speed / radius;
            let o = LuenbergerObserver::new(
                model.clone(),
                &operating,
                &input,
                &design,
                &seed_initial_estimate(),
            )
            .unwrap_or_else(|e| panic!("T = {t}, {speed} m/s: {}", e.0));
            let eigenvalues = eigenvalues(&o.error_dynamics());
            let largest = eigenvalues.iter().fold(0.0f64, |m, z| m.max(z.norm()));
            assert!(
                largest <= slowest * (1.0 + 1e-9),
                "T = {t}, {speed} m/s: {eigenvalues:?}"
            );
        }
    }
}
