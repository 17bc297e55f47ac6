//! Scenario files (TOML): which FMUs, their parameters, the connections, the input signals from
//! the manoeuvre library, the communication step, the stop time, what to record and score.
//!
//! The format is documented for users in `harness/scenarios/README.md`; in short:
//!
//! ```toml
//! name = "ramp_high_ay"
//! step = 0.001            # communication step h [s]; points are t0 + n h
//! # start_time = 0.0      # t0
//! # stop_time = 12.0      # default: the manoeuvre's duration
//! [manoeuvre]
//! library = "seed000_ramp_high_ay"   # or [manoeuvre.custom] kind = "steer_ramp" ...
//! [[fmu]]
//! name = "vehicle"                   # instance name, unique, no '.'
//! path = "{fmu_dir}/ReferenceVehicle.fmu"   # relative to this file; {fmu_dir} from the CLI
//! parameter_files = ["../../fmu-src/reference-vehicle/cars/bmw_320i.ssv"]  # SSP .ssv, first
//! parameters = { model = 1, seed = 7 }          # then these (they override the files)
//! [[connection]]
//! from = "vehicle"                   # "inst" = every output of inst to the same-named input
//! to = "ekf"                         # or "inst.variable" on both sides
//! [[input]]
//! signal = "steering_angle"          # a manoeuvre channel
//! to = ["*.steering_angle"]          # '*' = every FMU having that input (or parameter)
//! [record]
//! variables = ["*.*"]                # default: every output of every FMU
//! [[score]]
//! label = "vy"; unit = "m/s"; truth = "vehicle.vy"; estimate = "*.vy_est"; std = "*.vy_std"
//! [[nis]]
//! nis = "*.nis"; dof = "*.rows_used"
//! ```

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use serde::Deserialize;

use manoeuvres::{Channel, Manoeuvre};

/// A scenario file could not be used. The message names the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("scenario {path}: cannot read the file: {cause}")]
    Unreadable {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("scenario {path}: {message}")]
    Syntax { path: PathBuf, message: String },
    #[error("scenario {path}: field `{field}`: {message}")]
    Field {
        path: PathBuf,
        field: String,
        message: String,
    },
}

/// The most communication steps a scenario may take: ten million, i.e.
/// about three hours of simulated time at 1 ms, which keeps the recording's allocation bounded.
pub const MAX_STEPS: u64 = 10_000_000;

/// Checks a name that becomes a file or folder name (the scenario name names the run's output
/// folder and CSV): 1 to 100 ASCII letters, digits, `_`, `-`, `.`, not starting with `.`, so
/// that it can never leave the output folder or hide in it.
pub fn check_file_name(name: &str) -> Result<(), String> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if name.is_empty() || name.len() > 100 || name.starts_with('.') || !name.chars().all(allowed) {
        return Err(format!(
            "{name:?} is used as a file name: expected 1 to 100 letters, digits, '_', '-' or '.', not starting with '.'"
        ));
    }
    Ok(())
}

fn default_fmi_version() -> u8 {
    2
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub start_time: f64,
    #[serde(default)]
    pub stop_time: Option<f64>,
    /// Communication step h [s].
    pub step: f64,
    #[serde(default)]
    pub manoeuvre: Option<ManoeuvreSection>,
    #[serde(default, rename = "fmu")]
    pub fmus: Vec<FmuSection>,
    #[serde(default, rename = "connection")]
    pub connections: Vec<ConnectionSection>,
    #[serde(default, rename = "input")]
    pub inputs: Vec<InputSection>,
    #[serde(default)]
    pub record: RecordSection,
    #[serde(default, rename = "score")]
    pub scores: Vec<ScoreSection>,
    #[serde(default, rename = "nis")]
    pub nis: Vec<NisSection>,
    #[serde(default)]
    pub montecarlo: MonteCarloSection,
    /// `[[override]]`: values that replace driven inputs in a time window (glitches, outages).
    #[serde(default, rename = "override")]
    pub overrides: Vec<OverrideSection>,
    /// `fmi_version = 3` drives every FMU through its FMI 3.0 archive `<stem>-fmi3.fmu` beside
    /// the `.fmu` named (`cosim::FmiVersion`); 2, the default, through the named archives.
    #[serde(default = "default_fmi_version")]
    pub fmi_version: u8,
    /// Folder of the file (relative FMU paths are resolved against it).
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// The file the scenario came from (for messages).
    #[serde(skip)]
    pub source: PathBuf,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManoeuvreSection {
    /// Name of a library manoeuvre (see `manoeuvres::LIBRARY`).
    #[serde(default)]
    pub library: Option<String>,
    /// A manoeuvre defined in place: `kind = "..."` plus that kind's fields.
    #[serde(default)]
    pub custom: Option<Manoeuvre>,
    /// Where a closed-loop manoeuvre reads the vehicle's motion ("inst.variable").
    #[serde(default)]
    pub feedback: Option<FeedbackSection>,
    /// Sine with dwell only: derive the amplitude from a slowly increasing steer scenario.
    #[serde(default)]
    pub amplitude_from_sis: Option<AmplitudeFromSis>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedbackSection {
    pub longitudinal_velocity: String,
    pub lateral_velocity: String,
    pub yaw_rate: String,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmplitudeFromSis {
    /// Scenario file (relative to this one) running the slowly increasing steer.
    pub scenario: String,
    /// Recorded lateral acceleration in that scenario ("inst.variable").
    pub lateral_acceleration: String,
    /// Multiple of the steering-wheel angle at 0.3 g (FMVSS 126 uses 1.5 ... 6.5).
    pub scale: f64,
    /// Upper bound of the amplitude [deg] (FMVSS 126: 270).
    #[serde(default = "default_amplitude_cap")]
    pub max_amplitude_deg: f64,
}

fn default_amplitude_cap() -> f64 {
    270.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FmuSection {
    pub name: String,
    pub path: String,
    /// SSP 1.0 parameter-value files (.ssv) applied in order before `parameters`; each path
    /// relative to this file, `{fmu_dir}` replaced as in `path`.
    #[serde(default)]
    pub parameter_files: Vec<String>,
    /// Parameter values set after instantiation, before initialisation (after the files).
    #[serde(default)]
    pub parameters: BTreeMap<String, toml::Value>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConnectionSection {
    pub from: String,
    pub to: String,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSection {
    /// Manoeuvre channel: steering_angle, steering_wheel_angle, drive_torque, brake_torque,
    /// initial_speed.
    pub signal: String,
    pub to: Vec<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordSection {
    #[serde(default = "default_record")]
    pub variables: Vec<String>,
}

impl Default for RecordSection {
    fn default() -> Self {
        RecordSection {
            variables: default_record(),
        }
    }
}

fn default_record() -> Vec<String> {
    vec!["*.*".to_string()]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScoreSection {
    /// Name of the estimated quantity in tables and plots.
    pub label: String,
    #[serde(default)]
    pub unit: String,
    /// "inst.variable" of the truth.
    pub truth: String,
    /// "inst.variable" of the estimate; '*' as instance = every FMU having that variable.
    pub estimate: String,
    /// One-sigma output of the estimate (same instance), for NEES.
    #[serde(default)]
    pub std: Option<String>,
    /// Factor applied to errors in the report (e.g. 57.29577951308232 for rad -> deg).
    #[serde(default)]
    pub display_scale: Option<f64>,
    #[serde(default)]
    pub display_unit: Option<String>,
}

impl ScoreSection {
    /// The factor and unit errors are shown in: `display_scale` (default 1) and
    /// `display_unit` (default `unit`).
    pub fn display(&self) -> (f64, String) {
        let unit = self.display_unit.as_ref().unwrap_or(&self.unit);
        (self.display_scale.unwrap_or(1.0), unit.clone())
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NisSection {
    /// "inst.variable" of the normalised innovation squared; '*' allowed.
    pub nis: String,
    /// "inst.variable" holding the degrees of freedom of each NIS value (same instance), or a
    /// number.
    pub dof: toml::Value,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonteCarloSection {
    /// Integer parameters ("inst.variable") set to base + run index in run `run`.
    #[serde(default)]
    pub seeds: Vec<String>,
}

/// `[[override]]`: from the first communication point at or after `start`, for `duration`
/// seconds (0 = that one point only), the master sends `value` instead of what drives each
/// target input (a connection or an `[[input]]`): a sensor glitch, a zero row, an outage (`nan`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverrideSection {
    /// Driven Real inputs, "inst.variable"; '*' = every instance having that input.
    pub to: Vec<String>,
    /// The value sent instead (TOML also writes `nan` and `inf`).
    pub value: f64,
    /// Time of the first overridden communication point [s].
    pub start: f64,
    /// Length of the window [s]: every point t with start <= t < start + duration.
    #[serde(default)]
    pub duration: f64,
}

impl OverrideSection {
    /// The communication points `(first, last)` it covers, for points `t0 + n h`.
    pub fn points(&self, t0: f64, h: f64) -> (u64, u64) {
        let index = |t: f64| ((t - t0) / h - 1e-9).ceil().max(0.0) as u64;
        let first = index(self.start);
        let end = index(self.start + self.duration);
        (first, end.saturating_sub(1).max(first))
    }
}

/// A reference "inst.variable"; the instance may be '*'.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VarRef {
    pub instance: String,
    pub variable: String,
}

impl VarRef {
    /// Split at the first '.' (instance names contain none; variable names may).
    pub fn parse(text: &str) -> Option<VarRef> {
        let (instance, variable) = text.split_once('.')?;
        if instance.is_empty() || variable.is_empty() {
            return None;
        }
        Some(VarRef {
            instance: instance.to_string(),
            variable: variable.to_string(),
        })
    }
}

impl std::fmt::Display for VarRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}", self.instance, self.variable)
    }
}

impl Scenario {
    pub fn from_file(path: &Path) -> Result<Scenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|cause| ScenarioError::Unreadable {
            path: path.to_path_buf(),
            cause,
        })?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        Scenario::from_str_at(&text, path, &base)
    }

    /// Parse `text` as if read from `path` (messages name it), FMU paths relative to `base_dir`.
    pub fn from_str_at(
        text: &str,
        path: &Path,
        base_dir: &Path,
    ) -> Result<Scenario, ScenarioError> {
        let mut scenario: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
            path: path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })?;
        scenario.base_dir = base_dir.to_path_buf();
        scenario.source = path.to_path_buf();
        scenario.validate()?;
        Ok(scenario)
    }

    fn field_error(&self, field: impl Into<String>, message: impl Into<String>) -> ScenarioError {
        ScenarioError::Field {
            path: self.source.clone(),
            field: field.into(),
            message: message.into(),
        }
    }

    /// Checks that need no FMU: numbers, names, references.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        if let Err(message) = check_file_name(&self.name) {
            return Err(self.field_error("name", message));
        }
        if !matches!(self.fmi_version, 2 | 3) {
            return Err(self.field_error(
                "fmi_version",
                format!("expected 2 or 3, got {}", self.fmi_version),
            ));
        }
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(self.field_error(
                "step",
                format!(
                    "communication step must be a positive number of seconds, got {}",
                    self.step
                ),
            ));
        }
        if !self.start_time.is_finite() {
            return Err(self.field_error("start_time", "must be a finite number"));
        }
        self.manoeuvre()?;
        let stop = self.stop_time()?;
        if stop <= self.start_time {
            return Err(self.field_error(
                "stop_time",
                format!(
                    "must be after start_time ({} s), got {stop} s",
                    self.start_time
                ),
            ));
        }
        self.step_count()?;
        if self.fmus.is_empty() {
            return Err(self.field_error("fmu", "at least one [[fmu]] is needed"));
        }
        let mut names = HashSet::new();
        for (i, fmu) in self.fmus.iter().enumerate() {
            let field = format!("fmu[{i}].name");
            if fmu.name.is_empty() || fmu.name.contains('.') || fmu.name == "*" {
                return Err(self.field_error(
                    field,
                    format!(
                        "instance name {:?} must be non-empty, without '.', not '*'",
                        fmu.name
                    ),
                ));
            }
            if fmu.name == "manoeuvre" || fmu.name == "driver" {
                return Err(self.field_error(
                    field,
                    format!(
                        "instance name {:?} is reserved for the master's own signals",
                        fmu.name
                    ),
                ));
            }
            if !names.insert(fmu.name.as_str()) {
                return Err(
                    self.field_error(field, format!("instance name {:?} used twice", fmu.name))
                );
            }
            if fmu.path.trim().is_empty() {
                return Err(self.field_error(format!("fmu[{i}].path"), "must name an .fmu file"));
            }
        }
        let known = |instance: &str| instance == "*" || names.contains(instance);
        for (i, c) in self.connections.iter().enumerate() {
            for (side, text) in [("from", &c.from), ("to", &c.to)] {
                let instance = text.split_once('.').map_or(text.as_str(), |(a, _)| a);
                if instance == "*" || !names.contains(instance) {
                    return Err(self.field_error(
                        format!("connection[{i}].{side}"),
                        format!(
                            "{text:?}: no [[fmu]] named {instance:?} (instances: {})",
                            self.instance_list()
                        ),
                    ));
                }
            }
            if c.from.contains('.') != c.to.contains('.') {
                return Err(self.field_error(
                    format!("connection[{i}]"),
                    "either both sides are \"inst.variable\" or both are instance names (connect by name)",
                ));
            }
        }
        for (i, input) in self.inputs.iter().enumerate() {
            if Channel::from_name(&input.signal).is_none() {
                let channels: Vec<_> = Channel::ALL.iter().map(|c| c.name()).collect();
                return Err(self.field_error(
                    format!("input[{i}].signal"),
                    format!(
                        "unknown manoeuvre signal {:?}; expected one of {}",
                        input.signal,
                        channels.join(", ")
                    ),
                ));
            }
            if self.manoeuvre.is_none() {
                return Err(self.field_error(
                    format!("input[{i}]"),
                    "manoeuvre signals need a [manoeuvre] section",
                ));
            }
            for (j, target) in input.to.iter().enumerate() {
                self.check_ref(&format!("input[{i}].to[{j}]"), target, &known)?;
            }
        }
        for (i, pattern) in self.record.variables.iter().enumerate() {
            self.check_ref(&format!("record.variables[{i}]"), pattern, &known)?;
        }
        for (i, s) in self.scores.iter().enumerate() {
            if s.label.trim().is_empty() {
                return Err(self.field_error(format!("score[{i}].label"), "must not be empty"));
            }
            self.check_ref(&format!("score[{i}].truth"), &s.truth, &|n: &str| {
                names.contains(n)
            })?;
            self.check_ref(&format!("score[{i}].estimate"), &s.estimate, &known)?;
            if let Some(std) = &s.std {
                self.check_ref(&format!("score[{i}].std"), std, &known)?;
            }
        }
        for (i, n) in self.nis.iter().enumerate() {
            self.check_ref(&format!("nis[{i}].nis"), &n.nis, &known)?;
            match &n.dof {
                toml::Value::Integer(d) if *d > 0 => {}
                toml::Value::String(s) => self.check_ref(&format!("nis[{i}].dof"), s, &known)?,
                other => {
                    return Err(self.field_error(
                        format!("nis[{i}].dof"),
                        format!("expected a positive integer or \"inst.variable\", got {other}"),
                    ))
                }
            }
        }
        for (i, s) in self.montecarlo.seeds.iter().enumerate() {
            self.check_ref(&format!("montecarlo.seeds[{i}]"), s, &|n: &str| {
                names.contains(n)
            })?;
        }
        for (i, o) in self.overrides.iter().enumerate() {
            if !(o.start.is_finite() && o.duration.is_finite() && o.duration >= 0.0) {
                return Err(self.field_error(
                    format!("override[{i}]"),
                    format!(
                        "start must be finite and duration finite and >= 0, got start {} s, duration {} s",
                        o.start, o.duration
                    ),
                ));
            }
            for (j, target) in o.to.iter().enumerate() {
                self.check_ref(&format!("override[{i}].to[{j}]"), target, &known)?;
            }
        }
        if let Some(section) = &self.manoeuvre {
            if let Some(fb) = &section.feedback {
                for (field, text) in [
                    ("longitudinal_velocity", &fb.longitudinal_velocity),
                    ("lateral_velocity", &fb.lateral_velocity),
                    ("yaw_rate", &fb.yaw_rate),
                ] {
                    self.check_ref(&format!("manoeuvre.feedback.{field}"), text, &|n: &str| {
                        names.contains(n)
                    })?;
                }
            }
        }
        Ok(())
    }

    fn instance_list(&self) -> String {
        self.fmus
            .iter()
            .map(|f| f.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn check_ref(
        &self,
        field: &str,
        text: &str,
        known: &dyn Fn(&str) -> bool,
    ) -> Result<(), ScenarioError> {
        let Some(r) = VarRef::parse(text) else {
            return Err(self.field_error(
                field,
                format!("{text:?} is not of the form \"instance.variable\""),
            ));
        };
        if !known(&r.instance) {
            return Err(self.field_error(
                field,
                format!(
                    "{text:?}: no [[fmu]] named {:?} (instances: {})",
                    r.instance,
                    self.instance_list()
                ),
            ));
        }
        Ok(())
    }

    /// The manoeuvre, from the library or defined in place.
    pub fn manoeuvre(&self) -> Result<Option<Manoeuvre>, ScenarioError> {
        let Some(section) = &self.manoeuvre else {
            return Ok(None);
        };
        let m = match (&section.library, &section.custom) {
            (Some(name), None) => manoeuvres::library(name).ok_or_else(|| {
                self.field_error(
                    "manoeuvre.library",
                    format!(
                        "unknown manoeuvre {name:?}; the library has {}",
                        manoeuvres::LIBRARY.join(", ")
                    ),
                )
            })?,
            (None, Some(m)) => m.clone(),
            _ => {
                return Err(self.field_error(
                    "manoeuvre",
                    "give exactly one of `library = \"name\"` and a [manoeuvre.custom] table",
                ))
            }
        };
        m.validate()
            .map_err(|message| self.field_error("manoeuvre", message))?;
        if m.needs_feedback() && section.feedback.is_none() {
            return Err(self.field_error(
                "manoeuvre.feedback",
                "this manoeuvre is closed-loop: give longitudinal_velocity, lateral_velocity and \
                 yaw_rate as \"inst.variable\"",
            ));
        }
        if section.amplitude_from_sis.is_some() && !matches!(m, Manoeuvre::SineWithDwell(_)) {
            return Err(self.field_error(
                "manoeuvre.amplitude_from_sis",
                "only a sine-with-dwell manoeuvre takes its amplitude from a slowly increasing steer run",
            ));
        }
        Ok(Some(m))
    }

    pub fn stop_time(&self) -> Result<f64, ScenarioError> {
        match (self.stop_time, self.manoeuvre()?) {
            (Some(t), _) if t.is_finite() => Ok(t),
            (Some(t), _) => Err(self.field_error("stop_time", format!("must be finite, got {t}"))),
            (None, Some(m)) => Ok(self.start_time + m.duration()),
            (None, None) => {
                Err(self.field_error("stop_time", "needed when there is no [manoeuvre]"))
            }
        }
    }

    /// Number of communication steps N: the points are t0 + n h, n = 0..=N, and t0 + N h must be
    /// the stop time (to 1e-9 relative), so the run ends exactly there. At most [`MAX_STEPS`],
    /// checked here, before anything is allocated for the recording.
    pub fn step_count(&self) -> Result<u64, ScenarioError> {
        let span = self.stop_time()? - self.start_time;
        let steps = span / self.step;
        if !(steps.is_finite() && steps <= MAX_STEPS as f64) {
            return Err(self.field_error(
                "step",
                format!(
                    "stop_time - start_time = {span} s in communication steps of {} s is {steps:e} steps; at most {MAX_STEPS} are allowed",
                    self.step
                ),
            ));
        }
        let rounded = steps.round();
        if (steps - rounded).abs() > 1e-9 * steps.max(1.0) || rounded < 1.0 {
            return Err(self.field_error(
                "step",
                format!(
                    "stop_time - start_time = {span} s is not a whole number of communication steps of {} s",
                    self.step
                ),
            ));
        }
        Ok(rounded as u64)
    }

    /// Communication point n: t0 + n h (never accumulated, so no drift).
    pub fn time_of(&self, n: u64) -> f64 {
        self.start_time + n as f64 * self.step
    }

    /// Path of FMU section `index`, `{fmu_dir}` replaced, relative paths against the file's folder.
    pub fn fmu_path(&self, index: usize, fmu_dir: &Path) -> PathBuf {
        self.resolve_path(&self.fmus[index].path, fmu_dir)
    }

    /// Path of parameter file `file` of FMU section `index`, resolved as [`Scenario::fmu_path`].
    pub fn parameter_file_path(&self, index: usize, file: usize, fmu_dir: &Path) -> PathBuf {
        self.resolve_path(&self.fmus[index].parameter_files[file], fmu_dir)
    }

    fn resolve_path(&self, raw: &str, fmu_dir: &Path) -> PathBuf {
        let replaced = raw.replace("{fmu_dir}", &fmu_dir.to_string_lossy());
        let p = PathBuf::from(replaced);
        if p.is_absolute() {
            p
        } else {
            self.base_dir.join(p)
        }
    }
}
