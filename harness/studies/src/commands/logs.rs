//! Recorded drives: replay a log through the estimator FMU, fit the estimator to a car.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use harness::replay::fit::{self, FitModel, FitOptions};
use harness::replay::{self, ReplayOptions};

use super::{fmu_dir_or_default, Stdout};

#[derive(Args, Debug)]
pub struct Replay {
    /// The log: .csv with a header line, or .mf4.
    log: PathBuf,
    /// The map file (TOML): which column feeds which FMU input, units, signs, references.
    #[arg(long)]
    map: PathBuf,
    /// SSP parameter-value file (.ssv) of the car, applied before the map's parameters.
    #[arg(long)]
    parameters: Option<PathBuf>,
    #[arg(long, default_value = "out/replay")]
    out: PathBuf,
    /// Folder of the packaged FMUs (default: <target dir>/fmu).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
    /// Skip the PNG plot.
    #[arg(long)]
    no_plots: bool,
}

impl Replay {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let fmu_dir = fmu_dir_or_default(self.fmu_dir);
        let options = ReplayOptions {
            fmu: replay::estimator_path(None, &fmu_dir),
            log: self.log,
            map: self.map,
            parameters: self.parameters,
            out: self.out,
            plots: !self.no_plots,
        };
        let outcome = replay::replay(&options)?;
        writeln!(
            stdout,
            "replayed {} rows every {:.6} s in {:.2} s (reading, aligning, FMU)",
            outcome.prepared.grid.rows, outcome.prepared.grid.step, outcome.seconds
        )?;
        write!(stdout, "{}", replay::report::score_table(&outcome.scores))?;
        writeln!(stdout, "csv: {}", outcome.csv.display())?;
        if let Some(plot) = outcome.plot {
            writeln!(stdout, "plot: {}", plot.display())?;
        }
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct ReplayStudy {
    #[arg(long, default_value = "out/replay-study")]
    out: PathBuf,
    /// The particle filter too (about 1.8 ms a step).
    #[arg(long)]
    full: bool,
    /// Also write the rows to docs/data/mbds_replay.csv (needs --full).
    #[arg(long)]
    update_committed: bool,
    /// Folder of the packaged FMUs (default: <target dir>/fmu).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
}

impl ReplayStudy {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        replay::study::command(
            &fmu_dir_or_default(self.fmu_dir),
            self.out,
            self.full,
            self.update_committed,
            stdout,
        )
    }
}

#[derive(Args, Debug)]
pub struct Fit {
    log: PathBuf,
    #[arg(long)]
    map: PathBuf,
    /// Estimator model to fit: grip (the FMU's default, single track with grip states), a
    /// (single track, HSRI) or b (3-state two-track).
    #[arg(long, default_value = "grip")]
    model: String,
    /// The .ssv to write.
    #[arg(long)]
    out: PathBuf,
    /// SSP parameter-value file (.ssv) of the car to start from.
    #[arg(long)]
    parameters: Option<PathBuf>,
    /// Training segment t0:t1 in the log's seconds (default: the first two thirds).
    #[arg(long)]
    train: Option<String>,
    /// Held-out segment t2:t3 (default: the last third).
    #[arg(long)]
    validate: Option<String>,
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
}

impl Fit {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let fmu_dir = fmu_dir_or_default(self.fmu_dir);
        let options = FitOptions {
            fmu: replay::estimator_path(None, &fmu_dir),
            model: FitModel::parse(&self.model)?,
            train: segment(self.train.as_deref()).context("--train")?,
            validate: segment(self.validate.as_deref()).context("--validate")?,
            log: self.log,
            map: self.map,
            parameters: self.parameters,
            out: self.out,
        };
        let outcome = fit::fit(&options)?;
        write!(stdout, "{}", outcome.summary())?;
        writeln!(stdout, "parameters: {}", options.out.display())?;
        Ok(())
    }
}

fn segment(text: Option<&str>) -> Result<Option<(f64, f64)>> {
    text.map(fit::parse_segment).transpose()
}
