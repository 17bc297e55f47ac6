//! The Kalman filters on linear-Gaussian models, where the answer is known.

use crate::kalman_support;

use estimation::kalman::{
    ExtendedKalmanFilter, InitialEstimate, LinearKalmanFilter, SettingsError, SigmaPoints,
    UnscentedKalmanFilter,
};
use estimation::registry::{self, BoxedEstimator, EstimatorChoice, EstimatorSettings};
use estimation::{Estimator, FilterIssue};
use kalman_support::{simulate, three_state_model, LinearModel};
use nalgebra::{SMatrix, SVector, Vector1, Vector3};

/// Seed 004, exercise 1: `x(n+1) = 0.5 x(n) + u(n) + v(n)`, `y(n) = x(n) + w(n)`, `Q = R = 1`,
/// `P(0) = 10`.
fn exercise_one() -> LinearModel<1, 1, 1> {
    LinearModel {
        a: SMatrix::<f64, 1, 1>::new(0.5),
        b: SMatrix::<f64, 1, 1>::new(1.0),
        c: SMatrix::<f64, 1, 1>::new(1.0),
        d: SMatrix::<f64, 1, 1>::new(0.0),
        q: SMatrix::<f64, 1, 1>::new(1.0),
        r: SMatrix::<f64, 1, 1>::new(1.0),
    }
}

#[test]
fn seed_004_exercise_1_gain_sequence_and_stationary_gain() {
    // By hand: P⁻(n+1) = 0.25 P(n) + 1, K(n+1) = P⁻/(P⁻ + 1), P(n+1) = (1 - K) P⁻ = K (R = 1).
    //   P⁻(1) = 0.25·10 + 1 = 7/2            K(1) = (7/2)/(9/2)          = 7/9
    //   P⁻(2) = 0.25·7/9 + 1 = 43/36         K(2) = (43/36)/(79/36)      = 43/79
    //   P⁻(3) = 0.25·43/79 + 1 = 359/316     K(3) = (359/316)/(675/316)  = 359/675
    //   P⁻(4) = 0.25·359/675 + 1 = 3059/2700 K(4) = (3059/2700)/(5759/2700) = 3059/5759
    // Stationary: P⁻ = 0.25 P⁻/(P⁻ + 1) + 1  =>  P⁻² - P⁻/4 - 1 = 0  =>  P⁻ = (1 + √65)/8,
    //   K∞ = P⁻/(P⁻ + 1) = (1 + √65)/(9 + √65) ≈ 0.531129.
    let expected = [7.0 / 9.0, 43.0 / 79.0, 359.0 / 675.0, 3059.0 / 5759.0];
    let stationary = (1.0 + 65f64.sqrt()) / (9.0 + 65f64.sqrt());
    assert!((stationary - 0.531_129).abs() < 1e-6);

    let initial = InitialEstimate {
        state: Vector1::new(0.0),
        covariance: SMatrix::<f64, 1, 1>::new(10.0),
    };
    let mut filter = LinearKalmanFilter::new(
        exercise_one(),
        &Vector1::zeros(),
        &Vector1::zeros(),
        &initial,
    )
    .unwrap();
    let mut gains = Vec::new();
    for n in 0..60 {
        let u = Vector1::new(0.3 * n as f64);
        filter.predict(&u).unwrap();
        let prior = filter.state()[0];
        // Any measurement works: the gain is read off the correction it causes.
        let y = Vector1::new(prior + 1.0 + 0.1 * n as f64);
        let report = filter.update(&y, &u, &[true]).unwrap();
        let gain = (filter.state()[0] - prior) / (y[0] - prior);
        assert!((report.innovation[0] - (y[0] - prior)).abs() < 1e-12);
        // With R = 1, P(n) = K(n) R (000: 4.53).
        assert!((filter.covariance()[(0, 0)] - gain).abs() < 1e-12);
        gains.push(gain);
    }
    for (n, (k, e)) in gains.iter().zip(expected).enumerate() {
        assert!((k - e).abs() < 1e-14, "K({}) = {k}, expected {e}", n + 1);
    }
    assert!((gains.last().unwrap() - stationary).abs() < 1e-14);
}

fn initial3() -> InitialEstimate<3> {
    InitialEstimate {
        state: Vector3::new(0.5, -0.2, 0.1),
        covariance: SMatrix::<f64, 3, 3>::new(0.5, 0.1, 0.0, 0.1, 0.4, 0.05, 0.0, 0.05, 0.2),
    }
}

fn input(k: usize) -> SVector<f64, 1> {
    Vector1::new((0.05 * k as f64).sin() + if k > 100 { 0.5 } else { 0.0 })
}

/// The registry's settings for the three-state test model: the LKF about the origin, the given
/// sigma points for the scaled UKF, no observer design and no particle filter.
fn settings(scaled_sigma_points: SigmaPoints) -> EstimatorSettings<3, 1> {
    EstimatorSettings {
        operating_point: Ok((Vector3::zeros(), Vector1::zeros())),
        scaled_sigma_points,
        observer_design: Err(SettingsError("not needed".into())),
        particles: Err(SettingsError("not needed".into())),
    }
}

fn all_kinds() -> Vec<(&'static str, EstimatorChoice, EstimatorSettings<3, 1>)> {
    let symmetric = settings(SigmaPoints::Symmetric);
    vec![
        ("EKF", EstimatorChoice::Ekf, symmetric.clone()),
        ("UKF 2n", EstimatorChoice::Ukf, symmetric),
        (
            "UKF scaled",
            EstimatorChoice::UkfScaled,
            settings(SigmaPoints::scaled(0.5, 2.0, 0.0)),
        ),
        (
            "UKF scaled, kappa = 3 - n",
            EstimatorChoice::UkfScaled,
            settings(SigmaPoints::scaled(1.0, 2.0, 0.0)),
        ),
    ]
}

/// The registry's estimator `choice` on the three-state model from [`initial3`].
fn build(
    model: &LinearModel<3, 2, 1>,
    choice: EstimatorChoice,
    settings: &EstimatorSettings<3, 1>,
) -> BoxedEstimator<3, 2, 1> {
    registry::build(model.clone(), choice, settings, &initial3()).unwrap()
}

fn max_relative_difference<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    b: &SMatrix<f64, R, C>,
) -> f64 {
    (a - b).amax() / b.amax().max(1e-300)
}

#[test]
fn ekf_and_both_ukfs_equal_the_lkf_on_a_linear_gaussian_model() {
    let model = three_state_model();
    let truth = simulate(&model, Vector3::new(1.0, 0.0, 0.3), input, 400, 7);
    let mut reference = LinearKalmanFilter::new(
        model.clone(),
        &Vector3::new(0.2, 0.1, -0.1),
        &Vector1::new(0.7),
        &initial3(),
    )
    .unwrap();
    let mut others: Vec<_> = all_kinds()
        .into_iter()
        .map(|(name, choice, settings)| (name, build(&model, choice, &settings)))
        .collect();
    for k in 1..truth.inputs.len() {
        let u_prev = truth.inputs[k - 1];
        let u = truth.inputs[k];
        let mut y = truth.measurements[k];
        // Exercise the missing-data paths too: a masked row, and a NaN sensor value.
        let mut mask = [true, true];
        if k % 7 == 0 {
            mask[1] = false;
        }
        if k % 11 == 0 {
            y[0] = f64::NAN;
        }
        reference.predict(&u_prev).unwrap();
        let expected_report = reference.update(&y, &u, &mask).unwrap();
        for (name, filter) in others.iter_mut() {
            filter.predict(&u_prev).unwrap();
            let report = filter.update(&y, &u, &mask).unwrap();
            assert_eq!(report.used, expected_report.used, "{name} step {k}");
            assert!(
                max_relative_difference(filter.state(), reference.state()) < 1e-10,
                "{name} state at step {k}: {} vs {}",
                filter.state(),
                reference.state()
            );
            assert!(
                max_relative_difference(filter.covariance(), reference.covariance()) < 1e-10,
                "{name} covariance at step {k}"
            );
            assert!((report.nis - expected_report.nis).abs() < 1e-9 * expected_report.nis.max(1.0));
        }
    }
}

#[test]
fn a_skipped_row_is_the_update_with_the_other_row_alone() {
    // Masking row 1 of the 2-output model must give exactly the filter on a 1-output model.
    let model = three_state_model();
    let single = LinearModel::<3, 1, 1> {
        a: model.a,
        b: model.b,
        c: model.c.fixed_rows::<1>(0).into_owned(),
        d: model.d.fixed_rows::<1>(0).into_owned(),
        q: model.q,
        r: SMatrix::<f64, 1, 1>::new(model.r[(0, 0)]),
    };
    let truth = simulate(&model, Vector3::new(1.0, 0.0, 0.3), input, 50, 3);
    let mut two = ExtendedKalmanFilter::new(model.clone(), &initial3()).unwrap();
    let mut one = ExtendedKalmanFilter::new(single, &initial3()).unwrap();
    for k in 1..truth.inputs.len() {
        two.predict(&truth.inputs[k - 1]).unwrap();
        one.predict(&truth.inputs[k - 1]).unwrap();
        let y = truth.measurements[k];
        let report = two.update(&y, &truth.inputs[k], &[true, false]).unwrap();
        let single_report = one
            .update(&Vector1::new(y[0]), &truth.inputs[k], &[true])
            .unwrap();
        assert_eq!(report.rows_used, 1);
        assert_eq!(report.innovation[1], 0.0);
        assert!((report.nis - single_report.nis).abs() < 1e-12 * single_report.nis.max(1.0));
        assert!(max_relative_difference(two.state(), one.state()) < 1e-13);
        assert!(max_relative_difference(two.covariance(), one.covariance()) < 1e-13);
    }
}

#[test]
fn every_row_missing_leaves_the_estimate_unchanged() {
    let model = three_state_model();
    for (name, choice, settings) in all_kinds() {
        let mut filter = build(&model, choice, &settings);
        filter.predict(&Vector1::new(0.1)).unwrap();
        let (x, p) = (*filter.state(), *filter.covariance());
        let nan = SVector::<f64, 2>::new(f64::NAN, f64::INFINITY);
        let report = filter
            .update(&nan, &Vector1::new(0.1), &[true, true])
            .unwrap();
        assert_eq!(report.rows_used, 0, "{name}");
        assert_eq!(report.nis, 0.0);
        let report = filter
            .update(
                &SVector::<f64, 2>::new(1.0, 2.0),
                &Vector1::new(0.1),
                &[false, false],
            )
            .unwrap();
        assert_eq!(report.rows_used, 0, "{name}");
        assert_eq!(*filter.state(), x, "{name}");
        assert_eq!(*filter.covariance(), p, "{name}");
    }
}

#[test]
fn a_non_finite_input_never_yields_a_non_finite_estimate() {
    let model = three_state_model();
    let mut kinds = all_kinds();
    kinds.push((
        "LKF",
        EstimatorChoice::Lkf,
        settings(SigmaPoints::Symmetric),
    ));
    for (name, choice, settings) in kinds {
        let mut filter = build(&model, choice, &settings);
        let before = *filter.state();
        let issue = filter.predict(&Vector1::new(f64::NAN)).unwrap_err();
        assert_eq!(issue, FilterIssue::StateReset, "{name}");
        assert_eq!(*filter.state(), before, "{name}");
        assert!(filter.covariance().iter().all(|v| v.is_finite()), "{name}");
        // The filter keeps working afterwards.
        filter.predict(&Vector1::new(0.0)).unwrap();
        filter
            .update(
                &SVector::<f64, 2>::new(0.1, 0.2),
                &Vector1::new(0.0),
                &[true, true],
            )
            .unwrap();
        assert!(filter.state().iter().all(|v| v.is_finite()), "{name}");
    }
}

#[test]
fn a_covariance_that_lost_definiteness_is_repaired_and_reported() {
    // With a negative centre weight the scaled UKF's P⁻ can come out indefinite for a strongly
    // nonlinear model. Here (n = 2, alpha = 0.1, beta = -1, kappa = 0) the weights are
    // Wm0 = -99, Wc0 = -99.01, Wi = 25; the transition maps the centre to 0 and every outer point
    // to a = 0.02, so P⁻(0,0) = Wc0 (100a)² + 100 (99a)² = -1e4 a² < 0: not a covariance.
    #[derive(Clone)]
    struct Collapsing;
    impl estimation::StateSpaceModel<2, 1, 1> for Collapsing {
        fn state_names(&self) -> [&'static str; 2] {
            ["a", "b"]
        }
        fn measurement_names(&self) -> [&'static str; 1] {
            ["y"]
        }
        fn transition(&self, x: &SVector<f64, 2>, _: &SVector<f64, 1>) -> SVector<f64, 2> {
            // Quadratic in the deviation from the origin: the centre maps far from the others.
            SVector::<f64, 2>::new(x[0] * x[0] + x[1] * x[1], 0.0)
        }
        fn transition_jacobian(
            &self,
            x: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 2, 2> {
            SMatrix::<f64, 2, 2>::new(2.0 * x[0], 2.0 * x[1], 0.0, 0.0)
        }
        fn transition_input_jacobian(
            &self,
            _: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 2, 1> {
            SMatrix::zeros()
        }
        fn measurement(&self, x: &SVector<f64, 2>, _: &SVector<f64, 1>) -> SVector<f64, 1> {
            Vector1::new(x[0])
        }
        fn measurement_jacobian(
            &self,
            _: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 1, 2> {
            SMatrix::<f64, 1, 2>::new(1.0, 0.0)
        }
        fn measurement_input_jacobian(
            &self,
            _: &SVector<f64, 2>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 1, 1> {
            SMatrix::zeros()
        }
        fn process_noise(&self) -> SMatrix<f64, 2, 2> {
            SMatrix::identity() * 1e-12
        }
        fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
            SMatrix::<f64, 1, 1>::new(1.0)
        }
    }
    let initial = InitialEstimate {
        state: SVector::<f64, 2>::zeros(),
        covariance: SMatrix::identity(),
    };
    let mut filter =
        UnscentedKalmanFilter::new(Collapsing, SigmaPoints::scaled(0.1, -1.0, 0.0), &initial)
            .unwrap();
    let outcome = filter.predict(&Vector1::zeros());
    assert_eq!(outcome, Err(FilterIssue::CovarianceRepaired));
    let p = *filter.covariance();
    assert!(
        p.cholesky().is_some(),
        "repaired covariance must be positive definite: {p}"
    );
    assert_eq!(p, p.transpose());
    assert!(filter.state().iter().all(|v| v.is_finite()));
}

#[test]
fn settings_errors_name_the_setting() {
    let model = three_state_model();
    let bad_alpha = UnscentedKalmanFilter::new(
        model.clone(),
        SigmaPoints::scaled(0.0, 2.0, 0.0),
        &initial3(),
    );
    assert!(bad_alpha.unwrap_err().to_string().contains("alpha"));
    let mut bad_initial = initial3();
    bad_initial.covariance[(0, 0)] = -1.0;
    let err = ExtendedKalmanFilter::new(model.clone(), &bad_initial).unwrap_err();
    assert!(err.to_string().contains("initial covariance"), "{err}");
    let mut bad_q = model;
    bad_q.q[(1, 1)] = f64::NAN;
    let err = ExtendedKalmanFilter::new(bad_q, &initial3()).unwrap_err();
    assert!(err.to_string().contains("process noise"), "{err}");
}
