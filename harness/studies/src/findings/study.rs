//! The findings files' metrics over the offline studies' outcomes: the seed-003 identification
//! ([`Outcome`], `study = "seed003"`) and the model-mismatch study ([`MismatchReport`],
//! `study = "mismatch"`), and the values of seed 003's tables. Each metric reads the number the
//! study's own report shows (the same mean, spread and per-run values), so a finding written
//! here states exactly what the report's tables state.

use std::collections::BTreeMap;

use anyhow::{anyhow, bail, Result};
use estimation::models::rear_axle::PARAMETER_NAMES as SEED003_PARAMETERS;
use estimation::models::single_track_identification::PARAMETER_NAMES as MISMATCH_PARAMETERS;
use fmi_master::runner::RunOutput;
use serde::Deserialize;

use crate::identify::{Outcome, STATE_LABELS};
use crate::mismatch::MismatchReport;
use crate::seed003::{
    mean_and_spread, SEED_TABLE_3_1_FILTER, SEED_TABLE_3_1_SMOOTHER, SEED_TABLE_3_2_IDENTIFIED,
    SEED_TABLE_3_2_RELATIVE_PERCENT,
};

/// What findings are measured on: the co-simulated runs (keyed by scenario name) and the
/// offline studies that ran.
#[derive(Clone, Copy, Default)]
pub struct Sources<'a> {
    pub runs: &'a [(String, RunOutput)],
    pub seed003: Option<&'a Outcome>,
    pub mismatch: Option<&'a MismatchReport>,
}

/// A metric's value: a number, a list of numbers (one per run) or a word.
#[derive(Debug, Clone, PartialEq)]
pub enum Measured {
    Number(f64),
    List(Vec<f64>),
    Text(String),
}

/// A metric that cannot be measured on this outcome (no truth, no simulated states, no such
/// row): the finding is left out, as when its scenario did not run.
#[derive(Debug)]
pub struct Unavailable(pub String);

impl std::fmt::Display for Unavailable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "not available: {}", self.0)
    }
}

impl std::error::Error for Unavailable {}

/// An offline study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Study {
    /// The seed-003 EM identification (`harness identify`), over several noise seeds.
    Seed003,
    /// The model-mismatch study (`harness mismatch`), one identification run.
    Mismatch,
}

impl Study {
    /// Whether the study ran (its outcome is among the sources).
    pub fn ran(self, sources: &Sources) -> bool {
        match self {
            Study::Seed003 => sources.seed003.is_some(),
            Study::Mismatch => sources.mismatch.is_some(),
        }
    }
}

/// Which statistic over a study's runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OverRuns {
    #[default]
    Mean,
    /// The sample standard deviation (0 for one run).
    Spread,
    /// Each run's value, a list.
    Each,
}

/// Which estimate of a state in seed 003's table 3.1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StateEstimate {
    Filter,
    Smoother,
    /// The raw measurement.
    Measurement,
}

/// Which run of the mismatch study's held-out manoeuvres.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scales {
    /// The seed's tyre, cornering-stiffness scales 1.
    #[serde(rename = "scales_1")]
    One,
    /// The identified scales.
    Identified,
}

/// What a study counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Counted {
    Runs,
}

/// A word about a study's outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Word {
    /// "converged" or "NOT converged".
    Convergence,
}

/// A number (or list, or word) of an offline study's outcome.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum StudyMetric {
    /// An identified parameter (seed003: `Csf`, `Csr`, `m/J`, `lf`; mismatch:
    /// `cornering_stiffness_scale_front`, `_rear`).
    Identified {
        study: Study,
        identified: String,
        #[serde(default)]
        over_runs: OverRuns,
    },
    /// |identified - true| / true, percent (when the truth is known).
    RelativeError {
        study: Study,
        relative_error: String,
        #[serde(default)]
        over_runs: OverRuns,
    },
    /// The true value of a parameter (when known).
    TrueParameter {
        study: Study,
        true_parameter: String,
    },
    /// Table 3.1: the mean over the runs of a state's RMSE.
    StateRmse {
        study: Study,
        state_rmse: String,
        of: StateEstimate,
    },
    /// How many runs the study made.
    Count { study: Study, count: Counted },
    /// A word about the outcome.
    Text { study: Study, text: Word },
    /// The sideslip RMSE (rad) of `estimator` on the held-out `scenario`.
    SideslipRmse {
        study: Study,
        sideslip_rmse: Scales,
        scenario: String,
        estimator: String,
    },
}

/// A table of seed 003 (003: tables 3.1 and 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum SeedTable {
    /// RMSE of the particle filter, per state of [`STATE_LABELS`].
    #[serde(rename = "3.1 filter")]
    Filter,
    /// RMSE of the particle smoother, per state.
    #[serde(rename = "3.1 smoother")]
    Smoother,
    /// The identified parameters.
    #[serde(rename = "3.2 identified")]
    Identified,
    /// Their relative errors, percent.
    #[serde(rename = "3.2 relative error")]
    RelativeError,
}

impl SeedTable {
    /// The table's value for `entry` (a state label or a parameter name).
    pub fn value(self, entry: &str) -> Result<f64> {
        Ok(match self {
            SeedTable::Filter => SEED_TABLE_3_1_FILTER[index(&STATE_LABELS, entry)?],
            SeedTable::Smoother => SEED_TABLE_3_1_SMOOTHER[index(&STATE_LABELS, entry)?],
            SeedTable::Identified => SEED_TABLE_3_2_IDENTIFIED[index(&SEED003_PARAMETERS, entry)?],
            SeedTable::RelativeError => {
                SEED_TABLE_3_2_RELATIVE_PERCENT[index(&SEED003_PARAMETERS, entry)?]
            }
        })
    }
}

/// The rows of a study's outcome that an entry can repeat over (`cases = "..."`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RowSet {
    /// The mismatch study's held-out runs, in the study's order: words `scenario`, `estimator`.
    MismatchValidation,
}

impl RowSet {
    pub fn words(self) -> &'static [&'static str] {
        match self {
            RowSet::MismatchValidation => &["scenario", "estimator"],
        }
    }

    /// One case per row (none when the study did not run).
    pub fn cases(self, sources: &Sources) -> Vec<BTreeMap<String, String>> {
        match self {
            RowSet::MismatchValidation => sources
                .mismatch
                .map(|report| {
                    report
                        .validation
                        .iter()
                        .map(|row| {
                            BTreeMap::from([
                                ("scenario".to_string(), row.scenario.clone()),
                                ("estimator".to_string(), row.estimator.clone()),
                            ])
                        })
                        .collect()
                })
                .unwrap_or_default(),
        }
    }
}

/// Position of `name` in `names`, or an error listing them.
fn index(names: &[&str], name: &str) -> Result<usize> {
    names
        .iter()
        .position(|n| *n == name)
        .ok_or_else(|| anyhow!("{name:?}: expected one of {names:?}"))
}

fn unavailable(what: String) -> anyhow::Error {
    anyhow::Error::new(Unavailable(what))
}

impl OverRuns {
    fn of(self, values: Vec<f64>) -> Measured {
        match self {
            OverRuns::Mean => Measured::Number(mean_and_spread(values).0),
            OverRuns::Spread => Measured::Number(mean_and_spread(values).1),
            OverRuns::Each => Measured::List(values),
        }
    }
}

impl StudyMetric {
    pub fn study(&self) -> Study {
        match self {
            StudyMetric::Identified { study, .. }
            | StudyMetric::RelativeError { study, .. }
            | StudyMetric::TrueParameter { study, .. }
            | StudyMetric::StateRmse { study, .. }
            | StudyMetric::Count { study, .. }
            | StudyMetric::Text { study, .. }
            | StudyMetric::SideslipRmse { study, .. } => *study,
        }
    }

    /// The metric with its names passed through `s` (the case's words replaced).
    pub fn substituted(&self, s: &dyn Fn(&String) -> String) -> StudyMetric {
        let mut metric = self.clone();
        match &mut metric {
            StudyMetric::Identified { identified: n, .. }
            | StudyMetric::RelativeError {
                relative_error: n, ..
            }
            | StudyMetric::TrueParameter {
                true_parameter: n, ..
            }
            | StudyMetric::StateRmse { state_rmse: n, .. } => *n = s(n),
            StudyMetric::SideslipRmse {
                scenario,
                estimator,
                ..
            } => {
                *scenario = s(scenario);
                *estimator = s(estimator);
            }
            StudyMetric::Count { .. } | StudyMetric::Text { .. } => {}
        }
        metric
    }

    /// The metric on the study's outcome; [`Unavailable`] when the outcome lacks it.
    pub fn measure(&self, sources: &Sources) -> Result<Measured> {
        match self.study() {
            Study::Seed003 => {
                let outcome = sources
                    .seed003
                    .ok_or_else(|| unavailable("the seed-003 identification did not run".into()))?;
                self.on_seed003(outcome)
            }
            Study::Mismatch => {
                let report = sources
                    .mismatch
                    .ok_or_else(|| unavailable("the mismatch study did not run".into()))?;
                self.on_mismatch(report)
            }
        }
    }

    fn on_seed003(&self, outcome: &Outcome) -> Result<Measured> {
        let parameter = |name: &str| index(&SEED003_PARAMETERS, name);
        let no_truth = || unavailable("the identification's true parameters are not known".into());
        Ok(match self {
            StudyMetric::Identified {
                identified,
                over_runs,
                ..
            } => {
                let j = parameter(identified)?;
                over_runs.of(outcome
                    .runs
                    .iter()
                    .map(|r| r.result.parameters[j])
                    .collect())
            }
            // The same statistics as `Outcome::relative_error` (the report's table 3.2).
            StudyMetric::RelativeError {
                relative_error,
                over_runs,
                ..
            } => {
                let j = parameter(relative_error)?;
                outcome.job.truth.ok_or_else(no_truth)?;
                over_runs.of(outcome
                    .runs
                    .iter()
                    .filter_map(|r| outcome.relative_errors(r).map(|e| e[j]))
                    .collect())
            }
            StudyMetric::TrueParameter { true_parameter, .. } => {
                let j = parameter(true_parameter)?;
                Measured::Number(outcome.job.truth.ok_or_else(no_truth)?[j])
            }
            StudyMetric::StateRmse { state_rmse, of, .. } => {
                let i = index(&STATE_LABELS, state_rmse)?;
                let [filter, smoother, measurement] = outcome
                    .state_rmse(i)
                    .ok_or_else(|| unavailable("no simulated states (table 3.1)".into()))?;
                Measured::Number(match of {
                    StateEstimate::Filter => filter.0,
                    StateEstimate::Smoother => smoother.0,
                    StateEstimate::Measurement => measurement.0,
                })
            }
            StudyMetric::Count {
                count: Counted::Runs,
                ..
            } => Measured::Number(outcome.runs.len() as f64),
            StudyMetric::Text { .. } | StudyMetric::SideslipRmse { .. } => {
                bail!("{self:?}: not a metric of study seed003")
            }
        })
    }

    fn on_mismatch(&self, report: &MismatchReport) -> Result<Measured> {
        Ok(match self {
            StudyMetric::Identified {
                identified,
                over_runs,
                ..
            } => {
                let j = index(&MISMATCH_PARAMETERS, identified)?;
                over_runs.of(vec![report.identification.parameters[j]])
            }
            StudyMetric::Count {
                count: Counted::Runs,
                ..
            } => Measured::Number(1.0),
            StudyMetric::Text {
                text: Word::Convergence,
                ..
            } => Measured::Text(report.convergence()),
            StudyMetric::SideslipRmse {
                sideslip_rmse,
                scenario,
                estimator,
                ..
            } => {
                let row = report
                    .validation_of(scenario)
                    .find(|row| row.estimator == *estimator)
                    .ok_or_else(|| {
                        unavailable(format!("no held-out run of {estimator} on {scenario}"))
                    })?;
                Measured::Number(match sideslip_rmse {
                    Scales::One => row.sideslip_rmse_seed,
                    Scales::Identified => row.sideslip_rmse_identified,
                })
            }
            StudyMetric::RelativeError { .. }
            | StudyMetric::TrueParameter { .. }
            | StudyMetric::StateRmse { .. } => {
                bail!("{self:?}: not a metric of study mismatch (it has no true parameters)")
            }
        })
    }
}
