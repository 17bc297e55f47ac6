//! What a replay writes: the estimates CSV (time, the inputs fed in SI units, every FMU output,
//! every reference in SI units), the score table (RMSE, largest error, NEES where the FMU gives
//! a standard deviation, and for the sideslip the zero-sideslip baseline: the error of always
//! answering β = 0) and one plot of every estimate against its reference.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use fmi_master::plot::{draw_panels, Panel, Series};
use fmi_master::recording::partial_name;
use fmi_master::scoring::{score_state, StateScore};

use super::drive::Recording;
use super::Prepared;

/// Angles are scored and plotted in degrees.
fn display(unit: &str) -> (f64, String) {
    match unit {
        "rad" => (180.0 / std::f64::consts::PI, String::from("deg")),
        "rad/s" => (180.0 / std::f64::consts::PI, String::from("deg/s")),
        other => (1.0, other.to_string()),
    }
}

/// The name [`scores`] gives the estimator's rows (the zero-sideslip baseline has its own).
pub const ESTIMATOR: &str = "estimator";

/// The RMSE of the estimator's `label` among `scores`, if it was scored.
pub fn estimator_rmse(scores: &[StateScore], label: &str) -> Option<f64> {
    scores
        .iter()
        .find(|s| s.label == label && s.estimator == ESTIMATOR)
        .map(|s| s.rmse)
}

/// One score per reference channel, then the zero-sideslip baseline when a sideslip
/// reference exists. `rows` limits the scoring to part of the grid (a held-out segment).
pub fn scores(
    prepared: &Prepared,
    recording: &Recording,
    rows: std::ops::Range<usize>,
) -> Vec<StateScore> {
    let mut out = Vec::new();
    for (channel, truth) in &prepared.references {
        let name = &channel.target;
        let Some(estimate) = recording.column(&format!("{name}_est")) else {
            continue;
        };
        let std = recording
            .column(&format!("{name}_std"))
            .map(|s| &s[rows.clone()]);
        let (scale, unit) = display(&channel.si);
        out.push(score_state(
            name,
            ESTIMATOR,
            &unit,
            &truth[rows.clone()],
            &estimate[rows.clone()],
            std,
            scale,
        ));
        if name == "sideslip" {
            let zero = vec![0.0; rows.len()];
            out.push(score_state(
                "sideslip",
                "β = 0 baseline",
                &unit,
                &truth[rows.clone()],
                &zero,
                None,
                scale,
            ));
        }
    }
    out
}

/// The score table as Markdown.
pub fn score_table(scores: &[StateScore]) -> String {
    let mut text = String::from("| estimate | by | RMSE | max error | NEES (1 = consistent) | samples |\n| --- | --- | ---: | ---: | ---: | ---: |\n");
    for s in scores {
        let nees = s.nees.map_or(String::from("-"), |(n, _)| format!("{n:.2}"));
        text += &format!(
            "| {} | {} | {:.4} {} | {:.4} {} | {nees} | {} |\n",
            s.label, s.estimator, s.rmse, s.unit, s.max_abs, s.unit, s.samples
        );
    }
    text
}

/// Writes `<out>/estimates.csv` (under a temporary name, renamed when complete).
pub fn write_estimates(prepared: &Prepared, recording: &Recording, out: &Path) -> Result<PathBuf> {
    let path = out.join("estimates.csv");
    let partial = partial_name(&path);
    let write = || -> Result<()> {
        let mut file = std::io::BufWriter::new(std::fs::File::create(&partial)?);
        let mut header = vec![String::from("time")];
        header.extend(prepared.feeds.iter().map(|f| format!("input.{}", f.input)));
        header.extend(recording.names.iter().cloned());
        header.extend(
            prepared
                .references
                .iter()
                .map(|(c, _)| format!("reference.{}", c.target)),
        );
        writeln!(file, "{}", header.join(","))?;
        let columns: Vec<&[f64]> = prepared
            .feeds
            .iter()
            .map(|f| f.values.as_slice())
            .chain(recording.columns.iter().map(Vec::as_slice))
            .chain(prepared.references.iter().map(|(_, v)| v.as_slice()))
            .collect();
        let mut line = String::new();
        for n in 0..prepared.grid.rows {
            line.clear();
            line += &prepared.grid.time(n).to_string();
            for column in &columns {
                line.push(',');
                line += &column[n].to_string();
            }
            writeln!(file, "{line}")?;
        }
        file.flush()?;
        Ok(())
    };
    write()
        .and_then(|()| Ok(std::fs::rename(&partial, &path)?))
        .inspect_err(|_| {
            let _ = std::fs::remove_file(&partial);
        })
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

/// `<out>/replay.png`: every estimate that has a reference, against it.
pub fn plot(
    prepared: &Prepared,
    recording: &Recording,
    out: &Path,
    title: &str,
) -> Result<PathBuf> {
    let path = out.join("replay.png");
    let times = prepared.grid.times();
    let panels: Vec<Panel> = prepared
        .references
        .iter()
        .filter_map(|(channel, truth)| {
            let estimate = recording.column(&format!("{}_est", channel.target))?;
            let (scale, unit) = display(&channel.si);
            let scaled = |v: &[f64]| v.iter().map(|x| x * scale).collect::<Vec<_>>();
            Some(Panel {
                title: channel.target.clone(),
                x_label: String::from("time (s)"),
                y_label: unit,
                series: vec![
                    Series {
                        name: String::from("reference"),
                        x: times.clone(),
                        y: scaled(truth),
                        is_truth: true,
                    },
                    Series {
                        name: String::from("estimate"),
                        x: times.clone(),
                        y: scaled(estimate),
                        is_truth: false,
                    },
                ],
            })
        })
        .collect();
    if !panels.is_empty() {
        draw_panels(&path, title, &panels, 2)?;
    }
    Ok(path)
}
