//! Seed 003's offline EM identification of model C (no FMU involved).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use harness::identify::{self, JobOverrides};

use super::{progress_bar, Stdout};

#[derive(Args, Debug)]
pub struct Identify {
    /// A data set (.csv with the columns time, dvx_ref_dt, steering_angle, vx_ref, vy_ref,
    /// yaw_rate, yaw_angle in SI units) or an identification file (.toml) that simulates one
    /// or points to a CSV; both formats in harness/scenarios/README.md.
    file: PathBuf,
    /// Output folder; the files go to <out>/<name>/.
    #[arg(long, default_value = "out/identify")]
    out: PathBuf,
    /// Noise seed of a simulated data set (the first one with --seeds).
    #[arg(long)]
    noise_seed: Option<u64>,
    /// Identify N simulated data sets (noise seeds from --noise-seed on) in parallel and
    /// report mean and spread.
    #[arg(long, value_name = "N")]
    seeds: Option<usize>,
    /// True parameters of a recorded data set, for relative errors: Csf,Csr,m/J,lf.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "CSF,CSR,M/J,LF",
        allow_hyphen_values = true
    )]
    truth: Option<Vec<f64>>,
}

impl Identify {
    pub fn run(self, stdout: Stdout) -> Result<()> {
        let overrides = JobOverrides {
            noise_seed: self.noise_seed,
            seeds: self.seeds,
            truth: parse_truth(self.truth)?,
        };
        let job = identify::load(&self.file, &overrides)?;
        let runs = match &job.data {
            identify::JobData::Simulated => job.config.noise_seeds.len(),
            identify::JobData::Recorded { .. } => 1,
        };
        writeln!(
            stdout,
            "{}: model C, {} samples at {} s, {} particles, start p0 = {:?}",
            job.name,
            job.config.samples,
            job.config.sample_time,
            job.config.filter.particle_count,
            job.config.start_parameters.as_slice()
        )?;
        let bar = progress_bar(runs as u64);
        bar.set_message(format!(
            "identifying ({runs} data set{})",
            if runs == 1 { "" } else { "s" }
        ));
        let outcome = identify::run(&job, &|| bar.inc(1));
        bar.finish_and_clear();
        let outcome = outcome?;
        write!(stdout, "{}", outcome.history_text())?;
        write!(stdout, "{}", outcome.summary_text())?;
        let written = identify::write_outputs(&outcome, &self.out)?;
        writeln!(stdout)?;
        writeln!(stdout, "plot:    {}", written.convergence_png.display())?;
        writeln!(stdout, "history: {}", written.history_csv.display())?;
        writeln!(stdout, "updates: {}", written.updates_csv.display())?;
        writeln!(stdout, "summary: {}", written.summary_txt.display())?;
        for data in &written.data_csv {
            writeln!(stdout, "data:    {}", data.display())?;
        }
        Ok(())
    }
}

/// `--truth` as the four parameters Csf, Csr, m/J, lf.
fn parse_truth(values: Option<Vec<f64>>) -> Result<Option<[f64; 4]>> {
    let Some(values) = values else {
        return Ok(None);
    };
    let truth = <[f64; 4]>::try_from(values.as_slice()).map_err(|_| {
        anyhow::anyhow!(
            "--truth: {} values given; expected 4 (Csf,Csr,m/J,lf), e.g. --truth 8.36,7.78,0.62,1.014",
            values.len()
        )
    })?;
    Ok(Some(truth))
}
