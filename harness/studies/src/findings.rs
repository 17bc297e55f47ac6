//! The seeds' findings as data: one file per seed (`harness/studies/findings/seed000.toml`,
//! `seed001.toml`) lists for each finding what the seed says, the numbers measured on the demo's
//! runs (metrics), how they are reported, and the criterion that decides whether we agree.
//! This module loads those files, computes the metrics from the runs and renders one [`Finding`]
//! per entry (per case, for entries that repeat over scenarios).
//!
//! A file:
//!
//! ```toml
//! seed = "000"
//!
//! [[finding]]
//! experiment = "7.1 moderate ramp"
//! seed_says = "..."
//! measure = "vy RMSE LKF {lkf} m/s; ay over 10-12 s {ay} m/s²"  # {name}: a metric, formatted
//! criterion = "lkf > ekf and abs(ay - 3.7) < 0.3"               # see crate::expression
//! note = "..."
//! [finding.metrics]
//! lkf = { rmse = "vy", estimator = "LKF", scenario = "seed000_ramp_moderate_ay" }
//! ekf = { rmse = "vy", estimator = "EKF", scenario = "seed000_ramp_moderate_ay" }
//! ay = { mean = "vehicle.ay", from = 10.0, to = 12.0, scenario = "seed000_ramp_moderate_ay" }
//! ```
//!
//! Metrics: `rmse` (the scored RMSE of a state label for an estimator instance), `window_rmse`
//! (`truth`, `estimate` columns over `[from, to]`), `mean` (a column's mean over `[from, to]`),
//! `peak_abs` (a column's largest magnitude), `step_wall_time` (an instance's wall time per
//! doStep, s) and `value` (an expression of other metrics). A finding whose scenarios did not
//! run is left out. With `cases` (a list of tables of words, e.g. `{ scenario = "...", label =
//! "..." }`), `{word}` in any string is replaced per case; `each_case = "finding"` gives one
//! finding per case that ran, `each_case = "part"` one finding whose measure joins the cases'
//! (`part`, with "; ") and which agrees when every case's criterion holds.

use std::collections::{BTreeMap, BTreeSet};

use anyhow::{anyhow, bail, Context, Result};
use fmi_master::runner::RunOutput;
use serde::Deserialize;

use crate::expression::Expr;

/// One seed finding checked on our numbers.
#[derive(Debug, Clone)]
pub struct Finding {
    pub seed: String,
    pub experiment: String,
    pub seed_says: String,
    pub we_measure: String,
    pub agrees: bool,
    /// Why we differ (only shown when `agrees` is false), or a remark.
    pub note: String,
}

/// The shipped findings files, in report order.
pub const FINDINGS_FILES: [(&str, &str); 2] = [
    ("seed000.toml", include_str!("../findings/seed000.toml")),
    ("seed001.toml", include_str!("../findings/seed001.toml")),
];

/// A number as the report prints it.
pub fn fmt(x: f64) -> String {
    if x.is_nan() {
        "n/a".into()
    } else if x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e4) {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// One findings file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FindingsFile {
    pub seed: String,
    #[serde(rename = "finding")]
    pub findings: Vec<FindingSpec>,
}

/// One entry of a findings file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FindingSpec {
    pub experiment: String,
    pub seed_says: String,
    /// What we measured, `{metric}` replaced by its formatted value.
    pub measure: String,
    pub criterion: String,
    #[serde(default)]
    pub note: String,
    pub metrics: BTreeMap<String, Metric>,
    #[serde(default)]
    pub cases: Vec<BTreeMap<String, String>>,
    #[serde(default)]
    pub each_case: EachCase,
}

/// How an entry with `cases` becomes findings.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EachCase {
    /// One finding per case that ran.
    #[default]
    Finding,
    /// One finding of all cases that ran: `measure` of each joined with "; ", agreeing when
    /// every case's criterion holds.
    Part,
}

/// A number measured on the runs.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum Metric {
    /// The scored RMSE of state `rmse` for estimator instance `estimator`.
    Rmse {
        scenario: String,
        rmse: String,
        estimator: String,
    },
    /// RMSE of `estimate - truth` over `[from, to]`.
    WindowRmse {
        scenario: String,
        window_rmse: WindowColumns,
        from: f64,
        to: f64,
    },
    /// Mean of column `mean` over `[from, to]`.
    Mean {
        scenario: String,
        mean: String,
        from: f64,
        to: f64,
    },
    /// Largest |value| of column `peak_abs`.
    PeakAbs { scenario: String, peak_abs: String },
    /// Wall time per doStep of instance `step_wall_time`, s.
    StepWallTime {
        scenario: String,
        step_wall_time: String,
    },
    /// An expression of other metrics.
    Value { value: String },
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindowColumns {
    pub truth: String,
    pub estimate: String,
}

impl Metric {
    fn scenario(&self) -> Option<&str> {
        match self {
            Metric::Rmse { scenario, .. }
            | Metric::WindowRmse { scenario, .. }
            | Metric::Mean { scenario, .. }
            | Metric::PeakAbs { scenario, .. }
            | Metric::StepWallTime { scenario, .. } => Some(scenario),
            Metric::Value { .. } => None,
        }
    }

    /// The metric with `{word}` replaced from `case`.
    fn substituted(&self, case: &BTreeMap<String, String>) -> Metric {
        let s = |text: &String| substitute(text, case);
        match self {
            Metric::Rmse {
                scenario,
                rmse,
                estimator,
            } => Metric::Rmse {
                scenario: s(scenario),
                rmse: s(rmse),
                estimator: s(estimator),
            },
            Metric::WindowRmse {
                scenario,
                window_rmse,
                from,
                to,
            } => Metric::WindowRmse {
                scenario: s(scenario),
                window_rmse: WindowColumns {
                    truth: s(&window_rmse.truth),
                    estimate: s(&window_rmse.estimate),
                },
                from: *from,
                to: *to,
            },
            Metric::Mean {
                scenario,
                mean,
                from,
                to,
            } => Metric::Mean {
                scenario: s(scenario),
                mean: s(mean),
                from: *from,
                to: *to,
            },
            Metric::PeakAbs { scenario, peak_abs } => Metric::PeakAbs {
                scenario: s(scenario),
                peak_abs: s(peak_abs),
            },
            Metric::StepWallTime {
                scenario,
                step_wall_time,
            } => Metric::StepWallTime {
                scenario: s(scenario),
                step_wall_time: s(step_wall_time),
            },
            Metric::Value { value } => Metric::Value { value: s(value) },
        }
    }

    /// The metric on `output` (NaN where a column or score is missing, as the report shows it).
    fn measure(&self, output: &RunOutput) -> f64 {
        match self {
            Metric::Rmse {
                rmse, estimator, ..
            } => output
                .scores
                .state(rmse, estimator)
                .map_or(f64::NAN, |s| s.rmse),
            Metric::WindowRmse {
                window_rmse: columns,
                from,
                to,
                ..
            } => window_rmse(output, &columns.truth, &columns.estimate, *from, *to)
                .unwrap_or(f64::NAN),
            Metric::Mean { mean, from, to, .. } => {
                window_mean(output, mean, *from, *to).unwrap_or(f64::NAN)
            }
            Metric::PeakAbs { peak_abs, .. } => output
                .result
                .column(peak_abs)
                .map_or(f64::NAN, |v| v.iter().fold(0.0, |m, x| m.max(x.abs()))),
            Metric::StepWallTime { step_wall_time, .. } => output
                .scores
                .step_wall_time
                .iter()
                .find(|(n, _)| n == step_wall_time)
                .map_or(f64::NAN, |(_, s)| *s),
            Metric::Value { .. } => unreachable!("expressions are evaluated by Evaluation"),
        }
    }
}

/// RMSE of `estimate - truth` over t in [from, to].
pub fn window_rmse(
    output: &RunOutput,
    truth: &str,
    estimate: &str,
    from: f64,
    to: f64,
) -> Option<f64> {
    let r = &output.result;
    let truth = r.column(truth)?;
    let estimate = r.column(estimate)?;
    let mut sum = 0.0;
    let mut count = 0usize;
    for (k, &t) in r.times.iter().enumerate() {
        if t >= from - 1e-12 && t <= to + 1e-12 {
            let e = estimate[k] - truth[k];
            if e.is_finite() {
                sum += e * e;
                count += 1;
            }
        }
    }
    (count > 0).then(|| (sum / count as f64).sqrt())
}

/// Mean of a column over t in [from, to].
pub fn window_mean(output: &RunOutput, column: &str, from: f64, to: f64) -> Option<f64> {
    let r = &output.result;
    let values = r.column(column)?;
    let selected: Vec<f64> = r
        .times
        .iter()
        .zip(values)
        .filter(|(t, _)| **t >= from - 1e-12 && **t <= to + 1e-12)
        .map(|(_, v)| *v)
        .collect();
    (!selected.is_empty()).then(|| selected.iter().sum::<f64>() / selected.len() as f64)
}

/// `{word}` in `text` replaced by the case's value of `word` (other braces stay).
fn substitute(text: &str, case: &BTreeMap<String, String>) -> String {
    case.iter().fold(text.to_string(), |text, (word, value)| {
        text.replace(&format!("{{{word}}}"), value)
    })
}

/// The names `{name}` in a measure template.
fn placeholders(template: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = template;
    while let Some(start) = rest.find('{') {
        let Some(length) = rest[start..].find('}') else {
            break;
        };
        names.push(rest[start + 1..start + length].to_string());
        rest = &rest[start + length + 1..];
    }
    names
}

/// The metrics of one finding (one case) evaluated on the runs, each once.
struct Evaluation<'a> {
    metrics: BTreeMap<String, Metric>,
    outputs: &'a [(String, RunOutput)],
    values: BTreeMap<String, f64>,
    /// Names being evaluated, to report a metric defined through itself.
    pending: BTreeSet<String>,
}

impl<'a> Evaluation<'a> {
    /// None when a scenario the metrics read did not run.
    fn new(metrics: BTreeMap<String, Metric>, outputs: &'a [(String, RunOutput)]) -> Option<Self> {
        let ran = |scenario: &str| outputs.iter().any(|(n, _)| n == scenario);
        metrics
            .values()
            .filter_map(Metric::scenario)
            .all(ran)
            .then(|| Evaluation {
                metrics,
                outputs,
                values: BTreeMap::new(),
                pending: BTreeSet::new(),
            })
    }

    fn value(&mut self, name: &str) -> Result<f64> {
        if let Some(value) = self.values.get(name) {
            return Ok(*value);
        }
        let metric = self
            .metrics
            .get(name)
            .cloned()
            .ok_or_else(|| anyhow!("no metric {name:?}"))?;
        if !self.pending.insert(name.to_string()) {
            bail!("metric {name:?} is defined through itself");
        }
        let value = match &metric {
            Metric::Value { value } => Expr::parse(value)?.number(&mut |n| self.value(n))?,
            other => {
                let scenario = other.scenario().unwrap_or_default();
                let (_, output) = self
                    .outputs
                    .iter()
                    .find(|(n, _)| n == scenario)
                    .ok_or_else(|| anyhow!("scenario {scenario:?} did not run"))?;
                other.measure(output)
            }
        };
        self.pending.remove(name);
        self.values.insert(name.to_string(), value);
        Ok(value)
    }

    fn render(&mut self, template: &str) -> Result<String> {
        let mut text = template.to_string();
        for name in placeholders(template) {
            let value = self.value(&name)?;
            text = text.replacen(&format!("{{{name}}}"), &fmt(value), 1);
        }
        Ok(text)
    }

    fn criterion(&mut self, criterion: &str) -> Result<bool> {
        Expr::parse(criterion)?.truth(&mut |n| self.value(n))
    }
}

impl FindingSpec {
    /// The cases of this entry (one empty case when it has none).
    fn each_case(&self) -> Vec<BTreeMap<String, String>> {
        if self.cases.is_empty() {
            vec![BTreeMap::new()]
        } else {
            self.cases.clone()
        }
    }

    fn evaluation<'a>(
        &self,
        case: &BTreeMap<String, String>,
        outputs: &'a [(String, RunOutput)],
    ) -> Option<Evaluation<'a>> {
        let metrics = self
            .metrics
            .iter()
            .map(|(name, metric)| (name.clone(), metric.substituted(case)))
            .collect();
        Evaluation::new(metrics, outputs)
    }

    /// The findings of this entry on `outputs`.
    pub fn evaluate(&self, seed: &str, outputs: &[(String, RunOutput)]) -> Result<Vec<Finding>> {
        let finding = |case: &BTreeMap<String, String>, we_measure: String, agrees: bool| Finding {
            seed: seed.to_string(),
            experiment: substitute(&self.experiment, case),
            seed_says: substitute(&self.seed_says, case),
            we_measure,
            agrees,
            note: substitute(&self.note, case),
        };
        let mut findings = Vec::new();
        let (mut parts, mut all_agree) = (Vec::new(), true);
        for case in self.each_case() {
            let Some(mut evaluation) = self.evaluation(&case, outputs) else {
                continue;
            };
            let measured = evaluation.render(&substitute(&self.measure, &case))?;
            let agrees = evaluation.criterion(&substitute(&self.criterion, &case))?;
            match self.each_case {
                EachCase::Finding => findings.push(finding(&case, measured, agrees)),
                EachCase::Part => {
                    parts.push(measured);
                    all_agree &= agrees;
                }
            }
        }
        if !parts.is_empty() {
            findings.push(finding(&BTreeMap::new(), parts.join("; "), all_agree));
        }
        Ok(findings)
    }

    /// Checks, without runs, that every name the entry uses is a metric or a case word and
    /// that its expressions parse.
    fn check(&self) -> Result<()> {
        let words: BTreeSet<&String> = self.cases.iter().flat_map(|c| c.keys()).collect();
        let mut used = BTreeSet::new();
        Expr::parse(&self.criterion)?.names(&mut used);
        for metric in self.metrics.values() {
            if let Metric::Value { value } = metric {
                Expr::parse(value)?.names(&mut used);
            }
        }
        used.extend(placeholders(&self.measure));
        for name in used {
            if !self.metrics.contains_key(&name) && !words.contains(&name) {
                bail!("{name:?} is neither a metric nor a case word");
            }
        }
        Ok(())
    }
}

impl FindingsFile {
    /// Parses and checks a findings file; `name` is for messages.
    pub fn parse(name: &str, text: &str) -> Result<Self> {
        let file: FindingsFile =
            toml::from_str(text).with_context(|| format!("findings {name}"))?;
        for spec in &file.findings {
            spec.check()
                .with_context(|| format!("findings {name}, {:?}", spec.experiment))?;
        }
        Ok(file)
    }

    pub fn evaluate(&self, outputs: &[(String, RunOutput)]) -> Result<Vec<Finding>> {
        let mut findings = Vec::new();
        for spec in &self.findings {
            findings.extend(
                spec.evaluate(&self.seed, outputs)
                    .with_context(|| format!("finding {:?}", spec.experiment))?,
            );
        }
        Ok(findings)
    }
}

/// Every co-simulated seed finding, from the shipped files, on the runs (keyed by scenario name).
pub fn findings(outputs: &[(String, RunOutput)]) -> Result<Vec<Finding>> {
    let mut findings = Vec::new();
    for (name, text) in FINDINGS_FILES {
        findings.extend(FindingsFile::parse(name, text)?.evaluate(outputs)?);
    }
    Ok(findings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_files_parse_and_name_only_their_metrics() {
        for (name, text) in FINDINGS_FILES {
            let file = FindingsFile::parse(name, text).unwrap_or_else(|e| panic!("{e:#}"));
            assert!(!file.findings.is_empty(), "{name}");
        }
    }

    #[test]
    fn an_unknown_name_is_refused() {
        let text = r#"
seed = "000"
[[finding]]
experiment = "x"
seed_says = "y"
measure = "{a} and {b}"
criterion = "a > 1"
[finding.metrics]
a = { value = "2" }
"#;
        let error = format!("{:#}", FindingsFile::parse("test", text).unwrap_err());
        assert!(error.contains("\"b\" is neither a metric"), "{error}");
    }

    #[test]
    fn placeholders_and_substitution() {
        assert_eq!(placeholders("a {x} b {y_2}"), ["x", "y_2"]);
        let case = BTreeMap::from([("label".to_string(), "10 ms".to_string())]);
        assert_eq!(substitute("T = {label}: {e}", &case), "T = 10 ms: {e}");
    }
}
