//! Drives the estimator FMU with aligned log signals, through FMI only (the master's
//! [`LoadedFmu`] and [`FmuInstance`]; no estimator code is linked).
//!
//! The master's [`fmi_master::cosim::Plan`] takes its inputs from manoeuvres and connections,
//! not from recorded tables, so this module adds the one loop a replay needs on top of the
//! master's public API: at each grid point `t_n` the inputs of row `n` are set, every output is
//! read and recorded, and the FMU steps `fmi2DoStep(t_n, t_{n+1} − t_n)`. That is the master's
//! step order for a lone FMU (`harness/master/src/cosim/mod.rs`, steps 2-4).

use std::path::Path;

use anyhow::{anyhow, Context, Result};

use fmi_master::cosim::{convert_value, ParameterValue};
use fmi_master::fmu::{LoadedFmu, VariableInfo, VariableType};
use fmi_master::instance::{FmiVersion, FmuInstance, InstanceError};
use fmi_master::ssv::{read_parameter_file, SsvValue};

use super::align::Grid;

/// One FMU input and its value at every grid row (SI units; NaN = sample missing).
#[derive(Debug, Clone)]
pub struct Feed {
    pub input: String,
    pub values: Vec<f64>,
}

/// The recorded outputs: `columns[k][n]` is output `names[k]` at grid row `n`.
#[derive(Debug, Clone)]
pub struct Recording {
    pub names: Vec<String>,
    pub columns: Vec<Vec<f64>>,
}

impl Recording {
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|k| self.columns[k].as_slice())
    }
}

/// A parameter the FMU declares, for setting it; the message lists what it has.
pub fn parameter<'a>(fmu: &'a LoadedFmu, name: &str) -> Result<&'a VariableInfo> {
    fmu.variable(name)
        .filter(|v| v.is_parameter())
        .ok_or_else(|| {
            anyhow!(
                "the estimator FMU {} has no parameter {name:?}",
                fmu.path.display()
            )
        })
}

/// The values of an SSP parameter-value file for `fmu` (every name must be a parameter of it;
/// an enumeration item is set as its number). Errors name the file and line.
pub fn parameters_from_file(
    fmu: &LoadedFmu,
    path: &Path,
) -> Result<Vec<(VariableInfo, ParameterValue)>> {
    let mut values = Vec::new();
    for entry in read_parameter_file(path)? {
        let at = || format!("parameter file {}, line {}", path.display(), entry.line);
        let var = parameter(fmu, &entry.name).with_context(at)?;
        let value = match &entry.value {
            SsvValue::Enumeration(item) => fmu
                .enumeration_items(&var.name)
                .iter()
                .find(|(name, _)| name == item)
                .map(|&(_, number)| ParameterValue::Integer(number))
                .ok_or_else(|| anyhow!("{}: {item:?} is no item of {:?}", at(), var.name))?,
            SsvValue::Real(x) => convert_value(var, &toml::Value::Float(*x)).with_context(at)?,
            SsvValue::Integer(x) => {
                convert_value(var, &toml::Value::Integer(*x)).with_context(at)?
            }
            SsvValue::Boolean(b) => {
                convert_value(var, &toml::Value::Boolean(*b)).with_context(at)?
            }
            SsvValue::String(s) => {
                convert_value(var, &toml::Value::String(s.clone())).with_context(at)?
            }
        };
        values.push((var.clone(), value));
    }
    Ok(values)
}

/// The values of a TOML table of parameters (the map's `[estimator.parameters]`).
pub fn parameters_from_table(
    fmu: &LoadedFmu,
    table: &toml::Table,
    origin: &str,
) -> Result<Vec<(VariableInfo, ParameterValue)>> {
    table
        .iter()
        .map(|(name, value)| {
            let var = parameter(fmu, name).with_context(|| format!("{origin}: {name}"))?;
            let value = convert_value(var, value).with_context(|| format!("{origin}: {name}"))?;
            Ok((var.clone(), value))
        })
        .collect()
}

/// Runs `fmu` over `grid` with `parameters` (in order, the last of a name wins) and the inputs
/// `feeds`; records every Real and Integer output.
pub fn run(
    fmu: &LoadedFmu,
    parameters: &[(VariableInfo, ParameterValue)],
    grid: &Grid,
    feeds: &[Feed],
) -> Result<Recording> {
    let fail = |e: InstanceError| anyhow!("FMU {}: {e}", fmu.path.display());
    // One name per process: the replay's FMU messages are reported under it.
    let name = format!("replay{}", std::process::id());
    let mut instance = FmuInstance::new(fmu, &name, FmiVersion::Fmi2).map_err(fail)?;
    for (var, value) in parameters {
        instance.set_parameter(&var.name, value).map_err(fail)?;
    }
    let mut inputs = Inputs::new(&instance, feeds).map_err(fail)?;
    let mut outputs = Outputs::new(fmu, grid.rows);
    let stop = grid.time(grid.rows - 1);
    instance
        .enter_initialization_mode(grid.start, stop)
        .map_err(fail)?;
    inputs.set(&mut instance, 0).map_err(fail)?;
    instance.exit_initialization_mode().map_err(fail)?;
    for n in 0..grid.rows {
        inputs.set(&mut instance, n).map_err(fail)?;
        outputs.record(&mut instance).map_err(fail)?;
        if n + 1 < grid.rows {
            let t = grid.time(n);
            instance.do_step(t, grid.time(n + 1) - t).map_err(fail)?;
        }
    }
    Ok(outputs.into_recording())
}

/// The FMU's Real inputs the feeds drive, and one row of their values.
struct Inputs<'f> {
    feeds: &'f [Feed],
    references: Vec<u32>,
    row: Vec<f64>,
}

impl<'f> Inputs<'f> {
    fn new(instance: &FmuInstance, feeds: &'f [Feed]) -> Result<Self, InstanceError> {
        let references = feeds
            .iter()
            .map(|feed| instance.real_input(&feed.input))
            .collect::<Result<_, _>>()?;
        Ok(Inputs {
            feeds,
            references,
            row: vec![0.0; feeds.len()],
        })
    }

    /// Sets the inputs of grid row `n`.
    fn set(&mut self, instance: &mut FmuInstance, n: usize) -> Result<(), InstanceError> {
        for (value, feed) in self.row.iter_mut().zip(self.feeds) {
            *value = feed.values[n];
        }
        instance.set_reals(&self.references, &self.row)
    }
}

/// Every Real and Integer output of the FMU, and their columns so far.
struct Outputs<'a> {
    reals: Vec<&'a VariableInfo>,
    integers: Vec<&'a VariableInfo>,
    real_references: Vec<u32>,
    integer_references: Vec<u32>,
    real_row: Vec<f64>,
    integer_row: Vec<i32>,
    /// The Reals' columns, then the Integers'.
    columns: Vec<Vec<f64>>,
}

impl<'a> Outputs<'a> {
    fn new(fmu: &'a LoadedFmu, rows: usize) -> Self {
        let of_type = |t: VariableType| -> Vec<&VariableInfo> {
            (fmu.variables.iter())
                .filter(|v| v.is_output() && v.var_type == t)
                .collect()
        };
        let (reals, integers) = (of_type(VariableType::Real), of_type(VariableType::Integer));
        let references = |vars: &[&VariableInfo]| vars.iter().map(|v| v.value_reference).collect();
        Outputs {
            real_references: references(&reals),
            integer_references: references(&integers),
            real_row: vec![0.0; reals.len()],
            integer_row: vec![0; integers.len()],
            columns: vec![Vec::with_capacity(rows); reals.len() + integers.len()],
            reals,
            integers,
        }
    }

    /// Reads every output and appends it to its column.
    fn record(&mut self, instance: &mut FmuInstance) -> Result<(), InstanceError> {
        instance.get_reals(&self.real_references, &mut self.real_row)?;
        instance.get_integers(&self.integer_references, &mut self.integer_row)?;
        let row =
            (self.real_row.iter().copied()).chain(self.integer_row.iter().map(|&i| f64::from(i)));
        for (column, value) in self.columns.iter_mut().zip(row) {
            column.push(value);
        }
        Ok(())
    }

    fn into_recording(self) -> Recording {
        Recording {
            names: (self.reals.iter().chain(&self.integers))
                .map(|v| v.name.clone())
                .collect(),
            columns: self.columns,
        }
    }
}
