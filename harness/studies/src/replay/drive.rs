//! Drives the estimator FMU with aligned log signals, through FMI only (the master's
//! [`LoadedFmu`] and the `fmi` crate's Co-Simulation instance; no estimator code is linked).
//!
//! The master's [`fmi_master::cosim::Plan`] takes its inputs from manoeuvres and connections,
//! not from recorded tables, so this module adds the one loop a replay needs on top of the
//! master's public API: at each grid point `t_n` the inputs of row `n` are set, every output is
//! read and recorded, and the FMU steps `fmi2DoStep(t_n, t_{n+1} − t_n)`. That is the master's
//! step order for a lone FMU (`harness/master/src/cosim.rs`, steps 2-4).

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use fmi::fmi2::binding::fmi2Boolean;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::FmiInstance;

use fmi_master::cosim::{convert_value, ParameterValue};
use fmi_master::fmu::{LoadedFmu, VariableInfo, VariableType};
use fmi_master::fmu_log;
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
    fmu_log::install();
    let name = format!("replay{}", std::process::id());
    let mut instance = fmu
        .import()
        .instantiate_cs(&name, false, true)
        .map_err(|e| anyhow!("FMU {}: fmi2Instantiate failed: {e}", fmu.path.display()))?;
    let result = run_instance(fmu, &mut instance, &name, parameters, grid, feeds);
    if result.is_ok() {
        let _ = FmiInstance::terminate(&mut instance);
    }
    fmu_log::forget(&name);
    result
}

fn run_instance(
    fmu: &LoadedFmu,
    instance: &mut InstanceCS,
    name: &str,
    parameters: &[(VariableInfo, ParameterValue)],
    grid: &Grid,
    feeds: &[Feed],
) -> Result<Recording> {
    let fail = |call: &str, e: &dyn std::fmt::Display| {
        let said = fmu_log::take_recent(name).join(" | ");
        anyhow!(
            "FMU {}: {call} failed ({e}); the FMU logged: {said}",
            fmu.path.display()
        )
    };
    for (var, value) in parameters {
        set_parameter(instance, var, value)
            .map_err(|e| fail(&format!("setting {} = {value:?}", var.name), &e))?;
    }
    let input_refs: Vec<u32> = feeds
        .iter()
        .map(|f| {
            fmu.variable(&f.input)
                .filter(|v| v.is_input() && v.var_type == VariableType::Real)
                .map(|v| v.value_reference)
                .ok_or_else(|| anyhow!("the estimator FMU has no Real input {:?}", f.input))
        })
        .collect::<Result<_>>()?;
    let outputs = |t: VariableType| -> Vec<&VariableInfo> {
        fmu.variables
            .iter()
            .filter(|v| v.is_output() && v.var_type == t)
            .collect()
    };
    let (reals, integers) = (outputs(VariableType::Real), outputs(VariableType::Integer));
    let real_refs: Vec<u32> = reals.iter().map(|v| v.value_reference).collect();
    let integer_refs: Vec<u32> = integers.iter().map(|v| v.value_reference).collect();
    let stop = grid.time(grid.rows - 1);
    FmiInstance::enter_initialization_mode(instance, None, grid.start, Some(stop))
        .map_err(|e| fail("fmi2EnterInitializationMode", &e))?;
    let mut row_in = vec![0.0; feeds.len()];
    let mut set_inputs = |instance: &mut InstanceCS, n: usize| {
        for (value, feed) in row_in.iter_mut().zip(feeds) {
            *value = feed.values[n];
        }
        instance.set_real(&input_refs, &row_in).map(|_| ())
    };
    set_inputs(instance, 0).map_err(|e| fail("fmi2SetReal (inputs)", &e))?;
    FmiInstance::exit_initialization_mode(instance)
        .map_err(|e| fail("fmi2ExitInitializationMode", &e))?;
    let mut columns = vec![Vec::with_capacity(grid.rows); reals.len() + integers.len()];
    let (mut real_out, mut integer_out) = (vec![0.0; reals.len()], vec![0i32; integers.len()]);
    for n in 0..grid.rows {
        let t = grid.time(n);
        set_inputs(instance, n).map_err(|e| fail("fmi2SetReal (inputs)", &e))?;
        instance
            .get_real(&real_refs, &mut real_out)
            .map_err(|e| fail("fmi2GetReal", &e))?;
        instance
            .get_integer(&integer_refs, &mut integer_out)
            .map_err(|e| fail("fmi2GetInteger", &e))?;
        let row = real_out
            .iter()
            .copied()
            .chain(integer_out.iter().map(|&i| f64::from(i)));
        for (column, value) in columns.iter_mut().zip(row) {
            column.push(value);
        }
        if n + 1 < grid.rows {
            let h = grid.time(n + 1) - t;
            instance
                .do_step(t, h, true)
                .map_err(|e| fail(&format!("fmi2DoStep(t = {t} s, h = {h} s)"), &e))?;
        }
    }
    Ok(Recording {
        names: reals
            .iter()
            .chain(&integers)
            .map(|v| v.name.clone())
            .collect(),
        columns,
    })
}

fn set_parameter(
    instance: &mut InstanceCS,
    var: &VariableInfo,
    value: &ParameterValue,
) -> Result<()> {
    let reference = [var.value_reference];
    match value {
        ParameterValue::Real(x) => instance.set_real(&reference, &[*x]).map(|_| ())?,
        ParameterValue::Integer(i) => instance.set_integer(&reference, &[*i]).map(|_| ())?,
        ParameterValue::Boolean(b) => instance
            .set_boolean(&reference, &[fmi2Boolean::from(*b)])
            .map(|_| ())?,
        ParameterValue::String(_) => {
            bail!("{:?}: the estimator has no String parameters", var.name)
        }
    }
    Ok(())
}
