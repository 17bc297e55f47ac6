//! The campaigns' sideslip accuracy in the accuracy CSV format ([`crate::summary::HEADER`], the
//! real recording's `docs/data/mbds_replay.csv` has the same): per truth (the car files' full
//! vehicle, the ReferenceVehicle's other models) and per estimator model and kind, the mean over
//! the runs of the sideslip RMSE, the NEES, the zero-sideslip and steady-state-formula RMSEs and
//! the largest vx error. The README's accuracy table quotes the committed copy.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use fmi_master::recording::write_whole;
use fmi_master::runner::workspace_root;

use super::{distinct, CampaignReport, Row};
use crate::replay::study::MODELS;
use crate::summary::{self, AccuracyRow};

/// The file `harness robustness` writes into its output folder.
pub const CSV_NAME: &str = "campaigns_sideslip.csv";

/// The committed copy (`harness robustness --update-committed`), relative to the workspace.
pub const COMMITTED_CSV: &str = "docs/data/campaigns_sideslip.csv";

/// One truth, estimator model and estimator kind: the rows of its runs.
struct Group<'a> {
    truth: &'a str,
    model: &'static str,
    kind: &'a str,
    rows: Vec<&'a Row>,
}

/// The rows grouped by truth (in the order the truths first appear), estimator model (in the
/// order of [`MODELS`], whose replay-study name the group takes, so that both files name a model
/// alike) and estimator kind (in the order the kinds first appear).
fn groups(rows: &[Row]) -> Result<Vec<Group<'_>>> {
    if let Some(row) = rows
        .iter()
        .find(|r| !MODELS.iter().any(|(_, item)| *item == r.model_item))
    {
        bail!(
            "instance {}: estimator model {:?}; expected one of {MODELS:?}",
            row.estimator,
            row.model_item
        );
    }
    let truths = distinct(rows.iter().map(|r| r.truth.as_str()));
    let kinds = distinct(rows.iter().map(|r| r.estimator_item.as_str()));
    let mut groups = Vec::new();
    for truth in &truths {
        for (model, item) in MODELS {
            for kind in &kinds {
                let of_group: Vec<&Row> = rows
                    .iter()
                    .filter(|r| r.truth == *truth && r.model_item == item)
                    .filter(|r| r.estimator_item == *kind)
                    .collect();
                if !of_group.is_empty() {
                    groups.push(Group {
                        truth,
                        model,
                        kind,
                        rows: of_group,
                    });
                }
            }
        }
    }
    Ok(groups)
}

fn mean(rows: &[&Row], value: impl Fn(&Row) -> f64) -> f64 {
    rows.iter().map(|r| value(r)).sum::<f64>() / rows.len() as f64
}

fn counted(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// The mean rows: one per truth, estimator model and kind, over its runs. `source` names the
/// truth and its number of cars, `case` the number of runs.
pub fn mean_rows(rows: &[Row]) -> Result<Vec<AccuracyRow>> {
    if rows.is_empty() {
        bail!("the campaigns gave no rows to average");
    }
    Ok(groups(rows)?
        .into_iter()
        .map(|group| {
            let cars = distinct(
                rows.iter()
                    .filter(|r| r.truth == group.truth)
                    .map(|r| r.car.as_str()),
            );
            let of = |value: fn(&Row) -> f64| mean(&group.rows, value);
            AccuracyRow {
                source: format!(
                    "simulated {} ({})",
                    group.truth,
                    counted(cars.len(), "car", "cars")
                ),
                case: format!("mean of {}", counted(group.rows.len(), "run", "runs")),
                model: group.model.to_string(),
                estimator: group.kind.to_string(),
                wheel_speeds: true,
                rmse_deg: of(|r| r.rmse).to_degrees(),
                nees: of(|r| r.mean_nees),
                zero_rmse_deg: of(|r| r.zero_baseline).to_degrees(),
                yardstick_rmse_deg: Some(of(|r| r.yardstick).to_degrees()),
                max_vx_error_mps: Some(of(|r| r.max_vx_error)),
            }
        })
        .collect())
}

impl CampaignReport {
    /// Writes [`CSV_NAME`] (the [`mean_rows`]) into `out`, and with `update_committed` to
    /// [`COMMITTED_CSV`] too; the path written in `out`.
    pub fn write_accuracy(&self, out: &Path, update_committed: bool) -> Result<PathBuf> {
        let text = summary::csv_text(&mean_rows(&self.rows)?)?;
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
        let path = out.join(CSV_NAME);
        write_whole(&path, &text)?;
        if update_committed {
            write_whole(&workspace_root().join(COMMITTED_CSV), &text)?;
        }
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(truth: &str, car: &str, kind: &str, model_item: &str, rmse_deg: f64) -> Row {
        Row {
            manoeuvre: "step_steer".into(),
            car: car.into(),
            truth: truth.into(),
            estimator: format!("{kind}_{model_item}"),
            model: "A",
            estimator_item: kind.into(),
            model_item: model_item.into(),
            rmse: rmse_deg.to_radians(),
            max_error: 0.0,
            mean_nees: rmse_deg * 10.0,
            share_inside: 1.0,
            zero_baseline: 2f64.to_radians(),
            yardstick: 1f64.to_radians(),
            peak_sideslip: 0.0,
            max_speed_error: 0.0,
            max_vx_error: rmse_deg / 10.0,
            speed_nees: 1.0,
            speed_share_inside: 1.0,
            diverged: false,
        }
    }

    /// Two cars on the full vehicle and one on model 1: the file has the accuracy header, one row
    /// per truth, model and kind in that order, and each figure is the mean over the group's runs.
    #[test]
    fn the_csv_has_the_accuracy_header_and_the_mean_of_each_group() {
        let rows = vec![
            row("full vehicle", "escort", "ekf", "single_track_5_state", 0.5),
            row("full vehicle", "escort", "ekf", "single_track_grip", 0.1),
            row("full vehicle", "bmw", "ekf", "single_track_grip", 0.4),
            row("full vehicle", "bmw", "ukf", "single_track_grip", 0.3),
            row(
                "model 1",
                "escort (model 1)",
                "ekf",
                "single_track_grip",
                0.7,
            ),
        ];
        let dir = tempfile::tempdir().unwrap();
        let report = CampaignReport {
            rows,
            plots: Vec::new(),
            amplitudes: Vec::new(),
            manoeuvres: Vec::new(),
            seconds: 0.0,
            overrides: Vec::new(),
            cars: Vec::new(),
        };
        let path = report.write_accuracy(dir.path(), false).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "source,case,model,estimator,wheel_speeds,rmse_deg,nees,zero_rmse_deg,yardstick_rmse_deg,max_vx_error_mps"
        );
        let fields: Vec<Vec<&str>> = lines[1..].iter().map(|l| l.split(',').collect()).collect();
        let keys: Vec<[&str; 4]> = fields.iter().map(|f| [f[0], f[1], f[2], f[3]]).collect();
        assert_eq!(
            keys,
            [
                [
                    "simulated full vehicle (2 cars)",
                    "mean of 2 runs",
                    "grip",
                    "ekf"
                ],
                [
                    "simulated full vehicle (2 cars)",
                    "mean of 1 run",
                    "grip",
                    "ukf"
                ],
                [
                    "simulated full vehicle (2 cars)",
                    "mean of 1 run",
                    "model_a",
                    "ekf"
                ],
                ["simulated model 1 (1 car)", "mean of 1 run", "grip", "ekf"],
            ]
        );
        let number = |line: usize, column: usize| fields[line][column].parse::<f64>().unwrap();
        // the grip model's EKF on the full vehicle: RMSE (0.1 + 0.4) / 2, NEES (1 + 4) / 2
        assert!((number(0, 5) - 0.25).abs() < 1e-12, "{text}");
        assert!((number(0, 6) - 2.5).abs() < 1e-12, "{text}");
        assert!((number(0, 7) - 2.0).abs() < 1e-12, "{text}");
        assert!((number(0, 8) - 1.0).abs() < 1e-12, "{text}");
        assert!((number(0, 9) - 0.025).abs() < 1e-12, "{text}");
        assert_eq!(fields[0][4], "measured");
        assert!((number(3, 5) - 0.7).abs() < 1e-12, "{text}");
    }

    #[test]
    fn a_model_the_replay_study_does_not_name_is_refused() {
        let error = format!(
            "{:#}",
            mean_rows(&[row("full vehicle", "escort", "ekf", "model_c", 0.1)]).unwrap_err()
        );
        assert!(
            error.contains("\"model_c\"") && error.contains("single_track_grip"),
            "{error}"
        );
    }
}
