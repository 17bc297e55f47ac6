//! The identification file (TOML, `harness/scenarios/identification/*.toml`, format in
//! `harness/scenarios/README.md`, "Identification files") as self-checking types: serde refuses a
//! value while reading it, so every field that reaches [`crate::identify`] is already valid on
//! its own (a positive finite number, a count of at least N, a name fit for a folder, a
//! parameter vector of positive numbers). What depends on more than one field (one data source,
//! `lf` inside the wheelbase at the sample time) is checked by `identify::load`.
//!
//! A refused value is reported with the file, the dotted key (`identification.particles`) and
//! what was expected ([`parse`]).

use std::path::PathBuf;

use estimation::models::rear_axle::PARAMETER_NAMES;
use serde::Deserialize;

/// The whole file; every field but `name` is optional and defaults to seed 003's value.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentificationFile {
    pub name: FolderName,
    #[serde(default)]
    pub description: String,
    /// A recorded data set (CSV, relative to this file) instead of `[simulation]`.
    pub data: Option<PathBuf>,
    /// The true parameters of a recorded data set, when known (relative errors, plot).
    pub true_parameters: Option<ParameterVector>,
    pub simulation: Option<SimulationSection>,
    #[serde(default)]
    pub identification: IdentificationSection,
}

/// `[simulation]`: model C generates the data set.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationSection {
    pub samples: Option<AtLeast<2>>,
    /// s.
    pub sample_time: Option<PositiveReal>,
    pub true_parameters: Option<ParameterVector>,
    /// The simulator's process noise; zero is allowed (a simulator without process noise).
    pub process_noise_std: Option<[NonNegativeReal; 3]>,
    pub noise_seeds: Option<NoiseSeeds>,
}

/// `[identification]`: the filter, the smoother and the EM.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentificationSection {
    pub start: Option<ParameterVector>,
    /// `Θ` and `Ξ` must be positive definite: positive standard deviations.
    pub measurement_noise_std: Option<[PositiveReal; 3]>,
    pub process_noise_std: Option<[PositiveReal; 3]>,
    pub particles: Option<AtLeast<2>>,
    pub filter_seed: Option<u64>,
    pub proposal: Option<ProposalName>,
    pub schedule: Option<ScheduleName>,
    /// Powell sweeps per M-step (schedule `full` only).
    pub max_sweeps: Option<AtLeast<1>>,
    /// Stop when no parameter changes by more than this fraction of its value.
    pub tolerance: Option<PositiveReal>,
    pub max_iterations: Option<AtLeast<1>>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProposalName {
    LinearisedOptimal,
    Bootstrap,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScheduleName {
    Full,
    ParameterWise,
}

/// A finite number > 0.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct PositiveReal(pub f64);

impl TryFrom<f64> for PositiveReal {
    type Error = String;
    fn try_from(value: f64) -> Result<Self, String> {
        if value.is_finite() && value > 0.0 {
            Ok(PositiveReal(value))
        } else {
            Err(format!("{value}: expected a positive finite number"))
        }
    }
}

/// A finite number >= 0.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct NonNegativeReal(pub f64);

impl TryFrom<f64> for NonNegativeReal {
    type Error = String;
    fn try_from(value: f64) -> Result<Self, String> {
        if value.is_finite() && value >= 0.0 {
            Ok(NonNegativeReal(value))
        } else {
            Err(format!("{value}: expected a non-negative finite number"))
        }
    }
}

/// A count of at least `MIN`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "usize")]
pub struct AtLeast<const MIN: usize>(pub usize);

impl<const MIN: usize> TryFrom<usize> for AtLeast<MIN> {
    type Error = String;
    fn try_from(value: usize) -> Result<Self, String> {
        if value >= MIN {
            Ok(AtLeast(value))
        } else {
            Err(format!("{value}: expected at least {MIN}"))
        }
    }
}

/// The job's name, which names its output folder: letters, digits, '_', '-' or '.', and not
/// only dots.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub struct FolderName(pub String);

impl TryFrom<String> for FolderName {
    type Error = String;
    fn try_from(name: String) -> Result<Self, String> {
        let allowed = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.';
        if name.chars().all(allowed) && name.chars().any(|c| c != '.') {
            Ok(FolderName(name))
        } else {
            Err(format!(
                "{name:?}: expected letters, digits, '_', '-' or '.' (it names the output folder)"
            ))
        }
    }
}

/// Model C's `p = [Csf, Csr, m/J, lf]`, each positive and finite (whether `lf` fits the
/// wheelbase is the model's check, `identify::load`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "[f64; 4]")]
pub struct ParameterVector(pub [f64; 4]);

impl TryFrom<[f64; 4]> for ParameterVector {
    type Error = String;
    fn try_from(p: [f64; 4]) -> Result<Self, String> {
        match p.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            Some(j) => Err(format!(
                "{} = {} must be a positive finite number",
                PARAMETER_NAMES[j], p[j]
            )),
            None => Ok(ParameterVector(p)),
        }
    }
}

/// At least one noise seed.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(try_from = "Vec<u64>")]
pub struct NoiseSeeds(pub Vec<u64>);

impl TryFrom<Vec<u64>> for NoiseSeeds {
    type Error = String;
    fn try_from(seeds: Vec<u64>) -> Result<Self, String> {
        if seeds.is_empty() {
            Err("empty; expected at least one noise seed".into())
        } else {
            Ok(NoiseSeeds(seeds))
        }
    }
}

/// Why a file was refused: the dotted key of the refused value when it can be told, the
/// position and serde's message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileError {
    pub key: Option<String>,
    /// 1-based line and column.
    pub position: Option<(usize, usize)>,
    pub message: String,
}

impl std::fmt::Display for FileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(key) = &self.key {
            write!(f, "field `{key}`: ")?;
        }
        write!(f, "{}", self.message)?;
        if let Some((line, column)) = self.position {
            write!(f, " (line {line}, column {column})")?;
        }
        Ok(())
    }
}

/// Reads an identification file's text.
pub fn parse(text: &str) -> Result<IdentificationFile, FileError> {
    toml::from_str(text).map_err(|error: toml::de::Error| {
        let span = error.span();
        FileError {
            key: span.as_ref().and_then(|s| key_at(text, s.start)),
            position: span.map(|s| line_and_column(text, s.start)),
            message: error.message().trim_end().to_string(),
        }
    })
}

fn line_and_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |n| n + 1) + 1;
    (line, column)
}

/// The dotted key (`section.key`) whose value or name is at `offset`: the nearest `key = ` at
/// or above the offset's line, under the nearest `[section]` header above it.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let (line, _) = line_and_column(text, offset);
    let lines: Vec<&str> = text.lines().take(line).collect();
    let mut key = None;
    for content in lines.iter().rev() {
        let content = content.split('#').next().unwrap_or("").trim();
        if let Some(section) = content.strip_prefix('[').and_then(|s| s.strip_suffix(']')) {
            let key = key?;
            return Some(format!("{}.{key}", section.trim()));
        }
        if key.is_none() {
            if let Some((name, _)) = content.split_once('=') {
                let name = name.trim();
                let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
                if !name.is_empty() && name.chars().all(bare) {
                    key = Some(name.to_string());
                }
            }
        }
    }
    key
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_value_names_its_dotted_key_and_position() {
        let text = "name = \"t\"\n[simulation]\nsamples = 100\n[identification]\n\
                    measurement_noise_std = [0.005, 0.0, 1e-4]\n";
        let error = parse(text).unwrap_err();
        assert_eq!(
            error.key.as_deref(),
            Some("identification.measurement_noise_std")
        );
        assert_eq!(error.position.map(|p| p.0), Some(5));
        assert!(
            error
                .message
                .contains("0: expected a positive finite number"),
            "{error}"
        );
    }

    #[test]
    fn the_newtypes_refuse_what_the_format_forbids() {
        assert!(PositiveReal::try_from(f64::NAN).is_err());
        assert!(NonNegativeReal::try_from(0.0).is_ok());
        assert!(AtLeast::<2>::try_from(1).is_err());
        assert!(FolderName::try_from("..".to_string()).is_err());
        assert!(FolderName::try_from("run-1.b".to_string()).is_ok());
        assert!(NoiseSeeds::try_from(vec![]).is_err());
        let error = ParameterVector::try_from([8.0, 7.0, f64::INFINITY, 1.0]).unwrap_err();
        assert!(error.contains("m/J = inf"), "{error}");
    }
}
