//! `harness`: the co-simulation master's command line. `harness --help` lists the commands.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use fmi_master::cosim::Plan;
use fmi_master::montecarlo;
use fmi_master::runner::{self, Environment};
use fmi_master::scenario::{Scenario, VarRef};
use harness::demo::{self, DemoOptions};
use harness::identify::{self, JobOverrides};

mod cases;

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
    Demo {
        /// Output folder (everything is written below it).
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
        #[arg(long)]
        fmu_dir: Option<PathBuf>,
        /// Do not run `cargo run --release -p packaging`, use the FMUs as they are.
        #[arg(long)]
        no_package: bool,
    },
    /// Run one scenario file: CSV of every recorded signal, scores, plots
    Run {
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
    },
    /// Run a scenario with N noise seeds in parallel; mean and spread of every score, NEES/NIS consistency
    Montecarlo {
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
    },
    /// EM identification of seed 003's model C (p = [Csf, Csr, m/J, lf]) on a data set: prints the
    /// iteration history and the identified parameters, writes a convergence plot and CSV files
    Identify {
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
    },
    /// Model mismatch (beyond the seeds): identify model A's front/rear cornering-stiffness scales
    /// by EM from a model-B ReferenceVehicle run, then score the EKF and UKF FMUs on held-out
    /// manoeuvres with scales 1 and with the identified scales
    Mismatch {
        /// Output folder (CSV of every run).
        #[arg(long, default_value = "out/mismatch")]
        out: PathBuf,
        /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
        #[arg(long)]
        fmu_dir: Option<PathBuf>,
    },
    /// Consistency where the model is right (issue 17): Monte Carlo NEES and NIS of the
    /// seed-000 high-ay ramp's filters and their RMSE against the posterior Cramér-Rao bound
    Consistency {
        /// Output folder (the plot).
        #[arg(long, default_value = "out/consistency")]
        out: PathBuf,
        /// Monte Carlo runs (noise seeds 1 to N).
        #[arg(long, default_value_t = 40)]
        runs: usize,
        /// Folder of the packaged FMUs (default: <target dir>/fmu, where packaging writes).
        #[arg(long)]
        fmu_dir: Option<PathBuf>,
    },
    /// Replay a recorded drive (CSV or ASAM MDF4 .mf4) through the estimator FMU: estimates CSV,
    /// plots against the log's reference channels, score table (format: harness/logs/README.md)
    Replay {
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
    },
    /// The real track recording (harness/logs/mbds/) per model and estimator, with and without
    /// wheel speeds, scored on laps 2-6 beside zero, the steady-state formula and the published
    /// estimators: mbds_replay.md and mbds_replay.csv
    ReplayStudy {
        #[arg(long, default_value = "out/replay-study")]
        out: PathBuf,
        /// The particle filter too (about 1.8 ms a step).
        #[arg(long)]
        full: bool,
        /// Also write the rows to docs/data/mbds_replay.csv (needs --full).
        #[arg(long)]
        update_committed: bool,
        #[arg(long)]
        fmu_dir: Option<PathBuf>,
    },
    /// Fit the estimator to a car from a recorded drive: the grip model's sensor noise from the
    /// log, its tyre level by the log's sideslip reference (where the map names one) and its
    /// consistency; model A's per-axle cornering-stiffness scales by EM, model B's tyre level;
    /// held-out score against the starting parameters, which are kept when the fit makes it
    /// worse; writes an SSP parameter-value file (.ssv)
    Fit {
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
    },
    /// Issue 12's robustness cases and the mismatch campaigns (issues 13, 17) on real cars'
    /// parameter files, the demo's sections "Robustness" and "Mismatch campaigns" on their own
    Robustness {
        /// Output folder (report.md, report.html, CSV and plots).
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
    },
    /// Issue 17 point 3 over a population of cars: every campaign car file drawn N times with
    /// each axle's tyre side force scaled by a factor from N(1, spread²); the campaign's
    /// manoeuvres and estimators on each; the NEES and RMSE over the cars
    Population {
        /// Output folder (report.md, report.html, population.csv).
        #[arg(long, default_value = "out/population")]
        out: PathBuf,
        /// Cars drawn per car file.
        #[arg(long, default_value_t = harness::population::PopulationStudy::shipped().draws)]
        draws: usize,
        /// Standard deviation of each axle's side-force factor about 1 (default: the grip
        /// model's grip_std).
        #[arg(long, default_value_t = harness::population::PopulationStudy::shipped().spread)]
        spread: f64,
        /// Seed of the draws.
        #[arg(long, default_value_t = harness::population::PopulationStudy::shipped().seed)]
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
    },
    /// Check an .fmu and list its variables
    Inspect {
        fmu: PathBuf,
        /// Scratch folder for the extraction (removed afterwards).
        #[arg(long, default_value = "out/inspect")]
        out: PathBuf,
    },
    /// List the manoeuvre library with the numbers this project chose
    Manoeuvres,
    /// Run one chunk of a campaign's cases (a TOML chunk file written by `python -m
    /// vse_campaign`) and print each case's scores as CSV rows case,field,value
    Cases {
        /// Chunk file (format in harness/studies/src/cases.rs).
        chunk: PathBuf,
        /// Replaces {fmu_dir} in the scenario's FMU paths.
        #[arg(long)]
        fmu_dir: Option<PathBuf>,
        /// Cases run at once (a Dask worker runs one chunk on one thread).
        #[arg(long, default_value_t = 1)]
        threads: usize,
    },
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

fn execute(cli: Cli, stdout: &mut (dyn Write + Send)) -> Result<()> {
    match cli.command {
        Command::Demo {
            out,
            fmu_dir,
            no_package,
        } => {
            let custom_dir = fmu_dir.is_some();
            let env = Environment {
                fmu_dir: absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir),
                out_dir: out.clone(),
            };
            let options = DemoOptions {
                env,
                // A user-given FMU folder is used as it is.
                package: !no_package && !custom_dir,
                plots: true,
            };
            let (findings, outputs) = demo::run(&options)?;
            write!(stdout, "{}", demo::summary_table(&findings, &outputs))?;
            writeln!(stdout, "\nreport: {}", out.join("report.md").display())?;
            writeln!(stdout, "        {}", out.join("report.html").display())?;
            Ok(())
        }
        Command::Consistency { out, runs, fmu_dir } => {
            let fmu_dir = absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir);
            let study = harness::consistency::ConsistencyStudy {
                runs,
                ..harness::consistency::ConsistencyStudy::shipped()
            };
            let env = Environment {
                fmu_dir,
                out_dir: out,
            };
            let report = harness::consistency::run(&study, &env)?;
            let mut doc = fmi_master::report::Document::default();
            harness::consistency::section(&mut doc, &report);
            write!(stdout, "{}", doc.to_markdown())?;
            Ok(())
        }
        Command::Mismatch { out, fmu_dir } => {
            let fmu_dir = packaged_fmus(fmu_dir)?;
            let report = harness::mismatch::run_shipped(&fmu_dir, &out)?;
            write!(stdout, "{}", report.summary())?;
            writeln!(stdout, "csv: {}", out.display())?;
            Ok(())
        }
        Command::Robustness { out, fmu_dir, set } => {
            let overrides = harness::campaigns::Overrides::parse(&set)?;
            let fmu_dir = packaged_fmus(fmu_dir)?;
            write!(
                stdout,
                "{}",
                harness::robustness::run_and_report(&fmu_dir, &out, &overrides)?
            )?;
            writeln!(stdout, "report: {}", out.join("report.md").display())?;
            Ok(())
        }
        Command::Population {
            out,
            draws,
            spread,
            seed,
            manoeuvres,
            keep_runs,
            fmu_dir,
        } => {
            let study = harness::population::PopulationStudy {
                draws,
                spread,
                seed,
                manoeuvres,
                keep_runs,
            };
            let fmu_dir = packaged_fmus(fmu_dir)?;
            write!(
                stdout,
                "{}",
                harness::population::run_and_report(&study, &fmu_dir, &out)?
            )?;
            writeln!(stdout, "report: {}", out.join("report.md").display())?;
            Ok(())
        }
        Command::Run {
            scenario,
            out,
            fmu_dir,
            set,
            no_plots,
        } => {
            let parsed = Scenario::from_file(&scenario)?;
            let overrides = harness::campaigns::Overrides::parse(&set)?.parsed;
            let env = Environment {
                fmu_dir: absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir),
                out_dir: out.join(&parsed.name),
            };
            let work = env.work_folder();
            let bar = progress_bar(1000);
            bar.set_message(parsed.name.clone());
            let output = runner::run_scenario(parsed, &env, &overrides, !no_plots, |f| {
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
        Command::Montecarlo {
            scenario,
            runs,
            first_seed,
            seed_var,
            threads,
            instances,
            out,
            fmu_dir,
        } => {
            let mut parsed = Scenario::from_file(&scenario)?;
            cases::keep_instances(&mut parsed, &instances)?;
            let extra = seed_var
                .iter()
                .map(|s| {
                    VarRef::parse(s)
                        .with_context(|| format!("--seed-var {s:?}: expected instance.variable"))
                })
                .collect::<Result<Vec<_>>>()?;
            let env = Environment {
                fmu_dir: absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir),
                out_dir: out.join(&parsed.name),
            };
            std::fs::create_dir_all(&env.out_dir)
                .with_context(|| format!("creating {}", env.out_dir.display()))?;
            let work = env.work_folder();
            // The same manoeuvre as `harness run`: a sine with dwell sized from a slowly
            // increasing steer is resolved once, before the runs (it used to be skipped here,
            // so the runs drove the library's default amplitude instead).
            if let Some((amplitude, angle)) = runner::resolve_sine_with_dwell(&mut parsed, &env)? {
                writeln!(
                    stdout,
                    "sine with dwell: 0.3 g at a steering angle of {:.3}°; amplitude {:.3}°",
                    angle.to_degrees(),
                    amplitude.to_degrees()
                )?;
            }
            let plan = Plan::new(parsed, &env.fmu_dir, &env.work_dir())?;
            let bar = progress_bar(runs as u64);
            bar.set_message(format!("{} runs", runs));
            let pool = {
                let mut builder = rayon::ThreadPoolBuilder::new();
                if let Some(n) = threads {
                    builder = builder.num_threads(n);
                }
                builder.build().context("creating the worker threads")?
            };
            let summary =
                pool.install(|| montecarlo::run(&plan, runs, first_seed, &extra, &|| bar.inc(1)));
            bar.finish_and_clear();
            drop(plan);
            drop(work);
            let summary = summary?;
            let md = montecarlo::to_markdown(&summary);
            let path = env.out_dir.join("summary.md");
            std::fs::write(&path, &md).with_context(|| format!("writing {}", path.display()))?;
            let runs_csv = env.out_dir.join("runs.csv");
            cases::write_runs_csv(&runs_csv, first_seed, &summary.per_run)?;
            write!(stdout, "{md}")?;
            writeln!(stdout, "\nsummary: {}", path.display())?;
            writeln!(stdout, "every run's scores: {}", runs_csv.display())?;
            Ok(())
        }
        Command::Identify {
            file,
            out,
            noise_seed,
            seeds,
            truth,
        } => {
            let truth = match truth {
                None => None,
                Some(values) => Some(<[f64; 4]>::try_from(values.as_slice()).map_err(|_| {
                    anyhow::anyhow!(
                        "--truth: {} values given; expected 4 (Csf,Csr,m/J,lf), e.g. --truth 8.36,7.78,0.62,1.014",
                        values.len()
                    )
                })?),
            };
            let overrides = JobOverrides {
                noise_seed,
                seeds,
                truth,
            };
            let job = identify::load(&file, &overrides)?;
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
            let written = identify::write_outputs(&outcome, &out)?;
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
        Command::Replay {
            log,
            map,
            parameters,
            out,
            fmu_dir,
            no_plots,
        } => {
            let fmu_dir = absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir);
            let options = harness::replay::ReplayOptions {
                fmu: harness::replay::estimator_path(None, &fmu_dir),
                log,
                map,
                parameters,
                out,
                plots: !no_plots,
            };
            let outcome = harness::replay::replay(&options)?;
            writeln!(
                stdout,
                "replayed {} rows every {:.6} s in {:.2} s (reading, aligning, FMU)",
                outcome.prepared.grid.rows, outcome.prepared.grid.step, outcome.seconds
            )?;
            write!(
                stdout,
                "{}",
                harness::replay::report::score_table(&outcome.scores)
            )?;
            writeln!(stdout, "csv: {}", outcome.csv.display())?;
            if let Some(plot) = outcome.plot {
                writeln!(stdout, "plot: {}", plot.display())?;
            }
            Ok(())
        }
        Command::ReplayStudy {
            out,
            full,
            update_committed,
            fmu_dir,
        } => harness::replay::study::command(
            &absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir),
            out,
            full,
            update_committed,
            stdout,
        ),
        Command::Fit {
            log,
            map,
            model,
            out,
            parameters,
            train,
            validate,
            fmu_dir,
        } => {
            let fmu_dir = absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir);
            let options = harness::replay::fit::FitOptions {
                fmu: harness::replay::estimator_path(None, &fmu_dir),
                model: harness::replay::fit::FitModel::parse(&model)?,
                train: train
                    .as_deref()
                    .map(harness::replay::fit::parse_segment)
                    .transpose()
                    .context("--train")?,
                validate: validate
                    .as_deref()
                    .map(harness::replay::fit::parse_segment)
                    .transpose()
                    .context("--validate")?,
                log,
                map,
                parameters,
                out,
            };
            let outcome = harness::replay::fit::fit(&options)?;
            write!(stdout, "{}", outcome.summary())?;
            writeln!(stdout, "parameters: {}", options.out.display())?;
            Ok(())
        }
        Command::Inspect { fmu, out } => {
            let work = runner::WorkFolder::new(out.join(".fmu-work"));
            runner::inspect(&fmu, work.path(), stdout)
        }
        Command::Cases {
            chunk,
            fmu_dir,
            threads,
        } => {
            let fmu_dir = absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir);
            cases::run_chunk(&chunk, &fmu_dir, threads, stdout)
        }
        Command::Manoeuvres => {
            for name in manoeuvres::LIBRARY {
                writeln!(
                    stdout,
                    "{name}\n    {}",
                    manoeuvres::describe(name).unwrap_or_default()
                )?;
            }
            Ok(())
        }
    }
}

/// The FMU folder of a study: the one given (used as it is), else the project's own, packaged
/// first when missing or stale, as `demo` does.
fn packaged_fmus(fmu_dir: Option<PathBuf>) -> Result<PathBuf> {
    let custom_dir = fmu_dir.is_some();
    let fmu_dir = absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir);
    demo::ensure_fmus(&fmu_dir, !custom_dir)?;
    Ok(fmu_dir)
}

/// An FMU folder given on the command line is relative to the working directory, not to the
/// scenario file.
fn absolute(dir: Option<PathBuf>) -> Option<PathBuf> {
    dir.map(|d| std::path::absolute(&d).unwrap_or(d))
}

fn progress_bar(length: u64) -> ProgressBar {
    let bar = ProgressBar::new(length);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}
