//! The Luenberger observer on model A's linearisation about straight driving.

use crate::seed000_support;

use estimation::kalman::InitialEstimate;
use estimation::luenberger::{LuenbergerObserver, ObserverDesign};
use estimation::models::single_track::{seed_operating_point, SingleTrackEstimationModel};
use nalgebra::{Complex, DMatrix};
use seed000_support::{reference_run, rmse, run_filter, seed_initial_estimate};
use vehicle_models::manoeuvre::SeedManoeuvre;
use vehicle_models::single_track::state_index::{VX, VY};

fn observer(
    model: SingleTrackEstimationModel,
    design: &ObserverDesign,
    initial: &InitialEstimate<5>,
) -> LuenbergerObserver<SingleTrackEstimationModel, 5, 4, 3> {
    let (x0, u0) = seed_operating_point();
    LuenbergerObserver::new(model, &x0, &u0, design, initial).unwrap()
}

#[test]
fn default_design_places_the_eigenvalues_of_the_model_a_error_dynamics() {
    for t in [1e-3, 1e-2] {
        let model = SingleTrackEstimationModel::seed_000(t).unwrap();
        let design = model.default_observer_design();
        let o = observer(model, &design, &seed_initial_estimate());
        let e = o.error_dynamics();
        let mut actual: Vec<Complex<f64>> = DMatrix::from_iterator(5, 5, e.iter().copied())
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect();
        let mut expected = design.poles();
        let key =
            |a: &Complex<f64>, b: &Complex<f64>| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im));
        actual.sort_by(key);
        expected.sort_by(key);
        for (a, b) in actual.iter().zip(&expected) {
            assert!((a - b).norm() < 1e-9, "T = {t}: {actual:?} vs {expected:?}");
        }
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
    // The yaw-rate-driven lateral design, for comparison, is much worse at vy.
    let mut yaw_rate_design = design.clone();
    yaw_rate_design.blocks[0].output = 0;
    let yaw_rate_based = run_filter(
        &mut observer(model, &yaw_rate_design, &wrong_start),
        &reference,
    );
    assert!(rmse(&reference, &yaw_rate_based, VY, 1.0, 13.0) > 10.0 * vy);
}
