//! One update's extra measurement noise (`RunningEstimator::update_with_extra_noise`, the FMU's
//! `ay_model_error`): it is `R + extra` in that update, and only in that one.

use crate::kalman_support::{three_state_model, three_state_settings, LinearModel};

use estimation::kalman::InitialEstimate;
use estimation::registry::{self, BoxedEstimator, EstimatorChoice};
use estimation::Estimator;
use nalgebra::{SMatrix, Vector1, Vector2, Vector3};

/// The extra noise, of the size of `R`, on both rows (the Luenberger observer below has a gain
/// on the first row only, and its covariance sees the extra noise through that gain).
fn extra() -> SMatrix<f64, 2, 2> {
    SMatrix::<f64, 2, 2>::new(0.1, 0.0, 0.0, 0.25)
}

fn initial() -> InitialEstimate<3> {
    InitialEstimate {
        state: Vector3::new(0.2, -0.1, 0.4),
        covariance: SMatrix::<f64, 3, 3>::from_diagonal(&Vector3::new(0.5, 0.3, 0.2)),
    }
}

fn build(model: &LinearModel<3, 2, 1>, choice: EstimatorChoice) -> BoxedEstimator<3, 2, 1> {
    registry::build(model.clone(), choice, &three_state_settings(), &initial()).unwrap()
}

#[test]
fn the_ekf_innovation_variance_of_a_row_is_its_r_plus_the_extra_noise() {
    let model = three_state_model();
    let mut filter = build(&model, EstimatorChoice::Ekf);
    let u = Vector1::new(0.3);
    filter.predict(&u).unwrap();
    let prior = *filter.covariance();
    let y = model.c * filter.state() + model.d * u + Vector2::new(0.0, 0.7);
    // Only the second row: NIS = ν² / s with s = h P⁻ hᵀ + r + extra, computed here by hand.
    let report = filter
        .update_with_extra_noise(&y, &u, &[false, true], &extra())
        .unwrap();
    let h = model.c.row(1);
    let expected = (h * prior * h.transpose())[(0, 0)] + model.r[(1, 1)] + extra()[(1, 1)];
    let variance = report.innovation[1].powi(2) / report.nis;
    assert!(
        (variance - expected).abs() < 1e-12 * expected,
        "{variance} vs {expected}"
    );
    // Not vacuous: without the extra noise the variance is smaller by the extra noise.
    let without = expected - extra()[(1, 1)];
    assert!(expected > 1.5 * without);
}

#[test]
fn the_extra_noise_is_that_update_with_a_larger_r_and_leaves_r_as_it_was() {
    let model = three_state_model();
    let larger = LinearModel {
        r: model.r + extra(),
        ..model.clone()
    };
    let u = Vector1::new(0.3);
    let y = Vector2::new(0.5, 0.9);
    for &choice in EstimatorChoice::ALL {
        let mut tried = build(&model, choice);
        let mut reference = build(&larger, choice);
        tried.predict(&u).unwrap();
        reference.predict(&u).unwrap();
        let with = tried
            .update_with_extra_noise(&y, &u, &[true; 2], &extra())
            .unwrap();
        let expected = reference.update(&y, &u, &[true; 2]).unwrap();
        let name = choice.name();
        assert_eq!(with, expected, "{name}");
        assert_eq!(tried.state(), reference.state(), "{name}");
        assert_eq!(tried.covariance(), reference.covariance(), "{name}");
        // Not vacuous: the extra noise changed the covariance against the filter's own R.
        let mut own = build(&model, choice);
        own.predict(&u).unwrap();
        own.update(&y, &u, &[true; 2]).unwrap();
        assert_ne!(own.covariance(), tried.covariance(), "{name}");
        // The next update is with R again: as a filter without the extra noise, started from
        // where this one is (the particle filter's particles are not a Gaussian: skipped).
        if choice == EstimatorChoice::ParticleFilter {
            continue;
        }
        let here = InitialEstimate {
            state: *tried.state(),
            covariance: *tried.covariance(),
        };
        let mut fresh =
            registry::build(model.clone(), choice, &three_state_settings(), &here).unwrap();
        for filter in [&mut tried, &mut fresh] {
            filter.predict(&u).unwrap();
            filter.update(&y, &u, &[true; 2]).unwrap();
        }
        assert_eq!(tried.state(), fresh.state(), "{name}");
        assert_eq!(tried.covariance(), fresh.covariance(), "{name}");
    }
}

#[test]
fn zero_extra_noise_is_the_plain_update_bit_for_bit() {
    let model = three_state_model();
    let u = Vector1::new(-0.2);
    let y = Vector2::new(0.1, -0.4);
    for &choice in EstimatorChoice::ALL {
        let mut tried = build(&model, choice);
        let mut plain = build(&model, choice);
        for k in 0..5 {
            let y = y * f64::from(k);
            tried.predict(&u).unwrap();
            plain.predict(&u).unwrap();
            let with = tried.update_with_extra_noise(&y, &u, &[true; 2], &SMatrix::zeros());
            assert_eq!(with, plain.update(&y, &u, &[true; 2]), "{}", choice.name());
        }
        assert_eq!(tried.state(), plain.state(), "{}", choice.name());
        assert_eq!(tried.covariance(), plain.covariance(), "{}", choice.name());
    }
}
