//! `harness replay` and `harness fit`: a recorded drive (CSV or ASAM MDF4) fed
//! through the VehicleStateEstimator FMU, scored against the log's reference channels, and the
//! estimator fitted to the car.
//!
//! * [`log`]: reading CSV and MF4 logs; [`map`]: the map file (column, unit, sign per FMU
//!   input, reference columns); [`units`]: unit conversions;
//! * [`align`]: how non-uniform, multi-rate and missing samples meet the communication grid;
//! * [`drive`]: the FMU loop over the master's public API;
//! * [`report`]: the estimates CSV, the score table and the plots;
//! * [`fit`]: cornering-stiffness scales by EM, noise levels from the innovations;
//! * [`study`]: the real track recording (MBDS) per model and estimator (`harness replay-study`).

pub mod align;
pub mod drive;
pub mod fit;
pub mod friction;
pub mod log;
pub mod map;
pub mod noise;
pub mod record;
pub mod reference_fit;
pub mod report;
pub mod study;
pub mod units;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use quick_xml::events::Event;

use fmi_master::cosim::ParameterValue;
use fmi_master::fmu::{LoadedFmu, VariableInfo};

use align::{align, median_interval, Grid, DEFAULT_STALE_INTERVALS};
use drive::Feed;
use map::{Channel, Map, Source, VariableUnits};

/// The units of the estimator FMU's Real variables, read from its modelDescription.xml (the
/// `fmi` crate's schema does not keep the `unit` attribute).
pub struct FmuUnits {
    inputs: HashMap<String, String>,
    outputs: HashMap<String, String>,
}

impl FmuUnits {
    pub fn of(fmu: &LoadedFmu) -> Result<FmuUnits> {
        let all = real_attribute(fmu, "unit")?;
        let is =
            |name: &str, check: fn(&VariableInfo) -> bool| fmu.variable(name).is_some_and(check);
        let mut units = FmuUnits {
            inputs: all.clone(),
            outputs: all,
        };
        units
            .inputs
            .retain(|name, _| is(name, VariableInfo::is_input));
        units
            .outputs
            .retain(|name, _| is(name, VariableInfo::is_output));
        Ok(units)
    }
}

/// The attribute `key` of each Real variable that declares it (`unit`, `max`, ...), by variable
/// name, read from the FMU's modelDescription.xml: the `fmi` crate's schema keeps neither.
pub fn real_attribute(fmu: &LoadedFmu, key: &str) -> Result<HashMap<String, String>> {
    let path = fmu.model_description_path();
    let xml =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut found = HashMap::new();
    let mut reader = quick_xml::Reader::from_str(&xml);
    let mut current: Option<String> = None;
    loop {
        match reader
            .read_event()
            .map_err(|e| anyhow!("{}: {e}", path.display()))?
        {
            Event::Start(e) | Event::Empty(e) => {
                let attribute = |wanted: &str| {
                    e.attributes()
                        .flatten()
                        .find(|a| a.key.local_name().into_inner() == wanted)
                        .and_then(|a| {
                            a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                                .ok()
                                .map(|v| v.into_owned())
                        })
                };
                match e.local_name().into_inner() {
                    "ScalarVariable" => current = attribute("name"),
                    "Real" => {
                        if let (Some(name), Some(value)) = (current.take(), attribute(key)) {
                            found.insert(name, value);
                        }
                    }
                    _ => {}
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    Ok(found)
}

impl VariableUnits for FmuUnits {
    fn input_unit(&self, name: &str) -> Option<String> {
        self.inputs.get(name).cloned()
    }
    fn estimate_unit(&self, name: &str) -> Option<String> {
        self.outputs.get(&format!("{name}_est")).cloned()
    }
}

/// A log read through its map onto the communication grid.
pub struct Prepared {
    pub map: Map,
    pub log: log::Log,
    pub grid: Grid,
    /// Every mapped FMU input, SI, one value per grid row.
    pub feeds: Vec<Feed>,
    /// Every reference channel, SI, one value per grid row.
    pub references: Vec<(Channel, Vec<f64>)>,
    /// The FMU's sensor inputs the map leaves out: each is in `feeds` as missing (NaN) on every
    /// row, never its start value, which would be read as a measurement.
    pub missing_sensors: Vec<String>,
}

impl Prepared {
    /// One warning per sensor input the map leaves out (empty when it maps them all).
    pub fn warnings(&self) -> Vec<String> {
        self.missing_sensors
            .iter()
            .map(|name| {
                format!(
                    "warning: map {} leaves out the FMU sensor input {name}: fed as missing (NaN) on every row",
                    self.map.path.display()
                )
            })
            .collect()
    }
}

/// The estimator FMU's sensor inputs: its Real inputs named `*_meas`.
pub fn sensor_inputs(fmu: &LoadedFmu) -> Vec<String> {
    fmu.variables
        .iter()
        .filter(|v| v.is_input() && v.name.ends_with("_meas"))
        .map(|v| v.name.clone())
        .collect()
}

/// The FMU to use: `fmu` as given, or `VehicleStateEstimator.fmu` in `fmu_dir`.
pub fn estimator_path(fmu: Option<&Path>, fmu_dir: &Path) -> PathBuf {
    fmu.map_or_else(
        || fmu_dir.join("VehicleStateEstimator.fmu"),
        Path::to_path_buf,
    )
}

/// Reads `log_path` through the map at `map_path` (checked against `fmu`) and aligns it.
pub fn prepare(log_path: &Path, map_path: &Path, fmu: &LoadedFmu) -> Result<Prepared> {
    let map = Map::read(map_path, &FmuUnits::of(fmu)?)?;
    let log = log::Log::read(log_path, &map.time_column, map.time_factor, &map.columns())?;
    check_columns(&map, &log)?;
    let (start, end) = log
        .time_span()
        .ok_or_else(|| anyhow!("log {}: no samples", log_path.display()))?;
    let step = match map.step {
        Some(h) if h.is_finite() && h > 0.0 => h,
        Some(h) => bail!(
            "map {}: log.step = {h}: expected a positive step in seconds",
            map.path.display()
        ),
        None => fastest_interval(&log)
            .ok_or_else(|| anyhow!("log {}: fewer than two time stamps", log_path.display()))?,
    };
    let grid = Grid::new(start, end, step);
    let mut feeds: Vec<Feed> = map
        .inputs
        .iter()
        .map(|c| Feed {
            input: c.target.clone(),
            values: aligned(c, &map, &log, &grid),
        })
        .collect();
    let missing_sensors: Vec<String> = sensor_inputs(fmu)
        .into_iter()
        .filter(|name| !feeds.iter().any(|f| &f.input == name))
        .collect();
    feeds.extend(missing_sensors.iter().map(|name| Feed {
        input: name.clone(),
        values: vec![f64::NAN; grid.rows],
    }));
    let references = map
        .references
        .iter()
        .map(|c| (c.clone(), aligned(c, &map, &log, &grid)))
        .collect();
    Ok(Prepared {
        map,
        log,
        grid,
        feeds,
        references,
        missing_sensors,
    })
}

/// Every column the map names is in the log, and an MF4 channel's own unit is the map's.
fn check_columns(map: &Map, log: &log::Log) -> Result<()> {
    for channel in map.inputs.iter().chain(&map.references) {
        let Source::Column { name, at } = &channel.source else {
            continue;
        };
        let Some(signal) = log.signal(name) else {
            bail!(
                "{}: column {name:?} is not in log {} (for {})",
                map.describe(*at),
                log.path.display(),
                channel.target
            );
        };
        if let Some(unit) = &signal.unit {
            if !units::same_unit(unit, &channel.unit) {
                bail!(
                    "{}: {} is read as {:?}, but log {} records channel {name:?} in {unit:?}",
                    map.describe(channel.at),
                    channel.target,
                    channel.unit,
                    log.path.display()
                );
            }
        }
    }
    Ok(())
}

/// The median sample interval of the fastest signal, s.
fn fastest_interval(log: &log::Log) -> Option<f64> {
    log.signals
        .iter()
        .filter_map(|s| median_interval(&s.times, &s.values))
        .reduce(f64::min)
}

/// One channel on the grid, in SI units (see [`align`] for the rule).
fn aligned(channel: &Channel, map: &Map, log: &log::Log, grid: &Grid) -> Vec<f64> {
    let signal = match &channel.source {
        Source::Constant(value) => return vec![*value; grid.rows],
        Source::Column { name, .. } => log.signal(name).expect("checked by check_columns"),
    };
    let stale_after = channel
        .stale_after
        .or(map.stale_after)
        .or_else(|| {
            median_interval(&signal.times, &signal.values).map(|h| DEFAULT_STALE_INTERVALS * h)
        })
        .unwrap_or(f64::INFINITY);
    let mut values = align(&signal.times, &signal.values, grid, map.align, stale_after);
    for v in &mut values {
        *v = channel.factor * (*v - channel.offset);
    }
    values
}

/// The parameters a replay sets, in order: the map's sample time default (the grid step), the
/// map's `[estimator.parameters]`, the `--parameters` file, then `extra` (the last of a name
/// wins). The file comes after the map because it is the more specific choice of the two: what
/// `harness fit` writes holds the map's values and the fitted ones, and replayed under the map
/// its model and covariances must not fall back to the map's (a model-B fit ran as model A).
pub fn parameters(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    file: Option<&Path>,
    extra: &[(VariableInfo, ParameterValue)],
) -> Result<Vec<(VariableInfo, ParameterValue)>> {
    let mut values = vec![(
        drive::parameter(fmu, "sample_time")?.clone(),
        ParameterValue::Real(prepared.grid.step),
    )];
    let origin = format!(
        "map {}: [estimator.parameters]",
        prepared.map.path.display()
    );
    values.extend(drive::parameters_from_table(
        fmu,
        &prepared.map.parameters,
        &origin,
    )?);
    if let Some(path) = file {
        values.extend(drive::parameters_from_file(fmu, path)?);
    }
    values.extend(extra.iter().cloned());
    Ok(values)
}

/// What `harness replay` is given.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    pub log: PathBuf,
    pub map: PathBuf,
    /// An SSP parameter-value file for the estimator (`--parameters CAR.ssv`).
    pub parameters: Option<PathBuf>,
    pub fmu: PathBuf,
    pub out: PathBuf,
    pub plots: bool,
}

/// What a replay produced.
pub struct ReplayOutcome {
    pub prepared: Prepared,
    pub recording: drive::Recording,
    pub scores: Vec<fmi_master::scoring::StateScore>,
    pub csv: PathBuf,
    pub plot: Option<PathBuf>,
    /// Wall time of reading, aligning and the FMU run together, s.
    pub seconds: f64,
}

/// `harness replay`: the log through the estimator FMU; writes `estimates.csv`, `scores.md`
/// and `replay.png` to `options.out`.
pub fn replay(options: &ReplayOptions) -> Result<ReplayOutcome> {
    let started = std::time::Instant::now();
    std::fs::create_dir_all(&options.out)
        .with_context(|| format!("creating {}", options.out.display()))?;
    let work = fmi_master::runner::WorkFolder::new(options.out.join(".fmu-work"));
    let fmu = LoadedFmu::load(&options.fmu, work.path())?;
    let prepared = prepare(&options.log, &options.map, &fmu)?;
    for warning in prepared.warnings() {
        eprintln!("{warning}");
    }
    let values = parameters(&fmu, &prepared, options.parameters.as_deref(), &[])?;
    let recording = drive::run(&fmu, &values, &prepared.grid, &prepared.feeds)?;
    let seconds = started.elapsed().as_secs_f64();
    drop(fmu);
    drop(work);
    let scores = report::scores(&prepared, &recording, 0..prepared.grid.rows);
    let csv = report::write_estimates(&prepared, &recording, &options.out)?;
    let table = report::score_table(&scores);
    let scores_path = options.out.join("scores.md");
    std::fs::write(&scores_path, &table)
        .with_context(|| format!("writing {}", scores_path.display()))?;
    let plot = if options.plots && !prepared.references.is_empty() {
        let title = format!("replay of {}", options.log.display());
        Some(report::plot(&prepared, &recording, &options.out, &title)?)
    } else {
        None
    };
    Ok(ReplayOutcome {
        prepared,
        recording,
        scores,
        csv,
        plot,
        seconds,
    })
}
