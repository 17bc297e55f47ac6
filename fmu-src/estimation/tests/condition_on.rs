//! A scalar pseudo-measurement (`RunningEstimator::condition_on`, the FMU's low-speed
//! kinematics): the Kalman update of one linear constraint known within a variance, on the
//! estimators that own their Gaussian; the others decline it and change nothing.

use crate::kalman_support::{three_state_model, three_state_settings};

use estimation::kalman::InitialEstimate;
use estimation::registry::{self, EstimatorChoice};
use nalgebra::{SMatrix, Vector3};

fn initial() -> InitialEstimate<3> {
    InitialEstimate {
        state: Vector3::new(0.2, -0.1, 0.4),
        covariance: SMatrix::<f64, 3, 3>::new(0.5, 0.1, 0.0, 0.1, 0.3, 0.05, 0.0, 0.05, 0.2),
    }
}

#[test]
fn the_gaussian_filters_take_a_pseudo_measurement_as_a_scalar_kalman_update() {
    let model = three_state_model();
    let h = Vector3::new(1.0, -2.0, 0.0);
    let (residual, variance) = (0.3, 0.04);
    let p = initial().covariance;
    // By hand: s = h P hᵀ + r, K = P hᵀ / s, x += K ν, P -= K s Kᵀ (equal to the Joseph form).
    let s = (h.transpose() * p * h)[(0, 0)] + variance;
    let gain = p * h / s;
    let state = initial().state + gain * residual;
    let covariance = p - gain * gain.transpose() * s;
    for choice in [
        EstimatorChoice::Lkf,
        EstimatorChoice::Ekf,
        EstimatorChoice::Ukf,
        EstimatorChoice::UkfScaled,
    ] {
        let mut filter =
            registry::build(model.clone(), choice, &three_state_settings(), &initial()).unwrap();
        assert!(filter.condition_on(&h, residual, variance), "{choice:?}");
        assert!((filter.state() - state).amax() < 1e-12, "{choice:?}");
        assert!(
            (filter.covariance() - covariance).amax() < 1e-12,
            "{choice:?}"
        );
    }
}

#[test]
fn a_pseudo_measurement_without_a_positive_variance_or_a_finite_residual_changes_nothing() {
    let model = three_state_model();
    let h = Vector3::new(1.0, 0.0, 0.0);
    let mut filter = registry::build(
        model,
        EstimatorChoice::Ekf,
        &three_state_settings(),
        &initial(),
    )
    .unwrap();
    for (residual, variance) in [(0.3, 0.0), (0.3, -1.0), (f64::NAN, 0.1), (0.3, f64::NAN)] {
        assert!(!filter.condition_on(&h, residual, variance));
        assert_eq!(*filter.state(), initial().state);
        assert_eq!(*filter.covariance(), initial().covariance);
    }
}

#[test]
fn the_observer_and_the_particle_filter_decline_a_pseudo_measurement() {
    let model = three_state_model();
    let h = Vector3::new(1.0, 0.0, 0.0);
    for choice in [EstimatorChoice::Luenberger, EstimatorChoice::ParticleFilter] {
        let mut filter =
            registry::build(model.clone(), choice, &three_state_settings(), &initial()).unwrap();
        let before = *filter.state();
        assert!(!filter.condition_on(&h, 0.3, 0.04), "{choice:?}");
        assert_eq!(*filter.state(), before, "{choice:?}");
    }
}
