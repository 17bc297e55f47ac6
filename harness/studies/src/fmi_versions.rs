//! FMI 2.0 against FMI 3.0 on the mismatch campaigns (`harness fmi-versions`): every run of a
//! campaign ([`crate::campaigns`]: every car on every reference model and manoeuvre, every
//! estimator instance of the base scenario) once through the FMI 2.0 archives and once through
//! the FMI 3.0 ones (the scenario key `fmi_version = 3`: `<stem>-fmi3.fmu` beside each archive),
//! with every output of every instance recorded beside what the campaign records, and every
//! recorded value of the one compared with the other's bit for bit (`f64::to_bits`).
//!
//! Both archives hold the same library behind two front ends (docs/reference/fmi3.md), so the
//! outputs the two versions share must not differ in a single bit; the seed scenarios check
//! this in fmi-master's tests, this study on the campaigns' longer and closed-loop runs.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use rayon::prelude::*;

use fmi_master::cosim::RunResult;
use fmi_master::fmu::LoadedFmu;
use fmi_master::recording::write_whole;
use fmi_master::runner::{scenario_dir, workspace_root, Environment, WorkFolder};
use fmi_master::scenario::RecordSection;

use crate::campaigns::{Campaign, ReferenceModel, SHIPPED_CAMPAIGNS};

/// The study's file in its output folder.
pub const CSV_NAME: &str = "fmi_versions.csv";
/// The committed copy the documents quote (`--update-committed`).
pub const COMMITTED_CSV: &str = "docs/data/fmi_versions.csv";
/// The CSV's header: one row per campaign run.
pub const HEADER: [&str; 6] = [
    "car",
    "manoeuvre",
    "columns",
    "samples",
    "differing_values",
    "max_abs_difference",
];
/// The FMI versions compared, as the scenario key `fmi_version` names them.
const VERSIONS: [u8; 2] = [2, 3];

/// One run's recorded values through FMI 2.0 against the same run's through FMI 3.0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// Recorded columns compared (every output of every instance and the manoeuvre's signals).
    pub columns: usize,
    /// Communication points of each column.
    pub samples: usize,
    /// Values whose bits differ.
    pub differing: usize,
    /// The largest |FMI 2 - FMI 3| over the differing values ([`difference`]); 0 when none
    /// differ.
    pub max_abs_difference: f64,
}

/// How far apart two values whose bits differ are: |a - b|; infinite when one is NaN and the
/// other is not, 0 for two NaNs (their payloads differ, their values do not).
pub fn difference(a: f64, b: f64) -> f64 {
    match (a.is_nan(), b.is_nan()) {
        (true, true) => 0.0,
        (false, false) => (a - b).abs(),
        _ => f64::INFINITY,
    }
}

/// Column `k` of `fmi2` against column `k` of `fmi3`, bit for bit (a NaN equals only the same
/// NaN, 0 differs from -0). An error names the first pair whose lengths differ.
pub fn compare_columns(fmi2: &[&[f64]], fmi3: &[&[f64]]) -> Result<Comparison> {
    if fmi2.len() != fmi3.len() {
        bail!(
            "{} columns through FMI 2.0 against {} through FMI 3.0; expected the same columns",
            fmi2.len(),
            fmi3.len()
        );
    }
    let samples = fmi2.first().map_or(0, |column| column.len());
    let mut comparison = Comparison {
        columns: fmi2.len(),
        samples,
        differing: 0,
        max_abs_difference: 0.0,
    };
    for (k, (a, b)) in fmi2.iter().zip(fmi3).enumerate() {
        if a.len() != samples || b.len() != samples {
            bail!(
                "column {k}: {} values through FMI 2.0 and {} through FMI 3.0; expected {samples} each",
                a.len(),
                b.len()
            );
        }
        for (x, y) in a.iter().zip(b.iter()) {
            if x.to_bits() != y.to_bits() {
                comparison.differing += 1;
                comparison.max_abs_difference =
                    comparison.max_abs_difference.max(difference(*x, *y));
            }
        }
    }
    Ok(comparison)
}

/// A run through FMI 2.0 against the same run through FMI 3.0: the same columns at the same
/// communication points (else an error naming what differs), every value compared
/// ([`compare_columns`]).
pub fn compare(fmi2: &RunResult, fmi3: &RunResult) -> Result<Comparison> {
    if fmi2.columns != fmi3.columns {
        let first = fmi2
            .columns
            .iter()
            .zip(&fmi3.columns)
            .find(|(a, b)| a != b)
            .map_or_else(
                || "a different number of columns".to_string(),
                |(a, b)| format!("{a:?} against {b:?}"),
            );
        bail!("{}: the recorded columns differ: {first}", fmi2.scenario);
    }
    let same_times = fmi2.times.len() == fmi3.times.len()
        && fmi2
            .times
            .iter()
            .zip(&fmi3.times)
            .all(|(a, b)| a.to_bits() == b.to_bits());
    if !same_times {
        bail!(
            "{}: the communication points differ ({} through FMI 2.0, {} through FMI 3.0)",
            fmi2.scenario,
            fmi2.times.len(),
            fmi3.times.len()
        );
    }
    let fmi2_columns: Vec<&[f64]> = fmi2.data.iter().collect();
    let fmi3_columns: Vec<&[f64]> = fmi3.data.iter().collect();
    compare_columns(&fmi2_columns, &fmi3_columns)
}

/// One campaign run: the car (with its reference model's label) and the manoeuvre.
#[derive(Debug, Clone, PartialEq)]
pub struct RunComparison {
    pub car: String,
    pub manoeuvre: String,
    pub comparison: Comparison,
}

/// Every run of the campaign, in the campaign's order.
#[derive(Debug, Clone)]
pub struct Report {
    pub runs: Vec<RunComparison>,
    /// Wall time of the study, s.
    pub seconds: f64,
}

impl Report {
    /// Values compared over every run.
    pub fn values(&self) -> usize {
        self.runs
            .iter()
            .map(|r| r.comparison.columns * r.comparison.samples)
            .sum()
    }

    /// Values whose bits differ over every run.
    pub fn differing(&self) -> usize {
        self.runs.iter().map(|r| r.comparison.differing).sum()
    }

    /// The CSV: [`HEADER`], one row per run.
    pub fn csv_text(&self) -> Result<String> {
        let mut writer = csv::Writer::from_writer(Vec::new());
        writer.write_record(HEADER)?;
        for run in &self.runs {
            let c = &run.comparison;
            writer.write_record([
                run.car.clone(),
                run.manoeuvre.clone(),
                c.columns.to_string(),
                c.samples.to_string(),
                c.differing.to_string(),
                c.max_abs_difference.to_string(),
            ])?;
        }
        let bytes = writer
            .into_inner()
            .map_err(|e| anyhow!("writing the CSV: {e}"))?;
        Ok(String::from_utf8(bytes)?)
    }

    /// Writes [`CSV_NAME`] into `out` (and to [`COMMITTED_CSV`] with `update_committed`);
    /// the path written in `out`.
    pub fn write(&self, out: &Path, update_committed: bool) -> Result<PathBuf> {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
        let text = self.csv_text()?;
        let path = out.join(CSV_NAME);
        write_whole(&path, &text)?;
        if update_committed {
            write_whole(&workspace_root().join(COMMITTED_CSV), &text)?;
        }
        Ok(path)
    }

    /// One line: runs, columns, values compared, how many differ and by how much at most.
    pub fn summary(&self) -> String {
        let columns: usize = self.runs.iter().map(|r| r.comparison.columns).sum();
        let largest = self
            .runs
            .iter()
            .map(|r| r.comparison.max_abs_difference)
            .fold(0.0, f64::max);
        format!(
            "FMI 2.0 against FMI 3.0 on {} campaign runs: {} values in {columns} recorded columns \
             compared bit for bit, {} differ (largest difference {largest}), in {:.0} s",
            self.runs.len(),
            self.values(),
            self.differing(),
            self.seconds
        )
    }

    /// An error naming how many values of how many runs differ, when any does.
    pub fn check(&self) -> Result<()> {
        let runs = self
            .runs
            .iter()
            .filter(|r| r.comparison.differing > 0)
            .count();
        if runs > 0 {
            bail!(
                "{} of {} values differ between FMI 2.0 and FMI 3.0, in {runs} of {} runs; \
                 expected none (one library serves both archives)",
                self.differing(),
                self.values(),
                self.runs.len()
            );
        }
        Ok(())
    }
}

/// `campaign` with every output of every instance recorded beside what it records (the scenario
/// format's default record), run through FMI `version`.
fn through(campaign: &Campaign, version: u8) -> Campaign {
    let mut campaign = campaign.clone();
    campaign
        .base
        .record
        .variables
        .extend(RecordSection::default().variables);
    campaign.base.fmi_version = version;
    campaign
}

/// Every run of `campaign` through both FMI versions, compared ([`compare`]). The runs' CSVs
/// go below `env.out_dir` into a folder removed at the end.
pub fn compare_campaign(campaign: &Campaign, env: &Environment) -> Result<Report> {
    let started = Instant::now();
    let runs_dir = env.out_dir.join(".runs");
    let _runs = WorkFolder::new(runs_dir.clone());
    let versions = VERSIONS.map(|v| through(campaign, v));
    let envs = VERSIONS.map(|v| Environment {
        fmu_dir: env.fmu_dir.clone(),
        out_dir: runs_dir.join(format!("fmi{v}")),
    });
    let estimator_fmu = campaign.estimator_fmu(&envs[0])?;
    // One car on one reference model per task, as the campaigns run (a sine with dwell takes
    // its amplitude from the same version's slow ramp); collected in the campaign's order.
    let runs = campaign
        .cars_on_models()
        .par_iter()
        .map(|(reference, car_file)| {
            compare_car(&versions, reference, car_file, &envs, &estimator_fmu)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Report {
        runs: runs.into_iter().flatten().collect(),
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The campaign's runs of one car on one reference model through FMI 2.0, held in memory, then
/// through FMI 3.0, each compared with its FMI 2.0 run as it finishes.
fn compare_car(
    versions: &[Campaign; 2],
    reference: &ReferenceModel,
    car_file: &Path,
    envs: &[Environment; 2],
    estimator_fmu: &LoadedFmu,
) -> Result<Vec<RunComparison>> {
    let car = reference.car_label(car_file);
    let mut fmi2_runs = Vec::new();
    versions[0].for_each_run(
        reference,
        car_file,
        &envs[0],
        estimator_fmu,
        |m, _, run, _| {
            drop_csv(&run.csv)?;
            fmi2_runs.push((m.name.clone(), run.result));
            Ok(())
        },
    )?;
    let mut fmi2_runs = fmi2_runs.into_iter();
    let mut compared = Vec::new();
    versions[1].for_each_run(
        reference,
        car_file,
        &envs[1],
        estimator_fmu,
        |m, _, run, _| {
            drop_csv(&run.csv)?;
            let (manoeuvre, fmi2) = fmi2_runs
                .next()
                .filter(|(name, _)| *name == m.name)
                .ok_or_else(|| {
                    anyhow!(
                        "{car}: manoeuvre {:?} ran through FMI 3.0 where FMI 2.0 ran another",
                        m.name
                    )
                })?;
            let comparison =
                compare(&fmi2, &run.result).with_context(|| format!("{car}, {manoeuvre}"))?;
            compared.push(RunComparison {
                car: car.clone(),
                manoeuvre,
                comparison,
            });
            Ok(())
        },
    )?;
    Ok(compared)
}

/// Removes a run's CSV once its values are in memory: with every output of its 19 instances a
/// campaign run's CSV is 10-40 MB, and the study compares the values, not the files.
fn drop_csv(path: &Path) -> Result<()> {
    std::fs::remove_file(path).with_context(|| format!("removing {}", path.display()))
}

/// The shipped campaigns ([`SHIPPED_CAMPAIGNS`]) with the FMUs of `fmu_dir` through both
/// versions ([`compare_campaign`]), scratch files below `out`.
pub fn run_shipped(fmu_dir: &Path, out: &Path) -> Result<Report> {
    let campaign = Campaign::load(&scenario_dir().join(SHIPPED_CAMPAIGNS))?;
    compare_campaign(
        &campaign,
        &Environment {
            fmu_dir: fmu_dir.to_path_buf(),
            out_dir: out.to_path_buf(),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(differing: usize, max_abs_difference: f64) -> Report {
        Report {
            runs: vec![RunComparison {
                car: "ford_escort (model 1)".into(),
                manoeuvre: "step_steer".into(),
                comparison: Comparison {
                    columns: 2,
                    samples: 3,
                    differing,
                    max_abs_difference,
                },
            }],
            seconds: 1.0,
        }
    }

    /// Identical columns compare equal; one value moved by one ulp, a NaN against a number, a
    /// -0 against 0 and two NaNs of different payloads each count as one differing value, with
    /// the largest difference the ulp's (the NaN against a number: infinite).
    #[test]
    fn every_differing_bit_pattern_is_counted() {
        let truth: [f64; 3] = [0.1, -2.5, 1e300];
        let same: [f64; 3] = [0.1, -2.5, 1e300];
        let mut moved = same;
        moved[1] = f64::from_bits(moved[1].to_bits() + 1);
        let ulp = (moved[1] - truth[1]).abs();
        assert!(ulp > 0.0);
        let c = compare_columns(&[&truth, &truth], &[&same, &moved]).unwrap();
        assert_eq!((c.columns, c.samples, c.differing), (2, 3, 1));
        assert_eq!(c.max_abs_difference, ulp);
        let c = compare_columns(&[&truth], &[&same]).unwrap();
        assert_eq!((c.differing, c.max_abs_difference), (0, 0.0));
        let quiet = f64::NAN;
        let other_nan = f64::from_bits(quiet.to_bits() | 1);
        let c = compare_columns(&[&[0.0, quiet, 1.0]], &[&[-0.0, other_nan, quiet]]).unwrap();
        assert_eq!((c.differing, c.max_abs_difference), (3, f64::INFINITY));
        let c = compare_columns(&[&[quiet, quiet]], &[&[quiet, quiet]]).unwrap();
        assert_eq!(c.differing, 0);
    }

    /// Columns of different counts or lengths cannot be compared: an error names them.
    #[test]
    fn columns_of_different_shapes_are_refused() {
        let error = format!("{:#}", compare_columns(&[&[1.0]], &[]).unwrap_err());
        assert!(
            error.contains("1 columns") && error.contains("0 through"),
            "{error}"
        );
        let error = format!(
            "{:#}",
            compare_columns(&[&[1.0]], &[&[1.0, 2.0]]).unwrap_err()
        );
        assert!(
            error.contains("column 0") && error.contains("2 through"),
            "{error}"
        );
    }

    /// The CSV has the header and one row per run; `check` fails naming the count once a value
    /// differs and passes when none does.
    #[test]
    fn a_differing_value_fails_the_check_and_is_written() {
        let clean = report(0, 0.0);
        assert!(clean.check().is_ok());
        assert_eq!(
            clean.csv_text().unwrap(),
            format!(
                "{}\nford_escort (model 1),step_steer,2,3,0,0\n",
                HEADER.join(",")
            )
        );
        let off = report(1, 2e-16);
        let error = format!("{:#}", off.check().unwrap_err());
        assert!(error.starts_with("1 of 6 values differ"), "{error}");
        assert!(off.csv_text().unwrap().ends_with(",1,0.0000000000000002\n"));
        assert!(off.summary().contains("1 differ"), "{}", off.summary());
    }
}
