//! The studies behind the report: the demo and the sections it runs, each also on its own.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use fmi_master::recording::write_whole;
use fmi_master::report::Document;
use fmi_master::runner::Environment;
use harness::campaigns::Overrides;
use harness::consistency::ConsistencyStudy;
use harness::demo::{self, DemoOptions, ANSWER_PNG};
use harness::fmi_versions;
use harness::population::PopulationStudy;
use harness::summary;

use super::{fmu_dir_or_default, packaged_fmus, Stdout};

/// The cars of the mismatch campaigns a command runs (`--cars`), shared by `demo` and
/// `robustness`.
#[derive(Args, Debug)]
pub struct CampaignCars {
    /// Run the mismatch campaigns on these cars of harness/scenarios/campaigns/campaigns.toml
    /// only, by file stem (comma-separated, for example ford_escort): a quicker run of every
    /// manoeuvre and reference model; the report says which cars ran.
    #[arg(long, value_delimiter = ',', value_name = "CAR")]
    cars: Vec<String>,
}

#[derive(Args, Debug)]
pub struct Demo {
    /// Output folder (everything is written below it).
    #[arg(long, default_value = "out/demo")]
    out: PathBuf,
    /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
    /// Do not run `cargo run --release -p packaging`, use the FMUs as they are.
    #[arg(long)]
    no_package: bool,
    #[command(flatten)]
    cars: CampaignCars,
    /// Stop the model-mismatch study's EM after N SQUAREM cycles (the study allows 20): a
    /// quicker run; the report's mismatch section lists the cycles run.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    em_cycles: Option<u64>,
}

impl Demo {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let custom_dir = self.fmu_dir.is_some();
        let options = DemoOptions {
            env: Environment {
                fmu_dir: fmu_dir_or_default(self.fmu_dir),
                out_dir: self.out.clone(),
            },
            // A user-given FMU folder is used as it is.
            package: !self.no_package && !custom_dir,
            plots: true,
            campaign_cars: self.cars.cars,
            mismatch_em_cycles: self.em_cycles.map(|n| n as usize),
        };
        let (findings, outputs) = demo::run(&options)?;
        write!(stdout, "{}", demo::summary_table(&findings, &outputs))?;
        writeln!(stdout, "\nreport: {}", self.out.join("report.md").display())?;
        writeln!(stdout, "        {}", self.out.join("report.html").display())?;
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct Consistency {
    /// Output folder (the plot).
    #[arg(long, default_value = "out/consistency")]
    out: PathBuf,
    /// Monte Carlo runs (noise seeds 1 to N).
    #[arg(long, default_value_t = 40)]
    runs: usize,
    /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
}

impl Consistency {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let study = ConsistencyStudy {
            runs: self.runs,
            ..ConsistencyStudy::shipped()
        };
        let env = Environment {
            fmu_dir: fmu_dir_or_default(self.fmu_dir),
            out_dir: self.out,
        };
        let report = harness::consistency::run(&study, &env)?;
        let mut doc = Document::default();
        harness::consistency::section(&mut doc, &report);
        write!(stdout, "{}", doc.to_markdown())?;
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct Mismatch {
    /// Output folder (CSV of every run).
    #[arg(long, default_value = "out/mismatch")]
    out: PathBuf,
    /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
}

impl Mismatch {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let fmu_dir = packaged_fmus(self.fmu_dir)?;
        let report = harness::mismatch::run_shipped(&fmu_dir, &self.out, None)?;
        write!(stdout, "{}", report.summary())?;
        writeln!(stdout, "csv: {}", self.out.display())?;
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct Robustness {
    /// Output folder (report.md, report.html, campaigns_sideslip.csv and plots).
    #[arg(long, default_value = "out/robustness")]
    out: PathBuf,
    /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
    /// Set a parameter on every mismatch-campaign run, after the car's: an instance of
    /// harness/scenarios/campaigns/base.toml, instance.variable=value (repeatable; for
    /// example vehicle.gravity_in_accelerometers=true or EKF_G.ay_gain_std=0.1). The
    /// robustness cases run as shipped; the report says what was set.
    #[arg(long = "set", value_name = "INST.VAR=VALUE")]
    set: Vec<String>,
    /// Also write the campaigns' sideslip accuracy (campaigns_sideslip.csv, always written to
    /// the output folder) to docs/data/campaigns_sideslip.csv (not with --set or --cars).
    #[arg(long)]
    update_committed: bool,
    #[command(flatten)]
    cars: CampaignCars,
}

impl Robustness {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let overrides = Overrides::parse(&self.set)?.with_cars(&self.cars.cars);
        let fmu_dir = packaged_fmus(self.fmu_dir)?;
        let summary = harness::robustness::run_and_report(
            &fmu_dir,
            &self.out,
            &overrides,
            self.update_committed,
        )?;
        write!(stdout, "{summary}")?;
        writeln!(stdout, "report: {}", self.out.join("report.md").display())?;
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct Population {
    /// Output folder (report.md, report.html, population.csv).
    #[arg(long, default_value = "out/population")]
    out: PathBuf,
    /// Cars drawn per car file.
    #[arg(long, default_value_t = PopulationStudy::shipped().draws)]
    draws: usize,
    /// Standard deviation of each axle's side-force factor about 1 (default: the grip
    /// model's grip_std).
    #[arg(long, default_value_t = PopulationStudy::shipped().spread)]
    spread: f64,
    /// Seed of the draws.
    #[arg(long, default_value_t = PopulationStudy::shipped().seed)]
    seed: u64,
    /// Campaign manoeuvres to run (comma-separated; default: all of them).
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    manoeuvres: Vec<String>,
    /// Keep every run's CSV below <out>/runs/<car>_draw<NN>/ (about 0.8 MB a run).
    #[arg(long)]
    keep_runs: bool,
    /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
}

impl Population {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let study = PopulationStudy {
            draws: self.draws,
            spread: self.spread,
            seed: self.seed,
            manoeuvres: self.manoeuvres,
            keep_runs: self.keep_runs,
        };
        let fmu_dir = packaged_fmus(self.fmu_dir)?;
        let summary = harness::population::run_and_report(&study, &fmu_dir, &self.out)?;
        write!(stdout, "{summary}")?;
        writeln!(stdout, "report: {}", self.out.join("report.md").display())?;
        Ok(())
    }
}

#[derive(Args, Debug)]
pub struct FmiVersions {
    /// Output folder (fmi_versions.csv).
    #[arg(long, default_value = "out/fmi-versions")]
    out: PathBuf,
    /// Also write the rows to docs/data/fmi_versions.csv.
    #[arg(long)]
    update_committed: bool,
    /// Folder of the packaged FMUs, FMI 2.0 and FMI 3.0 (default: <target dir>/fmu, where
    /// packaging writes).
    #[arg(long)]
    fmu_dir: Option<PathBuf>,
}

impl FmiVersions {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let fmu_dir = packaged_fmus(self.fmu_dir)?;
        let report = fmi_versions::run_shipped(&fmu_dir, &self.out)?;
        let csv = report.write(&self.out, self.update_committed)?;
        writeln!(stdout, "{}", report.summary())?;
        writeln!(stdout, "csv: {}", csv.display())?;
        if self.update_committed {
            writeln!(stdout, "committed copy: {}", fmi_versions::COMMITTED_CSV)?;
        }
        report.check()
    }
}

#[derive(Args, Debug)]
pub struct Summary {
    /// Accuracy CSVs with the header harness::summary::HEADER, as the studies write them (the
    /// demo's accuracy_simulated.csv, a replay study's rows).
    #[arg(required = true)]
    rows: Vec<PathBuf>,
    /// Output folder (report.md, report.html and the figure).
    #[arg(long, default_value = "out/summary")]
    out: PathBuf,
}

impl Summary {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let rows = summary::read_rows(&self.rows)?;
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("creating {}", self.out.display()))?;
        let mut doc = Document::default();
        doc.heading(1, "Vehicle state estimation: how accurate, against what");
        summary::section(&mut doc, &rows, &self.out.join(ANSWER_PNG), ANSWER_PNG)?;
        write_whole(&self.out.join("report.md"), &doc.to_markdown())?;
        write_whole(
            &self.out.join("report.html"),
            &doc.to_html("Sideslip accuracy"),
        )?;
        writeln!(stdout, "{} rows", rows.len())?;
        writeln!(stdout, "report: {}", self.out.join("report.md").display())?;
        writeln!(stdout, "        {}", self.out.join("report.html").display())?;
        Ok(())
    }
}
