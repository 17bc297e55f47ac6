//! `harness`: the co-simulation master's command line. `harness --help` lists the commands; each
//! command is one function in [`commands`], this file only parses and dispatches.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

use fmi_master::runner;

mod cases;
mod commands;

#[derive(Parser, Debug)]
#[command(
    name = "harness",
    version,
    about = "FMI 2.0 Co-Simulation master: runs scenario files (FMUs, parameters, connections, manoeuvres), \
             scores estimators against the truth, writes CSV, PNG plots and reports"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Package the FMUs when missing or stale, run every seed experiment, write out/demo/report.md and report.html
    Demo(commands::studies::Demo),
    /// The report's opening answer on its own: sideslip RMSE per estimator and model against zero
    /// and the steady-state formula, from the accuracy CSVs the studies write
    Summary(commands::studies::Summary),
    /// Run one scenario file: CSV of every recorded signal, scores, plots
    Run(commands::scenarios::Run),
    /// Run a scenario with N noise seeds in parallel; mean and spread of every score, NEES/NIS consistency
    Montecarlo(commands::scenarios::Montecarlo),
    /// EM identification of seed 003's model C (p = [Csf, Csr, m/J, lf]) on a data set: prints the
    /// iteration history and the identified parameters, writes a convergence plot and CSV files
    Identify(commands::identify::Identify),
    /// Model mismatch (beyond the seeds): identify model A's front/rear cornering-stiffness scales
    /// by EM from a model-B ReferenceVehicle run, then score the EKF and UKF FMUs on held-out
    /// manoeuvres with scales 1 and with the identified scales
    Mismatch(commands::studies::Mismatch),
    /// Consistency where the model is right: Monte Carlo NEES and NIS of the seed-000 high-ay
    /// ramp's filters and their RMSE against the posterior Cramér-Rao bound
    Consistency(commands::studies::Consistency),
    /// Replay a recorded drive (CSV or ASAM MDF4 .mf4) through the estimator FMU: estimates CSV,
    /// plots against the log's reference channels, score table (format: harness/logs/README.md)
    Replay(commands::logs::Replay),
    /// The real track recording (harness/logs/mbds/) per model and estimator, with and without
    /// wheel speeds, scored on laps 2-6 beside zero, the steady-state formula and the published
    /// estimators: mbds_replay.md and mbds_replay.csv
    ReplayStudy(commands::logs::ReplayStudy),
    /// Fit the estimator to a car from a recorded drive: the grip model's sensor noise from the
    /// log, its tyre level by the log's sideslip reference (where the map names one) and its
    /// consistency; model A's per-axle cornering-stiffness scales by EM, model B's tyre level;
    /// held-out score against the starting parameters, which are kept when the fit makes it
    /// worse; writes an SSP parameter-value file (.ssv)
    Fit(commands::logs::Fit),
    /// The robustness cases (glitches, outages, standstill, out-of-range inputs) and the mismatch
    /// campaigns on real cars' parameter files: the demo's sections "Robustness" and "Mismatch
    /// campaigns" on their own
    Robustness(commands::studies::Robustness),
    /// Is the reported sideslip std honest over a population of cars? Every campaign car file
    /// drawn N times with each axle's tyre side force scaled by a factor from N(1, spread²); the
    /// campaign's manoeuvres and estimators on each; the NEES and RMSE over the cars
    Population(commands::studies::Population),
    /// Every mismatch-campaign run once through the FMI 2.0 archives and once through the FMI 3.0
    /// ones (*-fmi3.fmu beside them), every output of every instance recorded and compared bit for
    /// bit: fmi_versions.csv (one row per run) and a one-line summary; fails when any value differs
    FmiVersions(commands::studies::FmiVersions),
    /// Check an .fmu and list its variables
    Inspect(commands::scenarios::Inspect),
    /// List the manoeuvre library with the numbers this project chose
    Manoeuvres,
    /// Run one chunk of a campaign's cases (a TOML chunk file written by `python -m
    /// vse_campaign`) and print each case's scores as CSV rows case,field,value
    Cases(commands::scenarios::Cases),
}

/// Every command writes its output through `stdout` and returns write errors, so a reader that
/// goes away (`harness ... | head -1`) ends it with an `io::Error` of kind BrokenPipe (Rust
/// ignores SIGPIPE) instead of a panic in `println!`; that is no failure, the exit code is 0.
fn main() -> ExitCode {
    let cli = Cli::parse();
    let mut stdout = std::io::stdout();
    let outcome = execute(cli, &mut stdout).and_then(|()| Ok(stdout.flush()?));
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) if runner::is_broken_pipe(&error) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}

fn execute(cli: Cli, stdout: commands::Stdout) -> Result<()> {
    match cli.command {
        Command::Demo(command) => command.run(stdout),
        Command::Summary(command) => command.run(stdout),
        Command::Run(command) => command.run(stdout),
        Command::Montecarlo(command) => command.run(stdout),
        Command::Identify(command) => command.run(stdout),
        Command::Mismatch(command) => command.run(stdout),
        Command::Consistency(command) => command.run(stdout),
        Command::Replay(command) => command.run(stdout),
        Command::ReplayStudy(command) => command.run(stdout),
        Command::Fit(command) => command.run(stdout),
        Command::Robustness(command) => command.run(stdout),
        Command::Population(command) => command.run(stdout),
        Command::FmiVersions(command) => command.run(stdout),
        Command::Inspect(command) => command.run(stdout),
        Command::Manoeuvres => commands::scenarios::manoeuvres(stdout),
        Command::Cases(command) => command.run(stdout),
    }
}
