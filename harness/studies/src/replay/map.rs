//! The map file (TOML) that tells `harness replay` and `harness fit` which log column feeds
//! which estimator input, in which unit and sign, and which columns are references to score
//! against. Format and an example: `harness/logs/README.md`. Every error names the map file and
//! the line and column of the entry at fault.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use serde::Deserialize;
use toml::Spanned;

use super::align::Alignment;
use super::units;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    #[serde(default)]
    log: LogSection,
    #[serde(default)]
    estimator: EstimatorSection,
    inputs: BTreeMap<String, Spanned<EntryFile>>,
    #[serde(default)]
    reference: BTreeMap<String, Spanned<EntryFile>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct LogSection {
    time: Option<String>,
    time_unit: Option<Spanned<String>>,
    step: Option<f64>,
    align: Option<Spanned<String>>,
    stale_after: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct EstimatorSection {
    fmu: Option<PathBuf>,
    #[serde(default)]
    parameters: toml::Table,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EntryFile {
    column: Option<Spanned<String>>,
    value: Option<f64>,
    unit: Option<Spanned<String>>,
    sign: Option<Spanned<f64>>,
    offset: Option<f64>,
    steering_ratio: Option<f64>,
    wheel_radius: Option<f64>,
    stale_after: Option<f64>,
}

/// A place in the map file, 1-based.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Location {
    pub line: usize,
    pub column: usize,
}

/// Where one FMU input or reference comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// A log column (CSV header name or MF4 channel name) and where the map names it.
    Column { name: String, at: Location },
    /// A constant in SI units (e.g. a drive torque the log does not have: 0).
    Constant(f64),
}

/// One map entry, resolved: `si = factor × (logged − offset)` (the factor holds the unit, the
/// sign and a steering ratio).
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// The FMU input (inputs) or the estimate's name without `_est` (references).
    pub target: String,
    pub source: Source,
    /// The unit as the map writes it (checked against an MF4 channel's own unit).
    pub unit: String,
    /// The SI unit of the FMU variable (its modelDescription `unit`).
    pub si: String,
    pub factor: f64,
    pub offset: f64,
    /// Overrides the log-wide stale limit for this channel, s.
    pub stale_after: Option<f64>,
    pub at: Location,
}

/// The map file read and checked against the estimator FMU's variables.
#[derive(Debug, Clone)]
pub struct Map {
    pub path: PathBuf,
    /// The CSV column of the time stamps (MF4: each channel group's master channel).
    pub time_column: String,
    /// Factor from the logged time unit to seconds.
    pub time_factor: f64,
    /// Communication step, s; `None`: the median interval of the log's time stamps.
    pub step: Option<f64>,
    pub align: Alignment,
    /// Log-wide stale limit, s; `None`: 2.5 sample intervals of each channel.
    pub stale_after: Option<f64>,
    /// The estimator FMU, relative to the map file; `None`: the packaged one.
    pub fmu: Option<PathBuf>,
    /// Estimator parameters set after `--parameters` (TOML values in the FMU's types).
    pub parameters: toml::Table,
    pub inputs: Vec<Channel>,
    pub references: Vec<Channel>,
}

/// What the map is checked against: the SI unit of an FMU variable, by name; `None` when the
/// FMU has no such variable (inputs) or no such estimate (`<name>_est`, references).
pub trait VariableUnits {
    fn input_unit(&self, name: &str) -> Option<String>;
    fn estimate_unit(&self, name: &str) -> Option<String>;
}

impl Map {
    /// Reads `path` and checks every entry against `fmu`.
    pub fn read(path: &Path, fmu: &dyn VariableUnits) -> Result<Map> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("map {}: cannot read the file", path.display()))?;
        Self::parse(&text, path, fmu)
    }

    /// Parses the map `text` (read from `path`, named in messages).
    pub fn parse(text: &str, path: &Path, fmu: &dyn VariableUnits) -> Result<Map> {
        let at = |span: Range<usize>| location(text, span.start);
        let fail = |where_: Location, message: String| {
            anyhow!(
                "map {}, line {}, column {}: {message}",
                path.display(),
                where_.line,
                where_.column
            )
        };
        let file: MapFile = toml::from_str(text).map_err(|e| {
            let where_ = e.span().map_or(Location { line: 1, column: 1 }, &at);
            fail(where_, e.message().to_string())
        })?;
        let time_factor = match &file.log.time_unit {
            None => 1.0,
            Some(unit) => match unit.get_ref().as_str() {
                "s" => 1.0,
                "ms" => 1e-3,
                "us" => 1e-6,
                "ns" => 1e-9,
                other => {
                    return Err(fail(
                        at(unit.span()),
                        format!("log.time_unit {other:?}: expected s, ms, us or ns"),
                    ))
                }
            },
        };
        let align = match &file.log.align {
            None => Alignment::Hold,
            Some(a) => Alignment::from_name(a.get_ref()).ok_or_else(|| {
                fail(
                    at(a.span()),
                    format!(
                        "log.align {:?}: expected \"hold\" or \"linear\"",
                        a.get_ref()
                    ),
                )
            })?,
        };
        let mut inputs = Vec::new();
        for (name, entry) in &file.inputs {
            let here = at(entry.span());
            let si = fmu.input_unit(name).ok_or_else(|| {
                fail(
                    here,
                    format!("inputs.{name}: the estimator FMU has no input {name:?}"),
                )
            })?;
            inputs.push(
                resolve(&format!("inputs.{name}"), name, entry, &si, &at)
                    .map_err(|(w, m)| fail(w, m))?,
            );
        }
        let mut references = Vec::new();
        for (name, entry) in &file.reference {
            let here = at(entry.span());
            let si = fmu.estimate_unit(name).ok_or_else(|| {
                fail(here, format!("reference.{name}: the estimator FMU has no output {name}_est to score against it"))
            })?;
            references.push(
                resolve(&format!("reference.{name}"), name, entry, &si, &at)
                    .map_err(|(w, m)| fail(w, m))?,
            );
        }
        Ok(Map {
            path: path.to_path_buf(),
            time_column: file.log.time.unwrap_or_else(|| String::from("time")),
            time_factor,
            step: file.log.step,
            align,
            stale_after: file.log.stale_after,
            fmu: file.estimator.fmu,
            parameters: file.estimator.parameters,
            inputs,
            references,
        })
    }

    /// The log columns the map reads, each once, in map order.
    pub fn columns(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for channel in self.inputs.iter().chain(&self.references) {
            if let Source::Column { name, .. } = &channel.source {
                if !names.contains(&name.as_str()) {
                    names.push(name);
                }
            }
        }
        names
    }

    /// "map <file>, line L, column C" of a place in this map.
    pub fn describe(&self, at: Location) -> String {
        format!(
            "map {}, line {}, column {}",
            self.path.display(),
            at.line,
            at.column
        )
    }
}

/// One entry: its source and the factor from its unit, sign and steering ratio to `si`.
fn resolve(
    field: &str,
    target: &str,
    entry: &Spanned<EntryFile>,
    si: &str,
    at: &dyn Fn(Range<usize>) -> Location,
) -> Result<Channel, (Location, String)> {
    let here = at(entry.span());
    let e = entry.get_ref();
    let source = match (&e.column, e.value) {
        (Some(c), None) => Source::Column {
            name: c.get_ref().clone(),
            at: at(c.span()),
        },
        (None, Some(v)) => Source::Constant(v),
        _ => {
            return Err((
                here,
                format!(
                    "{field}: give either column = \"<log column>\" or value = <constant in {si}>"
                ),
            ))
        }
    };
    let (unit, unit_at) = match (&e.unit, &source) {
        (Some(u), _) => (u.get_ref().clone(), at(u.span())),
        (None, Source::Constant(_)) => (si.to_string(), here),
        (None, Source::Column { .. }) => {
            let accepted: Vec<&str> = units::units_of(si).iter().map(|(n, _)| *n).collect();
            return Err((
                here,
                format!(
                    "{field}: no unit; give unit = one of {}",
                    accepted.join(", ")
                ),
            ));
        }
    };
    let mut factor = units::factor(&unit, si, e.wheel_radius)
        .map_err(|m| (unit_at, format!("{field}.unit: {m}")))?;
    if let Some(ratio) = e.steering_ratio {
        // A steering-wheel angle: the road-wheel angle is it divided by the steering ratio.
        if si != "rad" || !(ratio.is_finite() && ratio > 0.0) {
            return Err((here, format!("{field}.steering_ratio = {ratio}: only an angle (rad) input takes a positive steering ratio")));
        }
        factor /= ratio;
    }
    if let Some(sign) = &e.sign {
        let s = *sign.get_ref();
        if s != 1.0 && s != -1.0 {
            return Err((at(sign.span()), format!("{field}.sign = {s}: expected 1 (the log's positive direction is ISO 8855's) or -1 (the opposite)")));
        }
        factor *= s;
    }
    Ok(Channel {
        target: target.to_string(),
        source,
        unit,
        si: si.to_string(),
        factor,
        offset: e.offset.unwrap_or(0.0),
        stale_after: e.stale_after,
        at: here,
    })
}

/// Line and column (1-based, in characters) of byte `offset` of `text`.
fn location(text: &str, offset: usize) -> Location {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    Location {
        line,
        column: before[line_start..].chars().count() + 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An estimator with one input of each unit the map test uses.
    struct Units;
    impl VariableUnits for Units {
        fn input_unit(&self, name: &str) -> Option<String> {
            match name {
                "steering_angle" => Some("rad".into()),
                "ay_meas" => Some("m/s2".into()),
                _ => None,
            }
        }
        fn estimate_unit(&self, name: &str) -> Option<String> {
            (name == "sideslip").then(|| "rad".into())
        }
    }

    fn parse(text: &str) -> Result<Map> {
        Map::parse(text, Path::new("m.toml"), &Units)
    }

    #[test]
    fn entries_resolve_to_si_factors_and_errors_name_line_and_column() {
        let map = parse(
            "[log]\ntime_unit = \"ms\"\nalign = \"linear\"\n[inputs.steering_angle]\ncolumn = \"swa\"\nunit = \"deg\"\nsteering_ratio = 16.0\nsign = -1\n[inputs.ay_meas]\nvalue = 0.5\n[reference.sideslip]\ncolumn = \"beta\"\nunit = \"rad\"\n",
        )
        .unwrap();
        assert_eq!((map.time_factor, map.align), (1e-3, Alignment::Linear));
        assert_eq!(map.inputs[1].factor, -std::f64::consts::PI / 180.0 / 16.0);
        assert_eq!(map.inputs[0].source, Source::Constant(0.5));
        assert_eq!(map.columns(), ["swa", "beta"]);
        let error = |text: &str| format!("{:#}", parse(text).unwrap_err());
        let e = error("[inputs.ay_meas]\ncolumn = \"a\"\nunit = \"deg\"\n");
        assert!(
            e.starts_with("map m.toml, line 3, column 8:") && e.contains("m/s2, m/s^2, g"),
            "{e}"
        );
        let e = error("[inputs.ay_meas]\ncolumn = \"a\"\nunit = \"g\"\nsign = 2\n");
        assert!(e.starts_with("map m.toml, line 4, column 8:"), "{e}");
        let e = error("[inputs.yaw]\ncolumn = \"a\"\nunit = \"g\"\n");
        assert!(e.contains("no input \"yaw\""), "{e}");
        let e = error("[inputs.ay_meas]\ncolumn = \"a\"\nunit = \"g\"\n[log]\nalign = \"cubic\"\n");
        assert!(e.starts_with("map m.toml, line 5, column 9:"), "{e}");
    }
}
