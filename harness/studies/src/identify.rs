//! `harness identify`: the EM parameter identification of seed 003 (model C, `p = [Csf, Csr, m/J,
//! lf]`, 003: §3.1-3.2) on a data set — a CSV of inputs and measurements, or an identification
//! file (TOML) that simulates one with the seed's vehicle and noise — with the history of every
//! iteration, a convergence plot (like 003 fig. 3.11) and CSV files of the history.
//!
//! Architecture: this module (and the demo's seed-003 section that calls it) links the
//! `estimation` library for this offline identification only. Nothing here is an FMU or talks
//! FMI; the co-simulation master (`cosim`, `runner`) couples the FMUs through FMI alone and never
//! links the FMU crates.
//!
//! The identification itself (particle filter, smoother, EM) is `estimation::identification::
//! seed003`; this module reads and checks the data, runs one identification per data set (noise
//! seeds in parallel) and presents the results.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::seed003::{
    self, mean_and_spread, Seed003Config, SEED_TABLE_3_1_FILTER, SEED_TABLE_3_1_SMOOTHER,
    SEED_TABLE_3_2_IDENTIFIED, SEED_TABLE_3_2_RELATIVE_PERCENT,
};
use anyhow::{anyhow, bail, Context, Result};
use estimation::identification::{EmResult, EmSchedule};
use estimation::models::rear_axle::{
    seed_identification_start, seed_parameters, RearAxleModel, RearAxleParameterVector,
    PARAMETER_NAMES,
};
use estimation::particle::Proposal;
use nalgebra::SVector;
use rayon::prelude::*;

use fmi_master::plot::{self, Panel, Series};

mod file;

use file::{
    AtLeast, IdentificationFile, IdentificationSection, NoiseSeeds, ParameterVector, PositiveReal,
    ProposalName, ScheduleName, SimulationSection,
};

/// One column of the identification CSV.
#[derive(Debug, Clone, Copy)]
pub struct CsvColumn {
    pub name: &'static str,
    pub unit: &'static str,
    pub meaning: &'static str,
}

/// The columns of the identification CSV, in the order `harness identify` writes them (any order
/// is read). Model C's input `u = [dVx_ref/dt, δ, Vx_ref]` and measurement `y = [Vy_ref, ω, φ]`
/// (003: 2.18-2.23), all in SI units.
pub const CSV_COLUMNS: [CsvColumn; 7] = [
    CsvColumn {
        name: "time",
        unit: "s",
        meaning: "sample time t_k, strictly increasing and uniformly spaced",
    },
    CsvColumn {
        name: "dvx_ref_dt",
        unit: "m/s²",
        meaning: "input: longitudinal acceleration of the rear-axle centre dVx_ref/dt",
    },
    CsvColumn {
        name: "steering_angle",
        unit: "rad",
        meaning: "input: road-wheel steering angle δ, positive left",
    },
    CsvColumn {
        name: "vx_ref",
        unit: "m/s",
        meaning: "input: longitudinal velocity of the rear-axle centre Vx_ref",
    },
    CsvColumn {
        name: "vy_ref",
        unit: "m/s",
        meaning:
            "measurement: lateral velocity of the rear-axle centre Vy_ref (empty or NaN = missing)",
    },
    CsvColumn {
        name: "yaw_rate",
        unit: "rad/s",
        meaning: "measurement: yaw rate ω (empty or NaN = missing)",
    },
    CsvColumn {
        name: "yaw_angle",
        unit: "rad",
        meaning: "measurement: yaw angle φ (empty or NaN = missing)",
    },
];

/// The first measurement column; the ones before it (time and inputs) cannot be missing.
const FIRST_MEASUREMENT_COLUMN: usize = 4;

/// Relative deviation of one time step from the mean step that still counts as uniform sampling:
/// model C is discretised with one sample time (003: A.32), so the data must have one too.
const SAMPLE_TIME_TOLERANCE: f64 = 0.01;

fn column_list() -> String {
    CSV_COLUMNS
        .iter()
        .map(|c| c.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// A data set of model C: input `k` is held from `times[k]` to `times[k + 1]`, measurement `k` is
/// taken at `times[k]`; a NaN measurement entry is missing.
#[derive(Debug, Clone, PartialEq)]
pub struct DataSet {
    pub times: Vec<f64>,
    pub inputs: Vec<[f64; 3]>,
    pub measurements: Vec<[f64; 3]>,
    pub sample_time: f64,
}

impl DataSet {
    pub fn len(&self) -> usize {
        self.times.len()
    }

    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }
}

/// Reads an identification CSV (columns [`CSV_COLUMNS`], header line first, `#` starts a comment
/// line). Every error names the file, the line and the column, and what was expected.
pub fn read_csv(path: &Path) -> Result<DataSet> {
    let file = std::fs::File::open(path)
        .with_context(|| format!("cannot read the data set {}", path.display()))?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(file);
    let name = path.display();
    let mut records = reader.records();
    let header = match records.next() {
        None => bail!(
            "{name}: the file is empty; expected a header line with the columns {}",
            column_list()
        ),
        Some(record) => record.map_err(|e| csv_error(path, &e))?,
    };
    let header_line = header.position().map_or(1, |p| p.line());
    // For each of CSV_COLUMNS, its position in the file.
    let mut position: [Option<usize>; 7] = [None; 7];
    for (index, field) in header.iter().enumerate() {
        let Some(known) = CSV_COLUMNS.iter().position(|c| c.name == field) else {
            bail!(
                "{name}: line {header_line}, column {}: unknown column {field:?}; expected the columns {} (any order, SI units)",
                index + 1,
                column_list()
            );
        };
        if let Some(first) = position[known] {
            bail!(
                "{name}: line {header_line}, column {}: column {field:?} appears twice (also column {}); expected each of {} once",
                index + 1,
                first + 1,
                column_list()
            );
        }
        position[known] = Some(index);
    }
    for (column, found) in CSV_COLUMNS.iter().zip(&position) {
        if found.is_none() {
            bail!(
                "{name}: line {header_line}: missing column {:?} ({} in {}); expected the columns {}",
                column.name,
                column.meaning,
                column.unit,
                column_list()
            );
        }
    }
    let position = position.map(|p| p.unwrap_or_default());
    let mut data = DataSet {
        times: Vec::new(),
        inputs: Vec::new(),
        measurements: Vec::new(),
        sample_time: f64::NAN,
    };
    let mut lines = Vec::new();
    for record in records {
        let record = record.map_err(|e| csv_error(path, &e))?;
        let line = record.position().map_or(0, |p| p.line());
        if record.len() != header.len() {
            bail!(
                "{name}: line {line}: {} fields, expected {} like the header ({})",
                record.len(),
                header.len(),
                header.iter().collect::<Vec<_>>().join(", ")
            );
        }
        let mut values = [0.0; 7];
        for (known, column) in CSV_COLUMNS.iter().enumerate() {
            let index = position[known];
            values[known] = parse_cell(
                &record[index],
                known >= FIRST_MEASUREMENT_COLUMN,
                column,
                &|message| {
                    format!(
                        "{name}: line {line}, column {} ({:?}): {message}",
                        index + 1,
                        column.name
                    )
                },
            )?;
        }
        data.times.push(values[0]);
        data.inputs.push([values[1], values[2], values[3]]);
        data.measurements.push([values[4], values[5], values[6]]);
        lines.push(line);
    }
    if data.len() < 2 {
        bail!(
            "{name}: {} data rows; expected at least 2 samples below the header",
            data.len()
        );
    }
    let time_column = position[0] + 1;
    // (line of the later sample, previous time, time) for every step.
    let steps = || {
        lines[1..]
            .iter()
            .zip(data.times.windows(2))
            .map(|(line, pair)| (*line, pair[0], pair[1]))
    };
    for (line, previous, time) in steps() {
        if time <= previous {
            bail!(
                "{name}: line {line}, column {time_column} (\"time\"): {time} is not after the previous sample's {previous}; expected strictly increasing times"
            );
        }
    }
    let sample_time = (data.times[data.len() - 1] - data.times[0]) / (data.len() - 1) as f64;
    for (line, previous, time) in steps() {
        let step = time - previous;
        if (step - sample_time).abs() > SAMPLE_TIME_TOLERANCE * sample_time {
            bail!(
                "{name}: line {line}, column {time_column} (\"time\"): the step from the previous sample is {step} s, but the mean step is {sample_time} s; expected uniformly spaced samples (within {} %), because model C is discretised with one sample time",
                100.0 * SAMPLE_TIME_TOLERANCE
            );
        }
    }
    if !data
        .measurements
        .iter()
        .any(|m| m.iter().all(|v| v.is_finite()))
    {
        bail!(
            "{name}: no row has all three measurements (vy_ref, yaw_rate, yaw_angle); expected at least one complete row, where the particle cloud starts"
        );
    }
    data.sample_time = sample_time;
    Ok(data)
}

fn csv_error(path: &Path, error: &csv::Error) -> anyhow::Error {
    match error.position() {
        Some(p) => anyhow!("{}: line {}: {error}", path.display(), p.line()),
        None => anyhow!("{}: {error}", path.display()),
    }
}

/// One cell: a finite number; a measurement may also be empty or NaN (missing).
fn parse_cell(
    text: &str,
    may_be_missing: bool,
    column: &CsvColumn,
    located: &dyn Fn(String) -> String,
) -> Result<f64> {
    let expected = format!("expected {} in {}", column.meaning, column.unit);
    if text.is_empty() {
        if may_be_missing {
            return Ok(f64::NAN);
        }
        bail!(located(format!(
            "empty; {expected} (only measurements may be missing)"
        )));
    }
    let value: f64 = text
        .parse()
        .map_err(|_| anyhow!(located(format!("{text:?} is not a number; {expected}"))))?;
    if value.is_nan() && may_be_missing {
        return Ok(value);
    }
    if !value.is_finite() {
        bail!(located(format!(
            "{text:?} is not a finite number; {expected}{}",
            if may_be_missing {
                " (empty or NaN for a missing measurement)"
            } else {
                ""
            }
        )));
    }
    Ok(value)
}

/// Writes a CSV file: the header, then the rows.
fn write_table(
    path: &Path,
    header: &[String],
    rows: impl IntoIterator<Item = Vec<String>>,
) -> Result<()> {
    let mut writer =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    writer.write_record(header)?;
    for row in rows {
        writer.write_record(&row)?;
    }
    writer
        .flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Writes a data set in the format [`read_csv`] reads (shortest round-trip number format, a
/// missing measurement as an empty cell).
pub fn write_csv(path: &Path, data: &DataSet) -> Result<()> {
    let header = CSV_COLUMNS.map(|c| c.name.to_string());
    let rows = (0..data.len()).map(|k| {
        let [a, d, vx] = data.inputs[k];
        let [vy, r, psi] = data.measurements[k];
        [data.times[k], a, d, vx, vy, r, psi]
            .map(number_or_empty)
            .to_vec()
    });
    write_table(path, &header, rows)
}

/// A number in the shortest form that reads back to the same value; NaN as an empty cell.
fn number_or_empty(value: f64) -> String {
    if value.is_nan() {
        String::new()
    } else {
        value.to_string()
    }
}

// ---------------------------------------------------------------------------------------------
// Identification files (TOML)

/// Where the data come from.
#[derive(Debug, Clone, PartialEq)]
pub enum JobData {
    /// Simulated with model C, one data set per noise seed of `config.noise_seeds`.
    Simulated,
    /// Read from a CSV file.
    Recorded { path: PathBuf, data: DataSet },
}

/// A checked identification: the data and every setting.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    pub name: String,
    pub description: String,
    /// The file the job was read from.
    pub source: PathBuf,
    pub data: JobData,
    /// Everything the library needs; `samples`, `sample_time`, `true_parameters` and
    /// `noise_seeds` describe the simulation (for recorded data: its sample time and length).
    pub config: Seed003Config,
    /// The true parameters, when known.
    pub truth: Option<[f64; 4]>,
}

/// Command-line settings that override the file.
#[derive(Debug, Clone, Default)]
pub struct JobOverrides {
    /// `--noise-seed`: the (first) noise seed of a simulated data set.
    pub noise_seed: Option<u64>,
    /// `--seeds N`: N consecutive noise seeds from the first.
    pub seeds: Option<usize>,
    /// `--truth`: the true parameters of a recorded data set.
    pub truth: Option<[f64; 4]>,
}

/// Loads `path`: a `.csv` data set (seed-003 settings) or a `.toml` identification file.
pub fn load(path: &Path, overrides: &JobOverrides) -> Result<Job> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut job = match extension.as_deref() {
        Some("csv") => {
            let data = read_csv(path)?;
            let config = Seed003Config {
                samples: data.len(),
                sample_time: data.sample_time,
                ..Seed003Config::default()
            };
            Job {
                name: path
                    .file_stem()
                    .map_or_else(|| "data".into(), |s| s.to_string_lossy().to_string()),
                description: format!("recorded data set {}", path.display()),
                source: path.to_path_buf(),
                data: JobData::Recorded {
                    path: path.to_path_buf(),
                    data,
                },
                config,
                truth: None,
            }
        }
        Some("toml") => load_toml(path)?,
        _ => bail!(
            "{}: expected a data set (.csv, columns {}) or an identification file (.toml)",
            path.display(),
            column_list()
        ),
    };
    apply_overrides(&mut job, overrides)?;
    Ok(job)
}

fn apply_overrides(job: &mut Job, overrides: &JobOverrides) -> Result<()> {
    match job.data {
        JobData::Simulated => {
            if overrides.truth.is_some() {
                bail!(
                    "--truth: {} simulates its data set, whose truth is `simulation.true_parameters`",
                    job.source.display()
                );
            }
            let first = overrides.noise_seed.unwrap_or(job.config.noise_seeds[0]);
            match overrides.seeds {
                Some(0) => bail!("--seeds: expected at least 1 noise seed"),
                Some(count) => {
                    job.config.noise_seeds =
                        (0..count as u64).map(|i| first.wrapping_add(i)).collect()
                }
                None if overrides.noise_seed.is_some() => job.config.noise_seeds = vec![first],
                None => {}
            }
        }
        JobData::Recorded { .. } => {
            if overrides.noise_seed.is_some() || overrides.seeds.is_some() {
                bail!(
                    "--noise-seed/--seeds: {} is a recorded data set; noise seeds apply to a simulated one (an identification file with [simulation])",
                    job.source.display()
                );
            }
            if let Some(truth) = overrides.truth {
                check_parameters(&job.source, "--truth", &truth, job.config.sample_time)?;
                job.truth = Some(truth);
            }
        }
    }
    Ok(())
}

fn field_error(path: &Path, field: &str, message: impl std::fmt::Display) -> anyhow::Error {
    anyhow!(
        "identification file {}: field `{field}`: {message}",
        path.display()
    )
}

/// `p` must be a valid model-C parameter vector (finite, positive, `0 < lf < wheelbase`).
fn check_parameters(path: &Path, field: &str, p: &[f64; 4], sample_time: f64) -> Result<()> {
    if let Some(j) = p.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(field_error(
            path,
            field,
            format!(
                "{} = {} must be a positive finite number",
                PARAMETER_NAMES[j], p[j]
            ),
        ));
    }
    let model =
        RearAxleModel::seed_vehicle(sample_time).map_err(|e| field_error(path, field, e))?;
    model
        .with_parameter_values(&RearAxleParameterVector::from(*p))
        .map_err(|e| field_error(path, field, e))?;
    Ok(())
}

fn load_toml(path: &Path) -> Result<Job> {
    let file = read_identification_file(path)?;
    let mut config = Seed003Config::default();
    let section = &file.identification;
    section.apply(path, &mut config)?;
    let (data, truth) = match (&file.data, &file.simulation) {
        (Some(_), Some(_)) => {
            return Err(field_error(
                path,
                "data",
                "both `data` and [simulation] are given; expected one source of the data set",
            ))
        }
        (None, None) => {
            return Err(field_error(
                path,
                "data",
                "neither `data` (a CSV data set) nor [simulation] is given; expected one of them",
            ))
        }
        (Some(csv), None) => recorded_data(path, csv, file.true_parameters, &mut config)?,
        (None, Some(simulation)) => {
            if file.true_parameters.is_some() {
                return Err(field_error(
                    path,
                    "true_parameters",
                    "only for a recorded data set (`data`); a simulated one has `simulation.true_parameters`",
                ));
            }
            simulation.apply(path, &mut config)?
        }
    };
    if let Some(ParameterVector(start)) = section.start {
        check_parameters(path, "identification.start", &start, config.sample_time)?;
        config.start_parameters = RearAxleParameterVector::from(start);
    }
    Ok(Job {
        name: file.name.0,
        description: file.description,
        source: path.to_path_buf(),
        data,
        config,
        truth,
    })
}

/// The file parsed by serde into its checked types (unknown fields, wrong types and refused
/// values named with their key, line and column); a co-simulation scenario given by mistake is
/// named as such.
fn read_identification_file(path: &Path) -> Result<IdentificationFile> {
    let text = std::fs::read_to_string(path).with_context(|| {
        format!(
            "identification file {}: cannot read the file",
            path.display()
        )
    })?;
    file::parse(&text).map_err(|error| {
        let mut message = error.to_string();
        if text.contains("[[fmu]]") {
            message += "\n(this looks like a co-simulation scenario for `harness run`; `harness identify` reads identification files, harness/scenarios/README.md)";
        }
        anyhow!("identification file {}: {message}", path.display())
    })
}

/// Standard deviations as the library takes them.
fn std_vector<T: Copy>(std: &[T; 3], value: impl Fn(T) -> f64) -> SVector<f64, 3> {
    SVector::from(std.map(value))
}

impl IdentificationSection {
    /// Writes the `[identification]` settings into `config` (seed 003's values where a field is
    /// absent); `max_sweeps` only goes with the full schedule.
    fn apply(&self, path: &Path, config: &mut Seed003Config) -> Result<()> {
        if let Some(AtLeast(n)) = self.particles {
            config.filter.particle_count = n;
        }
        if let Some(seed) = self.filter_seed {
            config.filter.seed = seed;
        }
        if let Some(proposal) = self.proposal {
            config.filter.proposal = match proposal {
                ProposalName::LinearisedOptimal => Proposal::LinearisedOptimal,
                ProposalName::Bootstrap => Proposal::Bootstrap,
            };
        }
        let default_sweeps = match config.schedule {
            EmSchedule::FullMaximisation { max_sweeps } => max_sweeps,
            EmSchedule::ParameterWise => 30,
        };
        let max_sweeps = self.max_sweeps.map_or(default_sweeps, |AtLeast(n)| n);
        config.schedule = match self.schedule {
            Some(ScheduleName::ParameterWise) => {
                if self.max_sweeps.is_some() {
                    return Err(field_error(
                        path,
                        "identification.max_sweeps",
                        "only for schedule = \"full\"; the parameter-wise schedule makes one line search per parameter",
                    ));
                }
                EmSchedule::ParameterWise
            }
            Some(ScheduleName::Full) => EmSchedule::FullMaximisation { max_sweeps },
            None => match config.schedule {
                EmSchedule::FullMaximisation { .. } => EmSchedule::FullMaximisation { max_sweeps },
                other => other,
            },
        };
        if let Some(PositiveReal(tolerance)) = self.tolerance {
            config.tolerance = tolerance;
        }
        if let Some(AtLeast(max)) = self.max_iterations {
            config.max_iterations = max;
        }
        if let Some(std) = &self.measurement_noise_std {
            config.measurement_noise_std = std_vector(std, |v| v.0);
        }
        if let Some(std) = &self.process_noise_std {
            config.identification_process_noise_std = std_vector(std, |v| v.0);
        }
        Ok(())
    }
}

/// A recorded data set: the CSV (relative to the identification file) sets the sample time
/// and length; its true parameters, when given, must be a valid model-C vector.
fn recorded_data(
    path: &Path,
    csv: &Path,
    true_parameters: Option<ParameterVector>,
    config: &mut Seed003Config,
) -> Result<(JobData, Option<[f64; 4]>)> {
    let base = path.parent().unwrap_or(Path::new("."));
    let csv_path = base.join(csv);
    let data = read_csv(&csv_path)
        .with_context(|| format!("identification file {}: field `data`", path.display()))?;
    config.samples = data.len();
    config.sample_time = data.sample_time;
    let truth = true_parameters.map(|ParameterVector(p)| p);
    if let Some(truth) = truth.as_ref() {
        check_parameters(path, "true_parameters", truth, config.sample_time)?;
    }
    Ok((
        JobData::Recorded {
            path: csv_path,
            data,
        },
        truth,
    ))
}

impl SimulationSection {
    /// Writes `[simulation]` into `config`; the data set is simulated, its truth is the
    /// simulation's parameters.
    fn apply(
        &self,
        path: &Path,
        config: &mut Seed003Config,
    ) -> Result<(JobData, Option<[f64; 4]>)> {
        if let Some(AtLeast(samples)) = self.samples {
            config.samples = samples;
        }
        if let Some(PositiveReal(t)) = self.sample_time {
            config.sample_time = t;
        }
        if let Some(ParameterVector(p)) = self.true_parameters {
            check_parameters(path, "simulation.true_parameters", &p, config.sample_time)?;
            config.true_parameters = RearAxleParameterVector::from(p);
        }
        if let Some(std) = &self.process_noise_std {
            config.simulation_process_noise_std = std_vector(std, |v| v.0);
        }
        config.noise_seeds = match &self.noise_seeds {
            Some(NoiseSeeds(seeds)) => seeds.clone(),
            None => vec![config.noise_seeds[0]],
        };
        let truth: [f64; 4] = config.true_parameters.into();
        Ok((JobData::Simulated, Some(truth)))
    }
}

// ---------------------------------------------------------------------------------------------
// Running

/// Table 3.1 of one simulated data set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateRmse {
    /// RMSE of `[Vy_ref, ω, φ]`: particle filter, smoother (true parameters, `Ξ = Θ`) and the raw
    /// measurements.
    pub filter: [f64; 3],
    pub smoother: [f64; 3],
    pub measurement: [f64; 3],
}

/// One identification run.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifiedRun {
    /// "noise seed 3" or the CSV's file name.
    pub label: String,
    pub noise_seed: Option<u64>,
    pub result: EmResult<4>,
    /// Wall-clock seconds of the identification alone.
    pub seconds: f64,
    /// For a simulated data set: table 3.1 and the data (written as CSV).
    pub state_rmse: Option<StateRmse>,
    pub simulated: Option<DataSet>,
}

/// Every run of a job.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    pub job: Job,
    pub runs: Vec<IdentifiedRun>,
}

/// Runs the job: one identification per noise seed (in parallel) or one on the recorded data.
/// `done` is called after each run (progress).
pub fn run(job: &Job, done: &(dyn Fn() + Sync)) -> Result<Outcome> {
    let runs = match &job.data {
        JobData::Simulated => job
            .config
            .noise_seeds
            .par_iter()
            .map(|&noise_seed| {
                let run = run_simulated(job, noise_seed);
                done();
                run
            })
            .collect::<Result<Vec<_>>>()?,
        JobData::Recorded { path, data } => {
            let inputs = &data.inputs;
            let started = Instant::now();
            let result = seed003::identify_from_arrays(
                inputs,
                &data.measurements,
                data.sample_time,
                &job.config,
            )
            .with_context(|| format!("identification of {}", path.display()))?;
            let seconds = started.elapsed().as_secs_f64();
            done();
            vec![IdentifiedRun {
                label: path
                    .file_name()
                    .map_or_else(|| "data".into(), |n| n.to_string_lossy().to_string()),
                noise_seed: None,
                result,
                seconds,
                state_rmse: None,
                simulated: None,
            }]
        }
    };
    Ok(Outcome {
        job: job.clone(),
        runs,
    })
}

fn run_simulated(job: &Job, noise_seed: u64) -> Result<IdentifiedRun> {
    let config = Seed003Config {
        noise_seeds: vec![noise_seed],
        ..job.config.clone()
    };
    let context = || {
        format!(
            "{}: identification of the data set simulated with noise seed {noise_seed}",
            job.source.display()
        )
    };
    let simulated = seed003::simulate(&config, noise_seed).with_context(context)?;
    let report = seed003::run(&config).with_context(context)?;
    let trial = report
        .trials
        .into_iter()
        .next()
        .ok_or_else(|| anyhow!("{}: no trial", context()))?;
    let data = DataSet {
        times: (0..config.samples)
            .map(|k| k as f64 * config.sample_time)
            .collect(),
        inputs: simulated.run.inputs.iter().map(|u| (*u).into()).collect(),
        measurements: simulated
            .run
            .measurements
            .iter()
            .map(|y| (*y).into())
            .collect(),
        sample_time: config.sample_time,
    };
    Ok(IdentifiedRun {
        label: format!("noise seed {noise_seed}"),
        noise_seed: Some(noise_seed),
        result: trial.identification,
        seconds: trial.identification_seconds,
        state_rmse: Some(StateRmse {
            filter: trial.filter_rmse,
            smoother: trial.smoother_rmse,
            measurement: trial.measurement_rmse,
        }),
        simulated: Some(data),
    })
}

// ---------------------------------------------------------------------------------------------
// Presenting

/// `100 (p - p_true) / p_true`, signed.
pub fn signed_relative_error_percent(p: &[f64; 4], truth: &[f64; 4]) -> [f64; 4] {
    std::array::from_fn(|j| 100.0 * (p[j] - truth[j]) / truth[j].abs())
}

fn parameters_of(v: &SVector<f64, 4>) -> [f64; 4] {
    (*v).into()
}

/// One row of the iteration history.
#[derive(Debug, Clone, PartialEq)]
pub struct IterationRow {
    pub iteration: usize,
    pub parameters: [f64; 4],
    /// E-steps of this iteration (0 for the start).
    pub e_steps: usize,
    /// `-Q` before the first and after the last update of the iteration (lower is better).
    pub objective_before: f64,
    pub objective_after: f64,
    pub evaluations: usize,
    pub mean_smoothed_ess: f64,
}

/// The history of one run, one row per iteration (row 0: the start).
pub fn iteration_rows(result: &EmResult<4>) -> Vec<IterationRow> {
    result
        .iterations
        .iter()
        .enumerate()
        .map(|(iteration, p)| {
            let updates: Vec<_> = result
                .updates
                .iter()
                .filter(|u| u.iteration == iteration)
                .collect();
            let e_steps = updates.len();
            IterationRow {
                iteration,
                parameters: parameters_of(p),
                e_steps,
                objective_before: updates.first().map_or(f64::NAN, |u| u.objective_before),
                objective_after: updates.last().map_or(f64::NAN, |u| u.objective_after),
                evaluations: updates.iter().map(|u| u.evaluations).sum(),
                mean_smoothed_ess: if e_steps == 0 {
                    f64::NAN
                } else {
                    updates.iter().map(|u| u.mean_smoothed_ess).sum::<f64>() / e_steps as f64
                },
            }
        })
        .collect()
}

impl Outcome {
    /// Whether the job is seed 003's own setup (its truth and start), so the seed's table 3.2
    /// is the right comparison.
    pub fn is_seed_setup(&self) -> bool {
        self.job.truth == Some(parameters_of(&seed_parameters()))
            && parameters_of(&self.job.config.start_parameters)
                == parameters_of(&seed_identification_start())
    }

    fn start(&self) -> [f64; 4] {
        parameters_of(&self.job.config.start_parameters)
    }

    /// Relative errors (percent, absolute value) of run `r`, when the truth is known.
    pub fn relative_errors(&self, run: &IdentifiedRun) -> Option<[f64; 4]> {
        self.job.truth.map(|truth| {
            signed_relative_error_percent(&parameters_of(&run.result.parameters), &truth)
                .map(f64::abs)
        })
    }

    /// Mean and spread over runs of the identified parameter `j`.
    pub fn identified(&self, j: usize) -> (f64, f64) {
        mean_and_spread(self.runs.iter().map(|r| r.result.parameters[j]))
    }

    /// Mean and spread over runs of the relative error (percent) of parameter `j`.
    pub fn relative_error(&self, j: usize) -> Option<(f64, f64)> {
        self.job.truth?;
        Some(mean_and_spread(
            self.runs
                .iter()
                .filter_map(|r| self.relative_errors(r))
                .map(|e| e[j]),
        ))
    }

    /// Mean and spread over runs of table 3.1 (filter, smoother, measurement) for state `i`.
    pub fn state_rmse(&self, i: usize) -> Option<[(f64, f64); 3]> {
        let rmse: Vec<StateRmse> = self.runs.iter().filter_map(|r| r.state_rmse).collect();
        if rmse.is_empty() {
            return None;
        }
        Some([
            mean_and_spread(rmse.iter().map(|s| s.filter[i])),
            mean_and_spread(rmse.iter().map(|s| s.smoother[i])),
            mean_and_spread(rmse.iter().map(|s| s.measurement[i])),
        ])
    }

    /// The iteration history of every run as text tables.
    pub fn history_text(&self) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        for run in &self.runs {
            let iterations = run.result.iterations.len() - 1;
            let _ = writeln!(
                out,
                "{}: {iterations} iteration{}, {}, identification {:.2} s",
                run.label,
                if iterations == 1 { "" } else { "s" },
                if run.result.converged {
                    "converged"
                } else {
                    "NOT converged (iteration limit)"
                },
                run.seconds
            );
            let _ = write!(out, "{:>4}", "it");
            for name in PARAMETER_NAMES {
                let _ = write!(out, " {name:>9}");
            }
            if self.job.truth.is_some() {
                for name in PARAMETER_NAMES {
                    let _ = write!(out, " {:>9}", format!("{name} %"));
                }
            }
            let _ = writeln!(
                out,
                " {:>7} {:>13} {:>13} {:>6} {:>6}",
                "E-steps", "-Q before", "-Q after", "evals", "ESS"
            );
            for row in iteration_rows(&run.result) {
                let _ = write!(out, "{:>4}", row.iteration);
                for p in row.parameters {
                    let _ = write!(out, " {p:>9.5}");
                }
                if let Some(truth) = &self.job.truth {
                    for e in signed_relative_error_percent(&row.parameters, truth) {
                        let _ = write!(out, " {e:>+9.3}");
                    }
                }
                if row.e_steps == 0 {
                    let _ = writeln!(
                        out,
                        " {:>7} {:>13} {:>13} {:>6} {:>6}",
                        "-", "-", "-", "-", "-"
                    );
                } else {
                    let _ = writeln!(
                        out,
                        " {:>7} {:>13.6e} {:>13.6e} {:>6} {:>6.1}",
                        row.e_steps,
                        row.objective_before,
                        row.objective_after,
                        row.evaluations,
                        row.mean_smoothed_ess
                    );
                }
            }
            let _ = writeln!(out);
        }
        out
    }

    /// Tables 3.1 (simulated data only) and 3.2 over the runs, beside the seed's numbers when the
    /// job is the seed's setup.
    pub fn summary_text(&self) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        let seed = self.is_seed_setup();
        let runs = self.runs.len();
        // "mean ± spread" over several runs, the plain value for one.
        let value = |(mean, spread): (f64, f64), format: &dyn Fn(f64) -> String| {
            if runs > 1 {
                format!("{} ± {}", format(mean), format(spread))
            } else {
                format(mean)
            }
        };
        let scientific = |v: f64| format!("{v:.3e}");
        if self.state_rmse(0).is_some() {
            let _ = writeln!(
                out,
                "Table 3.1: RMSE of particle filter and smoother with the true parameters (N = {}{})",
                self.job.config.filter.particle_count,
                if runs > 1 {
                    format!(", mean ± spread over {runs} noise seeds")
                } else {
                    String::new()
                }
            );
            let _ = writeln!(
                out,
                "{:<14} {:>21} {:>21} {:>12} {:>11} {:>11}",
                "state", "filter", "smoother", "measurement", "filter 003", "smooth 003"
            );
            for (i, name) in STATE_LABELS.iter().enumerate() {
                if let Some([f, s, m]) = self.state_rmse(i) {
                    let _ = writeln!(
                        out,
                        "{name:<14} {:>21} {:>21} {:>12.3e} {:>11} {:>11}",
                        value(f, &scientific),
                        value(s, &scientific),
                        m.0,
                        if seed {
                            SEED_TABLE_3_1_FILTER[i].to_string()
                        } else {
                            "-".into()
                        },
                        if seed {
                            SEED_TABLE_3_1_SMOOTHER[i].to_string()
                        } else {
                            "-".into()
                        },
                    );
                }
            }
            let _ = writeln!(out);
        }
        let start = self.start();
        let _ = writeln!(
            out,
            "Identified parameters from p0 = [{}, {}, {}, {}]{}",
            start[0],
            start[1],
            start[2],
            start[3],
            if runs > 1 {
                format!(" (mean ± spread over {runs} runs)")
            } else {
                String::new()
            }
        );
        let _ = write!(
            out,
            "{:<6} {:>10} {:>21} {:>20}",
            "param", "truth", "identified", "rel. error %"
        );
        if seed {
            let _ = write!(out, " {:>10} {:>10}", "ident. 003", "rel.% 003");
        }
        let _ = writeln!(out);
        for (j, name) in PARAMETER_NAMES.iter().enumerate() {
            let identified = value(self.identified(j), &|v| format!("{v:.5}"));
            let truth = self
                .job
                .truth
                .map_or_else(|| "-".to_string(), |t| format!("{:.4}", t[j]));
            let error = self
                .relative_error(j)
                .map_or_else(|| "-".to_string(), |e| value(e, &|v| format!("{v:.3}")));
            let _ = write!(out, "{name:<6} {truth:>10} {identified:>21} {error:>20}");
            if seed {
                let _ = write!(
                    out,
                    " {:>10} {:>10}",
                    SEED_TABLE_3_2_IDENTIFIED[j], SEED_TABLE_3_2_RELATIVE_PERCENT[j]
                );
            }
            let _ = writeln!(out);
        }
        out
    }

    /// One row per iteration and run.
    pub fn write_history_csv(&self, path: &Path) -> Result<()> {
        let mut header: Vec<String> = ["run", "noise_seed", "iteration"]
            .map(String::from)
            .to_vec();
        header.extend(PARAMETER_NAMES.map(csv_name));
        if self.job.truth.is_some() {
            header.extend(PARAMETER_NAMES.map(|n| format!("rel_error_{}_percent", csv_name(n))));
        }
        header.extend(
            [
                "e_steps",
                "objective_before",
                "objective_after",
                "evaluations",
                "mean_smoothed_ess",
                "converged",
            ]
            .map(String::from),
        );
        let rows = self.runs.iter().flat_map(|run| {
            iteration_rows(&run.result).into_iter().map(move |row| {
                let mut record = run_columns(run);
                record.push(row.iteration.to_string());
                record.extend(row.parameters.map(|p| p.to_string()));
                if let Some(truth) = &self.job.truth {
                    record.extend(
                        signed_relative_error_percent(&row.parameters, truth)
                            .map(|e| e.to_string()),
                    );
                }
                record.extend([
                    row.e_steps.to_string(),
                    number_or_empty(row.objective_before),
                    number_or_empty(row.objective_after),
                    row.evaluations.to_string(),
                    number_or_empty(row.mean_smoothed_ess),
                    run.result.converged.to_string(),
                ]);
                record
            })
        });
        write_table(path, &header, rows)
    }

    /// Every single update of the EM (one per E-step), per run.
    pub fn write_updates_csv(&self, path: &Path) -> Result<()> {
        let mut header: Vec<String> = ["run", "noise_seed", "iteration", "updated"]
            .map(String::from)
            .to_vec();
        header.extend(PARAMETER_NAMES.map(csv_name));
        header.extend(
            [
                "objective_before",
                "objective_after",
                "evaluations",
                "mean_smoothed_ess",
            ]
            .map(String::from),
        );
        let rows = self.runs.iter().flat_map(|run| {
            run.result.updates.iter().map(move |update| {
                let mut record = run_columns(run);
                record.push(update.iteration.to_string());
                record.push(
                    PARAMETER_NAMES
                        .get(update.parameter_index)
                        .map_or_else(|| "all".to_string(), |n| n.to_string()),
                );
                record.extend(parameters_of(&update.parameters).map(|p| p.to_string()));
                record.extend(
                    [
                        update.objective_before,
                        update.objective_after,
                        update.evaluations as f64,
                        update.mean_smoothed_ess,
                    ]
                    .map(|v| v.to_string()),
                );
                record
            })
        });
        write_table(path, &header, rows)
    }

    /// The convergence plot (like 003 fig. 3.11): one row of panels per parameter against the
    /// iteration, on the left from the start, on the right from iteration 1 on (the start's
    /// error dwarfs the final one). With a known truth the signed relative error in percent is
    /// drawn (the truth is the zero line, and for the seed's setup the seed's final error is a
    /// line too), otherwise the estimate.
    pub fn draw_convergence(&self, path: &Path) -> Result<()> {
        let last = self
            .runs
            .iter()
            .map(|r| r.result.iterations.len() - 1)
            .max()
            .unwrap_or(0)
            .max(1);
        let seed = self.is_seed_setup();
        let mut panels = Vec::new();
        for (j, name) in PARAMETER_NAMES.iter().enumerate() {
            for first in [0, 1] {
                let mut series = Vec::new();
                let level = |name: String, y: f64, is_truth: bool| Series {
                    name,
                    x: vec![first as f64, last as f64],
                    y: vec![y, y],
                    is_truth,
                };
                if let Some(truth) = &self.job.truth {
                    series.push(level(format!("truth {}", truth[j]), 0.0, true));
                    if seed {
                        let error = 100.0 * (SEED_TABLE_3_2_IDENTIFIED[j] - truth[j]) / truth[j];
                        series.push(level(
                            format!("seed 003 result ({error:+.2} %)"),
                            error,
                            false,
                        ));
                    }
                }
                for run in &self.runs {
                    let history = &run.result.iterations;
                    let range = first.min(history.len() - 1)..history.len();
                    series.push(Series {
                        name: run.label.clone(),
                        x: range.clone().map(|i| i as f64).collect(),
                        y: history[range]
                            .iter()
                            .map(|p| match &self.job.truth {
                                Some(truth) => 100.0 * (p[j] - truth[j]) / truth[j],
                                None => p[j],
                            })
                            .collect(),
                        is_truth: false,
                    });
                }
                let what = if self.job.truth.is_some() {
                    "relative error to the truth"
                } else {
                    "estimate"
                };
                panels.push(Panel {
                    title: if first == 0 {
                        format!("{name}: {what}")
                    } else {
                        format!("{name}: {what}, from iteration 1")
                    },
                    x_label: "EM iteration".into(),
                    y_label: if self.job.truth.is_some() {
                        format!("({name} - truth) / truth [%]")
                    } else {
                        name.to_string()
                    },
                    series,
                });
            }
        }
        plot::draw_panels(
            path,
            &format!(
                "{}: EM identification of p = [Csf, Csr, m/J, lf] (cf. seed 003 fig. 3.11)",
                self.job.name
            ),
            &panels,
            2,
        )
    }
}

/// Labels of model C's states in table 3.1.
pub const STATE_LABELS: [&str; 3] = ["Vy_ref [m/s]", "ω [rad/s]", "φ [rad]"];

/// The run's label and noise seed, the first columns of the history files.
fn run_columns(run: &IdentifiedRun) -> Vec<String> {
    vec![
        run.label.clone(),
        run.noise_seed.map_or_else(String::new, |s| s.to_string()),
    ]
}

/// A parameter name usable as a CSV column name ("m/J" -> "m_over_J").
fn csv_name(name: &str) -> String {
    name.replace('/', "_over_")
}

/// What `harness identify` wrote.
#[derive(Debug, Clone)]
pub struct Written {
    pub folder: PathBuf,
    pub convergence_png: PathBuf,
    pub history_csv: PathBuf,
    pub updates_csv: PathBuf,
    pub summary_txt: PathBuf,
    /// The simulated data sets, in the CSV format `harness identify` reads.
    pub data_csv: Vec<PathBuf>,
}

/// Writes the outcome below `out/<job name>/`.
pub fn write_outputs(outcome: &Outcome, out: &Path) -> Result<Written> {
    let folder = out.join(&outcome.job.name);
    std::fs::create_dir_all(&folder).with_context(|| format!("creating {}", folder.display()))?;
    let written = Written {
        convergence_png: folder.join("convergence.png"),
        history_csv: folder.join("history.csv"),
        updates_csv: folder.join("updates.csv"),
        summary_txt: folder.join("summary.txt"),
        data_csv: outcome
            .runs
            .iter()
            .filter(|r| r.simulated.is_some())
            .map(|r| folder.join(format!("data_seed{}.csv", r.noise_seed.unwrap_or_default())))
            .collect(),
        folder,
    };
    outcome.draw_convergence(&written.convergence_png)?;
    outcome.write_history_csv(&written.history_csv)?;
    outcome.write_updates_csv(&written.updates_csv)?;
    let text = format!("{}{}", outcome.history_text(), outcome.summary_text());
    std::fs::write(&written.summary_txt, text)
        .with_context(|| format!("writing {}", written.summary_txt.display()))?;
    let simulated = outcome.runs.iter().filter_map(|r| r.simulated.as_ref());
    for (path, data) in written.data_csv.iter().zip(simulated) {
        write_csv(path, data)?;
    }
    Ok(written)
}
