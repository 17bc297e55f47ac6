//! Scenario files and FMUs as they are: one run, Monte Carlo runs, a campaign's chunk of cases,
//! an FMU's variables, the manoeuvre library.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use fmi_master::cosim::Plan;
use fmi_master::montecarlo;
use fmi_master::runner::{self, Environment};
use fmi_master::scenario::{Scenario, VarRef};
use harness::campaigns::Overrides;

use super::{fmu_dir_or_default, progress_bar, Stdout};
use crate::cases;

#[derive(Args, Debug)]
pub struct Run {
    /// Scenario file (TOML; format in harness/scenarios/README.md).
    scenario: PathBuf,
    /// Output folder.
    #[arg(long, default_value = "out/run")]
    out: PathBuf,
    /// Replaces {fmu_dir} in the scenario's FMU paths.
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
    /// Override a parameter: instance.variable=value (repeatable).
    #[arg(long = "set", value_name = "INST.VAR=VALUE")]
    set: Vec<String>,
    /// Skip the PNG plots.
    #[arg(long)]
    no_plots: bool,
}

impl Run {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let parsed = Scenario::from_file(&self.scenario)?;
        let overrides = Overrides::parse(&self.set)?.parsed;
        let env = Environment {
            fmu_dir: fmu_dir_or_default(self.fmu_dir),
            out_dir: self.out.join(&parsed.name),
        };
        let work = env.work_folder();
        let bar = progress_bar(1000);
        bar.set_message(parsed.name.clone());
        let output = runner::run_scenario(parsed, &env, &overrides, !self.no_plots, |f| {
            bar.set_position((f * 1000.0) as u64)
        });
        bar.finish_and_clear();
        drop(work);
        let output = output?;
        writeln!(
            stdout,
            "scenario {} ({} steps)",
            output.scenario.name,
            output.result.times.len() - 1
        )?;
        write!(stdout, "{}", runner::scores_table(&output.scores))?;
        writeln!(stdout, "csv: {}", output.csv.display())?;
        for p in &output.plots {
            writeln!(stdout, "plot: {}", p.display())?;
        }
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct Montecarlo {
    /// Scenario file.
    scenario: PathBuf,
    /// Number of runs (seeds first_seed .. first_seed + N - 1).
    #[arg(long, default_value_t = 20)]
    runs: usize,
    /// Seed of the first run.
    #[arg(long, default_value_t = 1)]
    first_seed: i32,
    /// Additional integer parameter to vary with the run (instance.variable, repeatable).
    #[arg(long = "seed-var", value_name = "INST.VAR")]
    seed_var: Vec<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Keep only these [[fmu]] instances and their connections (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "INSTANCE,...")]
    instances: Vec<String>,
    #[arg(long, default_value = "out/montecarlo")]
    out: PathBuf,
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
}

impl Montecarlo {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let mut parsed = Scenario::from_file(&self.scenario)?;
        cases::keep_instances(&mut parsed, &self.instances)?;
        let extra = self
            .seed_var
            .iter()
            .map(|s| {
                VarRef::parse(s)
                    .with_context(|| format!("--seed-var {s:?}: expected instance.variable"))
            })
            .collect::<Result<Vec<_>>>()?;
        let env = Environment {
            fmu_dir: fmu_dir_or_default(self.fmu_dir),
            out_dir: self.out.join(&parsed.name),
        };
        std::fs::create_dir_all(&env.out_dir)
            .with_context(|| format!("creating {}", env.out_dir.display()))?;
        let work = env.work_folder();
        // The same manoeuvre as `harness run`: a sine with dwell sized from a slowly increasing
        // steer is resolved once, before the runs, so they do not drive the library's
        // placeholder amplitude.
        if let Some((amplitude, angle)) = runner::resolve_sine_with_dwell(&mut parsed, &env)? {
            writeln!(
                stdout,
                "sine with dwell: 0.3 g at a steering angle of {:.3}°; amplitude {:.3}°",
                angle.to_degrees(),
                amplitude.to_degrees()
            )?;
        }
        let plan = Plan::new(parsed, &env.fmu_dir, &env.work_dir())?;
        let bar = progress_bar(self.runs as u64);
        bar.set_message(format!("{} runs", self.runs));
        let pool = {
            let mut builder = rayon::ThreadPoolBuilder::new();
            if let Some(n) = self.threads {
                builder = builder.num_threads(n);
            }
            builder.build().context("creating the worker threads")?
        };
        let summary = pool
            .install(|| montecarlo::run(&plan, self.runs, self.first_seed, &extra, &|| bar.inc(1)));
        bar.finish_and_clear();
        drop(plan);
        drop(work);
        let summary = summary?;
        let md = montecarlo::to_markdown(&summary);
        let path = env.out_dir.join("summary.md");
        std::fs::write(&path, &md).with_context(|| format!("writing {}", path.display()))?;
        let runs_csv = env.out_dir.join("runs.csv");
        cases::write_runs_csv(&runs_csv, self.first_seed, &summary.per_run)?;
        write!(stdout, "{md}")?;
        writeln!(stdout, "\nsummary: {}", path.display())?;
        writeln!(stdout, "every run's scores: {}", runs_csv.display())?;
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct Cases {
    /// Chunk file (format in harness/studies/src/cases.rs).
    chunk: PathBuf,
    /// Replaces {fmu_dir} in the scenario's FMU paths.
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
    /// Cases run at once (a Dask worker runs one chunk on one thread).
    #[arg(long, default_value_t = 1)]
    threads: usize,
}

impl Cases {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let fmu_dir = fmu_dir_or_default(self.fmu_dir);
        cases::run_chunk(&self.chunk, &fmu_dir, self.threads, stdout)
    }
}

#[derive(Args, Debug)]
pub struct Inspect {
    fmu: PathBuf,
    /// Scratch folder for the extraction (removed afterwards).
    #[arg(long, default_value = "out/inspect")]
    out: PathBuf,
}

impl Inspect {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let work = runner::WorkFolder::new(self.out.join(".fmu-work"));
        runner::inspect(&self.fmu, work.path(), stdout)
    }
}

/// Every library manoeuvre with the numbers this project chose.
pub fn manoeuvres(stdout: Stdout) -> Result<()> {
    for name in manoeuvres::LIBRARY {
        writeln!(
            stdout,
            "{name}\n    {}",
            manoeuvres::describe(name).unwrap_or_default()
        )?;
    }
    Ok(())
}
