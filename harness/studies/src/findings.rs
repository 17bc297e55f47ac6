//! The seeds' findings as data: one file per seed (`harness/studies/findings/seed000.toml`,
//! `seed001.toml`, `seed003.toml`, and `mismatch.toml` beyond the seeds) lists for each finding
//! what the seed says, the numbers measured (metrics), how they are reported, and the criterion
//! that decides whether we agree. This module loads those files, computes the metrics from the
//! co-simulated runs and the offline studies ([`Sources`]) and renders one [`Finding`] per entry
//! (per case, for entries that repeat over scenarios, parameters or study rows).
//!
//! A file:
//!
//! ```toml
//! seed = "000"
//!
//! [[finding]]
//! experiment = "7.1 moderate ramp"
//! seed_says = "..."
//! measure = "vy RMSE LKF {lkf} m/s; ay over 10-12 s {ay:.2} m/s²"  # {name}: a metric, formatted
//! criterion = "lkf > ekf and abs(ay - 3.7) < 0.3"                 # see crate::expression
//! note = "..."
//! [finding.metrics]
//! lkf = { rmse = "vy", estimator = "LKF", scenario = "seed000_ramp_moderate_ay" }
//! ekf = { rmse = "vy", estimator = "EKF", scenario = "seed000_ramp_moderate_ay" }
//! ay = { mean = "vehicle.ay", from = 10.0, to = 12.0, scenario = "seed000_ramp_moderate_ay" }
//! ```
//!
//! Metrics of a co-simulated run: `rmse` (the scored RMSE of a state label for an estimator
//! instance), `window_rmse` (`truth`, `estimate` columns over `[from, to]`), `mean` (a column's
//! mean over `[from, to]`), `peak_abs` (a column's largest magnitude), `step_wall_time` (an
//! instance's wall time per doStep, s). Metrics of an offline study (`study = "seed003"`, the
//! identification of `harness identify`; `study = "mismatch"`, `harness mismatch`): `identified`
//! (a parameter; `over_runs` = `mean`, `spread` or `each`, a list), `relative_error` (percent,
//! same `over_runs`), `true_parameter`, `state_rmse` (table 3.1 mean over the runs, `of` =
//! `filter`, `smoother` or `measurement`), `count = "runs"`, `text = "convergence"` and
//! `sideslip_rmse` (`scales_1` or `identified`, rad, of `estimator` on held-out `scenario`).
//! `seed_table` (with `entry`) is a value of seed 003's tables 3.1 and 3.2, and `value` an
//! expression of other metrics. A finding whose scenarios or studies did not run, or whose study
//! lacks what a metric needs (no truth, no simulated states), is left out.
//!
//! `{name}` in `seed_says`, `measure`, `lead` and `note` is a metric in the report's number
//! format ([`fmt`]); `{name:.N}` gives N decimals, `{name:shortest}` the shortest text that reads
//! back as the same number; a list joins its items with ", ". `note` is a string or a list of
//! `{ text, when }` segments, each shown when its criterion `when` (if any) holds.
//!
//! With `cases` (a list of tables of words, e.g. `{ scenario = "...", label = "..." }`, or the
//! name of a study's rows: `"mismatch_validation"`, words `scenario` and `estimator`), `{word}`
//! in any string is replaced per case; `each_case = "finding"` gives one finding per case that
//! ran, `each_case = "part"` one finding whose measure is `lead` followed by the cases'
//! measures (joined with "; ") and which agrees when every case's criterion holds.

use std::collections::{BTreeMap, BTreeSet};

use anyhow::{anyhow, bail, Context, Result};
use fmi_master::runner::RunOutput;
use serde::Deserialize;

use crate::expression::Expr;

mod study;

pub use study::{
    Measured, RowSet, Scales, SeedTable, Sources, StateEstimate, Study, StudyMetric, Unavailable,
};

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
pub const FINDINGS_FILES: [(&str, &str); 4] = [
    ("seed000.toml", include_str!("../findings/seed000.toml")),
    ("seed001.toml", include_str!("../findings/seed001.toml")),
    ("seed003.toml", include_str!("../findings/seed003.toml")),
    ("mismatch.toml", include_str!("../findings/mismatch.toml")),
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
    /// With `each_case = "part"`: the text before the cases' measures.
    #[serde(default)]
    pub lead: String,
    pub criterion: String,
    #[serde(default)]
    pub note: Note,
    pub metrics: BTreeMap<String, Metric>,
    #[serde(default)]
    pub cases: Cases,
    #[serde(default)]
    pub each_case: EachCase,
}

/// The cases an entry repeats over.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Cases {
    /// Written out in the file: the words of each case.
    Listed(Vec<BTreeMap<String, String>>),
    /// The rows of a study's outcome, one case each.
    Rows(RowSet),
}

impl Default for Cases {
    fn default() -> Self {
        Cases::Listed(Vec::new())
    }
}

/// A finding's note: one text, or segments shown when their criterion holds.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Note {
    Text(String),
    Segments(Vec<NoteSegment>),
}

impl Default for Note {
    fn default() -> Self {
        Note::Text(String::new())
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoteSegment {
    pub text: String,
    /// A criterion (see [`crate::expression`]); the segment is shown when it holds.
    #[serde(default)]
    pub when: Option<String>,
}

impl Note {
    fn segments(&self) -> Vec<NoteSegment> {
        match self {
            Note::Text(text) => vec![NoteSegment {
                text: text.clone(),
                when: None,
            }],
            Note::Segments(segments) => segments.clone(),
        }
    }
}

/// How an entry with `cases` becomes findings.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EachCase {
    /// One finding per case that ran.
    #[default]
    Finding,
    /// One finding of all cases that ran: `lead` and the `measure` of each joined with "; ",
    /// agreeing when every case's criterion holds.
    Part,
}

/// A number measured on the runs or the studies.
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
    /// A number of an offline study's outcome.
    Study(StudyMetric),
    /// A value of seed 003's tables.
    SeedTable {
        seed_table: SeedTable,
        entry: String,
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
            Metric::Study(_) | Metric::SeedTable { .. } | Metric::Value { .. } => None,
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
            Metric::Study(metric) => Metric::Study(metric.substituted(&s)),
            Metric::SeedTable { seed_table, entry } => Metric::SeedTable {
                seed_table: *seed_table,
                entry: s(entry),
            },
            Metric::Value { value } => Metric::Value { value: s(value) },
        }
    }

    /// The metric of a co-simulated run on `output` (NaN where a column or score is missing,
    /// as the report shows it).
    fn measure_run(&self, output: &RunOutput) -> f64 {
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
            Metric::Study(_) | Metric::SeedTable { .. } | Metric::Value { .. } => {
                unreachable!("measured by Evaluation::measure")
            }
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

/// How a placeholder formats its metric: `{name}`, `{name:.N}`, `{name:shortest}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    /// [`fmt`], the report's number format.
    Report,
    /// A fixed number of decimals.
    Decimals(usize),
    /// The shortest text that reads back as the same number (Rust's `{}`).
    Shortest,
}

impl Format {
    fn parse(spec: Option<&str>) -> Result<Format> {
        match spec {
            None => Ok(Format::Report),
            Some("shortest") => Ok(Format::Shortest),
            Some(spec) => spec
                .strip_prefix('.')
                .and_then(|digits| digits.parse().ok())
                .map(Format::Decimals)
                .ok_or_else(|| anyhow!("format {spec:?}: expected .N (decimals) or shortest")),
        }
    }

    fn number(self, x: f64) -> String {
        match self {
            Format::Report => fmt(x),
            Format::Decimals(decimals) => format!("{x:.decimals$}"),
            Format::Shortest => x.to_string(),
        }
    }

    fn measured(self, value: &Measured) -> String {
        match value {
            Measured::Number(x) => self.number(*x),
            Measured::List(items) => items
                .iter()
                .map(|x| self.number(*x))
                .collect::<Vec<_>>()
                .join(", "),
            Measured::Text(text) => text.clone(),
        }
    }
}

/// The placeholders `{name}` or `{name:format}` in a template, as (name, format).
fn placeholders(template: &str) -> Vec<(String, Option<String>)> {
    let mut found = Vec::new();
    let mut rest = template;
    while let Some(start) = rest.find('{') {
        let Some(length) = rest[start..].find('}') else {
            break;
        };
        let inner = &rest[start + 1..start + length];
        found.push(match inner.split_once(':') {
            Some((name, format)) => (name.to_string(), Some(format.to_string())),
            None => (inner.to_string(), None),
        });
        rest = &rest[start + length + 1..];
    }
    found
}

/// The metrics of one finding (one case) evaluated on the sources, each once.
struct Evaluation<'a> {
    metrics: BTreeMap<String, Metric>,
    sources: Sources<'a>,
    values: BTreeMap<String, Measured>,
    /// Names being evaluated, to report a metric defined through itself.
    pending: BTreeSet<String>,
}

impl<'a> Evaluation<'a> {
    /// None when a scenario or study the metrics read did not run.
    fn new(metrics: BTreeMap<String, Metric>, sources: Sources<'a>) -> Option<Self> {
        let ran = |scenario: &str| sources.runs.iter().any(|(n, _)| n == scenario);
        let scenarios_ran = metrics.values().filter_map(Metric::scenario).all(ran);
        let studies_ran = metrics.values().all(|metric| match metric {
            Metric::Study(metric) => metric.study().ran(&sources),
            _ => true,
        });
        (scenarios_ran && studies_ran).then(|| Evaluation {
            metrics,
            sources,
            values: BTreeMap::new(),
            pending: BTreeSet::new(),
        })
    }

    fn measured(&mut self, name: &str) -> Result<Measured> {
        if let Some(value) = self.values.get(name) {
            return Ok(value.clone());
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
            Metric::Value { value } => {
                Measured::Number(Expr::parse(value)?.number(&mut |n| self.number(n))?)
            }
            Metric::Study(metric) => metric.measure(&self.sources)?,
            Metric::SeedTable { seed_table, entry } => Measured::Number(seed_table.value(entry)?),
            run => {
                let scenario = run.scenario().unwrap_or_default();
                let (_, output) = self
                    .sources
                    .runs
                    .iter()
                    .find(|(n, _)| n == scenario)
                    .ok_or_else(|| anyhow!("scenario {scenario:?} did not run"))?;
                Measured::Number(run.measure_run(output))
            }
        };
        self.pending.remove(name);
        self.values.insert(name.to_string(), value.clone());
        Ok(value)
    }

    fn number(&mut self, name: &str) -> Result<f64> {
        match self.measured(name)? {
            Measured::Number(x) => Ok(x),
            other => bail!("metric {name:?} is {other:?}, not a number"),
        }
    }

    fn render(&mut self, template: &str) -> Result<String> {
        let mut text = template.to_string();
        for (name, format) in placeholders(template) {
            let value = self.measured(&name)?;
            let written = Format::parse(format.as_deref())?.measured(&value);
            let placeholder = match &format {
                Some(format) => format!("{{{name}:{format}}}"),
                None => format!("{{{name}}}"),
            };
            text = text.replacen(&placeholder, &written, 1);
        }
        Ok(text)
    }

    fn criterion(&mut self, criterion: &str) -> Result<bool> {
        Expr::parse(criterion)?.truth(&mut |n| self.number(n))
    }

    /// The note's segments whose `when` holds, rendered and joined.
    fn note(&mut self, note: &Note, case: &BTreeMap<String, String>) -> Result<String> {
        let mut text = String::new();
        for segment in note.segments() {
            let shown = match &segment.when {
                Some(when) => self.criterion(&substitute(when, case))?,
                None => true,
            };
            if shown {
                text += &self.render(&substitute(&segment.text, case))?;
            }
        }
        Ok(text)
    }
}

/// One case's texts and verdict.
struct CaseResult {
    seed_says: String,
    measured: String,
    agrees: bool,
    note: String,
    /// `lead`, rendered (only for `each_case = "part"`).
    lead: String,
}

impl FindingSpec {
    /// The cases of this entry (one empty case when it has none).
    fn each_case(&self, sources: &Sources) -> Vec<BTreeMap<String, String>> {
        match &self.cases {
            Cases::Listed(cases) if cases.is_empty() => vec![BTreeMap::new()],
            Cases::Listed(cases) => cases.clone(),
            Cases::Rows(rows) => rows.cases(sources),
        }
    }

    /// The words a case defines.
    fn case_words(&self) -> BTreeSet<String> {
        match &self.cases {
            Cases::Listed(cases) => cases.iter().flat_map(|c| c.keys().cloned()).collect(),
            Cases::Rows(rows) => rows.words().iter().map(|w| w.to_string()).collect(),
        }
    }

    /// One case on `sources`; None when it did not run or its study lacks a metric.
    fn evaluate_case(
        &self,
        case: &BTreeMap<String, String>,
        sources: Sources,
    ) -> Result<Option<CaseResult>> {
        let metrics = self
            .metrics
            .iter()
            .map(|(name, metric)| (name.clone(), metric.substituted(case)))
            .collect();
        let Some(mut evaluation) = Evaluation::new(metrics, sources) else {
            return Ok(None);
        };
        let mut texts = || -> Result<CaseResult> {
            Ok(CaseResult {
                seed_says: evaluation.render(&substitute(&self.seed_says, case))?,
                measured: evaluation.render(&substitute(&self.measure, case))?,
                agrees: evaluation.criterion(&substitute(&self.criterion, case))?,
                note: evaluation.note(&self.note, case)?,
                lead: match self.each_case {
                    EachCase::Part => evaluation.render(&self.lead)?,
                    EachCase::Finding => String::new(),
                },
            })
        };
        match texts() {
            Ok(result) => Ok(Some(result)),
            Err(error) if error.downcast_ref::<Unavailable>().is_some() => Ok(None),
            Err(error) => Err(error),
        }
    }

    /// The findings of this entry on `sources`.
    pub fn evaluate(&self, seed: &str, sources: Sources) -> Result<Vec<Finding>> {
        let finding = |case: &BTreeMap<String, String>, result: CaseResult| Finding {
            seed: seed.to_string(),
            experiment: substitute(&self.experiment, case),
            seed_says: result.seed_says,
            we_measure: result.measured,
            agrees: result.agrees,
            note: result.note,
        };
        let mut findings = Vec::new();
        let mut parts: Vec<CaseResult> = Vec::new();
        for case in self.each_case(&sources) {
            let Some(result) = self.evaluate_case(&case, sources)? else {
                continue;
            };
            match self.each_case {
                EachCase::Finding => findings.push(finding(&case, result)),
                EachCase::Part => parts.push(result),
            }
        }
        if let Some(first) = parts.first() {
            let measures: Vec<&str> = parts.iter().map(|p| p.measured.as_str()).collect();
            let joined = CaseResult {
                seed_says: first.seed_says.clone(),
                measured: format!("{}{}", first.lead, measures.join("; ")),
                agrees: parts.iter().all(|p| p.agrees),
                note: first.note.clone(),
                lead: String::new(),
            };
            findings.push(finding(&BTreeMap::new(), joined));
        }
        Ok(findings)
    }

    /// Checks, without runs, that every name the entry uses is a metric or a case word, that
    /// its expressions parse and its formats are known.
    fn check(&self) -> Result<()> {
        let words = self.case_words();
        let mut used = BTreeSet::new();
        Expr::parse(&self.criterion)?.names(&mut used);
        for metric in self.metrics.values() {
            if let Metric::Value { value } = metric {
                Expr::parse(value)?.names(&mut used);
            }
        }
        let mut templates = vec![&self.seed_says, &self.measure, &self.lead];
        let segments = self.note.segments();
        for segment in &segments {
            templates.push(&segment.text);
            if let Some(when) = &segment.when {
                Expr::parse(when)?.names(&mut used);
            }
        }
        for template in templates {
            for (name, format) in placeholders(template) {
                Format::parse(format.as_deref())?;
                used.insert(name);
            }
        }
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

    pub fn evaluate(&self, sources: Sources) -> Result<Vec<Finding>> {
        let mut findings = Vec::new();
        for spec in &self.findings {
            findings.extend(
                spec.evaluate(&self.seed, sources)
                    .with_context(|| format!("finding {:?}", spec.experiment))?,
            );
        }
        Ok(findings)
    }
}

/// Every seed finding and the studies' findings, from the shipped files, on `sources`.
pub fn findings(sources: Sources) -> Result<Vec<Finding>> {
    let mut findings = Vec::new();
    for (name, text) in FINDINGS_FILES {
        findings.extend(FindingsFile::parse(name, text)?.evaluate(sources)?);
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
        assert_eq!(
            placeholders("a {x} b {y_2:.3}"),
            [
                ("x".to_string(), None),
                ("y_2".to_string(), Some(".3".to_string()))
            ]
        );
        let case = BTreeMap::from([("label".to_string(), "10 ms".to_string())]);
        assert_eq!(substitute("T = {label}: {e}", &case), "T = 10 ms: {e}");
    }
}
