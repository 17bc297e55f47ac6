//! The scoring maths against independently known values.

use approx::assert_relative_eq;
use fmi_master::scoring::{
    average_band, chi_square_cdf, chi_square_quantile, ln_gamma, max_abs, rmse, score_nis,
    score_state,
};

#[test]
fn rmse_and_max_abs_of_a_known_sequence() {
    let e = [3.0, -4.0, 0.0, 0.0];
    assert_relative_eq!(rmse(&e), (25.0f64 / 4.0).sqrt(), max_relative = 1e-15);
    assert_eq!(max_abs(&e), 4.0);
    assert!(rmse(&[]).is_nan());
}

#[test]
fn ln_gamma_matches_factorials_and_sqrt_pi() {
    assert_relative_eq!(ln_gamma(1.0), 0.0, epsilon = 1e-13);
    assert_relative_eq!(ln_gamma(5.0), 24.0f64.ln(), max_relative = 1e-13);
    assert_relative_eq!(
        ln_gamma(0.5),
        std::f64::consts::PI.sqrt().ln(),
        max_relative = 1e-13
    );
    assert_relative_eq!(ln_gamma(101.0), 363.739_375_555_563_5, max_relative = 1e-13);
}

#[test]
fn chi_square_cdf_closed_forms() {
    // dof 2: F(x) = 1 - exp(-x/2).
    for x in [0.1, 1.0, 3.0, 10.0, 40.0] {
        assert_relative_eq!(
            chi_square_cdf(x, 2.0),
            1.0 - (-x / 2.0f64).exp(),
            max_relative = 1e-12
        );
    }
}

#[test]
fn chi_square_quantiles_match_tables() {
    // Values of scipy.stats.chi2.ppf.
    let cases = [
        (0.975, 1.0, 5.023_886_187_314_888),
        (0.025, 1.0, 0.000_982_069_117_175_255_5),
        (0.975, 4.0, 11.143_286_781_877_79),
        (0.025, 4.0, 0.484_418_557_087_929_9),
        (0.975, 10.0, 20.483_177_350_807_4),
        (0.025, 10.0, 3.246_972_780_236_86),
        (0.975, 1000.0, 1_089.530_912_774_913_5),
        (0.025, 1000.0, 914.257_153_799_259),
    ];
    for (p, dof, expected) in cases {
        assert_relative_eq!(chi_square_quantile(p, dof), expected, max_relative = 1e-8);
    }
}

#[test]
fn band_of_an_average_shrinks_towards_one() {
    let (lo, hi) = average_band(1000.0, 1000);
    assert!(lo < 1.0 && hi > 1.0 && hi - lo < 0.2, "{lo} {hi}");
    let (lo10, hi10) = average_band(10.0, 10);
    assert!(lo10 < lo && hi10 > hi);
}

#[test]
fn nees_of_errors_equal_to_their_sigma_is_one() {
    let truth = vec![1.0; 100];
    let estimate: Vec<f64> = (0..100)
        .map(|k| if k % 2 == 0 { 1.2 } else { 0.8 })
        .collect();
    let std = vec![0.2; 100];
    let s = score_state("x", "f", "m", &truth, &estimate, Some(&std), 1.0);
    let (nees, band) = s.nees.unwrap();
    assert_relative_eq!(nees, 1.0, max_relative = 1e-12);
    assert!(band.0 < 1.0 && band.1 > 1.0);
    assert_relative_eq!(s.rmse, 0.2, max_relative = 1e-12);
    assert_eq!(s.samples, 100);
}

#[test]
fn display_scale_applies_to_errors_not_to_nees() {
    let truth = [0.0, 0.0];
    let estimate = [0.01, -0.01];
    let std = [0.01, 0.01];
    let s = score_state(
        "beta",
        "f",
        "deg",
        &truth,
        &estimate,
        Some(&std),
        180.0 / std::f64::consts::PI,
    );
    assert_relative_eq!(s.rmse, 0.01f64.to_degrees(), max_relative = 1e-12);
    assert_relative_eq!(s.nees.unwrap().0, 1.0, max_relative = 1e-12);
}

#[test]
fn non_finite_samples_are_counted_and_left_out() {
    let s = score_state(
        "x",
        "f",
        "",
        &[0.0, 0.0, 0.0],
        &[1.0, f64::NAN, 1.0],
        None,
        1.0,
    );
    assert_eq!(s.samples, 2);
    assert_eq!(s.non_finite, 1);
    assert_eq!(s.rmse, 1.0);
    assert!(s.nees.is_none());
}

#[test]
fn nis_counts_held_outputs_once_and_skips_empty_updates() {
    // An estimator at 3x the communication step holds its outputs for three rows.
    let nis = [2.0, 2.0, 2.0, 6.0, 6.0, 6.0, 0.0, 0.0, 0.0];
    let dof = [2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 0.0, 0.0, 0.0];
    let s = score_nis("f", &nis, &dof).unwrap();
    assert_eq!(s.updates, 2);
    assert_relative_eq!(s.mean_nis, 4.0);
    assert_relative_eq!(s.mean_dof, 2.0);
    assert_relative_eq!(
        s.band.1,
        chi_square_quantile(0.975, 4.0) / 2.0,
        max_relative = 1e-12
    );
    assert!(score_nis("f", &[0.0], &[0.0]).is_none());
}
