//! Scores of an estimator against the truth: RMSE, largest absolute error, time-averaged NEES
//! (from the one-sigma outputs) and NIS, each average with its two-sided 95 % chi-square band.
//!
//! Consistency statistics (Bar-Shalom, Li, Kirubarajan, "Estimation with Applications to Tracking
//! and Navigation", ch. 5.4): for a consistent filter the normalised error squared
//! `e_k^2 / sigma_k^2` of one state is chi-square with 1 degree of freedom, the NIS of an update
//! with m rows is chi-square with m; the sum of K independent values is chi-square with the summed
//! degrees of freedom, which gives the band of the time average. Samples of one run are
//! correlated in time, so a single run's band is nominal; `montecarlo` averages over runs.

use crate::cosim::RunResult;
use crate::scenario::{Scenario, VarRef};

/// Lower and upper 95 % band of a time average.
pub type Band = (f64, f64);

#[derive(Debug, Clone, PartialEq)]
pub struct StateScore {
    pub label: String,
    /// Instance whose estimate this is.
    pub estimator: String,
    /// Unit of rmse and max_abs (the display unit when a display scale is given).
    pub unit: String,
    pub rmse: f64,
    pub max_abs: f64,
    /// Time-averaged NEES (1 degree of freedom) and its 95 % band, when a std output is given.
    pub nees: Option<(f64, Band)>,
    pub samples: usize,
    /// Samples where the estimate, truth or std was not finite (left out of the scores).
    pub non_finite: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct NisScore {
    pub estimator: String,
    /// Time-averaged NIS over the updates.
    pub mean_nis: f64,
    /// Mean degrees of freedom per update (rows used).
    pub mean_dof: f64,
    pub band: Band,
    pub updates: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct RunScores {
    pub states: Vec<StateScore>,
    pub nis: Vec<NisScore>,
    /// Mean wall time of one fmi2DoStep per instance [s].
    pub step_wall_time: Vec<(String, f64)>,
}

impl RunScores {
    pub fn state(&self, label: &str, estimator: &str) -> Option<&StateScore> {
        self.states
            .iter()
            .find(|s| s.label == label && s.estimator == estimator)
    }
}

/// Root mean square of `errors`.
pub fn rmse(errors: &[f64]) -> f64 {
    if errors.is_empty() {
        return f64::NAN;
    }
    (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt()
}

/// Largest absolute value.
pub fn max_abs(errors: &[f64]) -> f64 {
    errors.iter().fold(0.0, |m, e| m.max(e.abs()))
}

/// Natural log of the gamma function (Lanczos approximation, g = 7, n = 9; relative error below
/// 1e-13 for positive arguments).
pub fn ln_gamma(x: f64) -> f64 {
    const COEFFICIENTS: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut sum = COEFFICIENTS[0];
    for (i, c) in COEFFICIENTS.iter().enumerate().skip(1) {
        sum += c / (x + i as f64);
    }
    let t = x + 7.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

/// Regularised lower incomplete gamma function P(a, x): series for x < a + 1, continued fraction
/// (modified Lentz) otherwise.
pub fn regularized_gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let log_prefactor = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut n = a;
        for _ in 0..100_000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (sum.ln() + log_prefactor).exp().min(1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (1.0 - (h.ln() + log_prefactor).exp()).max(0.0)
    }
}

/// Chi-square cumulative distribution function with `dof` degrees of freedom.
pub fn chi_square_cdf(x: f64, dof: f64) -> f64 {
    regularized_gamma_p(0.5 * dof, 0.5 * x)
}

/// Quantile of the chi-square distribution (bisection on the CDF to 1e-12 relative).
pub fn chi_square_quantile(probability: f64, dof: f64) -> f64 {
    assert!(probability > 0.0 && probability < 1.0 && dof > 0.0);
    let mut low = 0.0;
    let mut high = dof.max(1.0);
    while chi_square_cdf(high, dof) < probability {
        high *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if chi_square_cdf(mid, dof) < probability {
            low = mid;
        } else {
            high = mid;
        }
        if high - low <= 1e-12 * high {
            break;
        }
    }
    0.5 * (low + high)
}

/// 95 % band of the average of `count` independent chi-square values whose degrees of freedom
/// sum to `total_dof`: [q(0.025), q(0.975)] of chi-square(total_dof), divided by `count`.
pub fn average_band(total_dof: f64, count: usize) -> Band {
    let n = count as f64;
    (
        chi_square_quantile(0.025, total_dof) / n,
        chi_square_quantile(0.975, total_dof) / n,
    )
}

/// Columns "inst.variable" of `result` matching the pattern `inst.variable` ('*' instance).
pub fn matching_columns(result: &RunResult, pattern: &str) -> Vec<(String, usize)> {
    let Some(r) = VarRef::parse(pattern) else {
        return Vec::new();
    };
    result
        .columns
        .iter()
        .enumerate()
        .filter_map(|(i, c)| {
            let cr = VarRef::parse(c)?;
            (cr.variable == r.variable && (r.instance == "*" || r.instance == cr.instance))
                .then_some((cr.instance, i))
        })
        .collect()
}

/// Score one state: errors `estimate - truth` over all samples where everything is finite.
pub fn score_state(
    label: &str,
    estimator: &str,
    unit: &str,
    truth: &[f64],
    estimate: &[f64],
    std: Option<&[f64]>,
    display_scale: f64,
) -> StateScore {
    let mut errors = Vec::with_capacity(truth.len());
    let mut nees_sum = 0.0;
    let mut nees_count = 0usize;
    let mut non_finite = 0usize;
    for k in 0..truth.len() {
        let e = estimate[k] - truth[k];
        let sigma = std.map(|s| s[k]);
        if !e.is_finite() || sigma.is_some_and(|s| !s.is_finite()) {
            non_finite += 1;
            continue;
        }
        errors.push(e * display_scale);
        if let Some(s) = sigma {
            if s > 0.0 {
                nees_sum += e * e / (s * s);
                nees_count += 1;
            }
        }
    }
    let nees = (std.is_some() && nees_count > 0).then(|| {
        (
            nees_sum / nees_count as f64,
            average_band(nees_count as f64, nees_count),
        )
    });
    StateScore {
        label: label.to_string(),
        estimator: estimator.to_string(),
        unit: unit.to_string(),
        rmse: rmse(&errors),
        max_abs: max_abs(&errors),
        nees,
        samples: errors.len(),
        non_finite,
    }
}

/// Time-averaged NIS. An estimator holds its outputs between its own samples, so consecutive
/// identical (NIS, dof) rows count as one update; rows with 0 degrees of freedom had no update.
pub fn score_nis(estimator: &str, nis: &[f64], dof: &[f64]) -> Option<NisScore> {
    let mut sum = 0.0;
    let mut dof_sum = 0.0;
    let mut updates = 0usize;
    let mut previous: Option<(f64, f64)> = None;
    for (&value, &d) in nis.iter().zip(dof) {
        let current = (value, d);
        if previous == Some(current) {
            continue;
        }
        previous = Some(current);
        if d > 0.0 && value.is_finite() {
            sum += value;
            dof_sum += d;
            updates += 1;
        }
    }
    (updates > 0).then(|| NisScore {
        estimator: estimator.to_string(),
        mean_nis: sum / updates as f64,
        mean_dof: dof_sum / updates as f64,
        band: average_band(dof_sum, updates),
        updates,
    })
}

/// Every score the scenario asks for, on one run's recording.
pub fn score_run(scenario: &Scenario, result: &RunResult) -> RunScores {
    let mut states = Vec::new();
    for section in &scenario.scores {
        let Some(truth) = result.column(&section.truth) else {
            continue;
        };
        let (scale, unit) = section.display();
        for (instance, column) in matching_columns(result, &section.estimate) {
            let std = section.std.as_ref().and_then(|pattern| {
                let variable = VarRef::parse(pattern)?.variable;
                result.column(&format!("{instance}.{variable}"))
            });
            states.push(score_state(
                &section.label,
                &instance,
                &unit,
                truth,
                &result.data[column],
                std,
                scale,
            ));
        }
    }
    let mut nis = Vec::new();
    for section in &scenario.nis {
        for (instance, column) in matching_columns(result, &section.nis) {
            let values = &result.data[column];
            let dof: Vec<f64> = match &section.dof {
                toml::Value::Integer(d) => vec![*d as f64; values.len()],
                toml::Value::String(pattern) => {
                    let Some(variable) = VarRef::parse(pattern).map(|r| r.variable) else {
                        continue;
                    };
                    match result.column(&format!("{instance}.{variable}")) {
                        Some(d) => d.to_vec(),
                        None => continue,
                    }
                }
                _ => continue,
            };
            if let Some(score) = score_nis(&instance, values, &dof) {
                nis.push(score);
            }
        }
    }
    RunScores {
        states,
        nis,
        step_wall_time: result.step_wall_time.clone(),
    }
}
