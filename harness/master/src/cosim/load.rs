//! Load step: the FMUs each once, their parameters checked against the model descriptions, the
//! connections resolved and the instances ordered.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};

use super::{InstancePlan, ParameterValue, TypedGroup};
use crate::fmu::{LoadedFmu, VariableInfo, VariableType};
use crate::scenario::{Scenario, VarRef};
use crate::ssv::{read_parameter_file, SsvValue};

/// One resolved connection: output `output` of instance `from` drives input `input` of `to`.
pub(super) struct Edge {
    pub(super) from: usize,
    pub(super) output: VariableInfo,
    pub(super) to: usize,
    pub(super) input: VariableInfo,
    /// The scenario field it comes from, for messages.
    pub(super) field: String,
}

/// What drives each `(instance, value reference)` input so far (a scenario field), so that no
/// input is driven twice.
pub(super) type Drivers = HashMap<(usize, u32), String>;

/// Load step: each distinct .fmu file once, and per `[[fmu]]` entry its parameters checked
/// against the model description.
pub(super) fn load_instances(
    scenario: &Scenario,
    fmu_dir: &Path,
    work_dir: &Path,
) -> Result<(Vec<LoadedFmu>, Vec<InstancePlan>)> {
    let source = scenario.source.display().to_string();
    let mut fmus: Vec<LoadedFmu> = Vec::new();
    let mut loaded_paths: HashMap<PathBuf, usize> = HashMap::new();
    let mut instances = Vec::new();
    for (i, section) in scenario.fmus.iter().enumerate() {
        let path = scenario.fmu_path(i, fmu_dir);
        let key = path.canonicalize().unwrap_or_else(|_| path.clone());
        let fmu = match loaded_paths.get(&key) {
            Some(&index) => index,
            None => {
                let loaded = LoadedFmu::load(&path, work_dir)
                    .with_context(|| format!("scenario {source}: fmu[{i}] ({:?})", section.name))?;
                fmus.push(loaded);
                loaded_paths.insert(key, fmus.len() - 1);
                fmus.len() - 1
            }
        };
        let mut parameters = file_parameters(scenario, i, &fmus[fmu], fmu_dir)?;
        for (name, value) in &section.parameters {
            let field = format!("scenario {source}: fmu[{i}].parameters.{name}");
            let var = settable(&fmus[fmu], name).with_context(|| field.clone())?;
            let value =
                convert_scenario_value(&fmus[fmu], var, value).with_context(|| field.clone())?;
            parameters.push((var.clone(), value));
        }
        instances.push(InstancePlan {
            name: section.name.clone(),
            fmu,
            parameters,
            parameter_signals: Vec::new(),
            inputs: TypedGroup::default(),
            reads: Vec::new(),
            read_groups: TypedGroup::default(),
            overrides: Vec::new(),
        });
    }
    Ok((fmus, instances))
}

/// The values of `[[fmu]]` entry `index`'s parameter files, in file order (a later file and
/// the scenario's own `parameters` override an earlier value, as the last set wins). Every
/// name must be a parameter of the FMU; the message names the file, its line, the parameter
/// and the FMU.
pub(super) fn file_parameters(
    scenario: &Scenario,
    index: usize,
    fmu: &LoadedFmu,
    fmu_dir: &Path,
) -> Result<Vec<(VariableInfo, ParameterValue)>> {
    let source = scenario.source.display();
    let mut values = Vec::new();
    for file in 0..scenario.fmus[index].parameter_files.len() {
        let field = format!("scenario {source}: fmu[{index}].parameter_files[{file}]");
        let path = scenario.parameter_file_path(index, file, fmu_dir);
        for parameter in read_parameter_file(&path).with_context(|| field.clone())? {
            let at = || {
                format!(
                    "{field}: {}, line {}: parameter {:?}",
                    path.display(),
                    parameter.line,
                    parameter.name
                )
            };
            let var = fmu.variable(&parameter.name).ok_or_else(|| {
                anyhow!(
                    "{}: FMU {} has no variable of that name",
                    at(),
                    fmu.path.display()
                )
            })?;
            if !var.is_parameter() {
                bail!(
                    "{}: {:?} of FMU {} has causality {}; a parameter file sets parameters only",
                    at(),
                    var.name,
                    fmu.path.display(),
                    var.causality
                );
            }
            let value = convert_file_value(fmu, var, &parameter.value).with_context(at)?;
            values.push((var.clone(), value));
        }
    }
    Ok(values)
}

/// Convert a parameter-file value to what `var` takes; an enumeration item by its name.
fn convert_file_value(
    fmu: &LoadedFmu,
    var: &VariableInfo,
    value: &SsvValue,
) -> Result<ParameterValue> {
    let as_toml = match value {
        SsvValue::Real(x) => toml::Value::Float(*x),
        SsvValue::Integer(x) => toml::Value::Integer(*x),
        SsvValue::Boolean(b) => toml::Value::Boolean(*b),
        SsvValue::String(s) => toml::Value::String(s.clone()),
        SsvValue::Enumeration(item) => return enumeration_item(fmu, var, item),
    };
    convert_value(var, &as_toml)
}

/// Convert a scenario's TOML value to what `var` of `fmu` takes: as [`convert_value`], and an
/// Enumeration also by its item name (`estimator = "ukf"`), looked up in the modelDescription.
pub fn convert_scenario_value(
    fmu: &LoadedFmu,
    var: &VariableInfo,
    value: &toml::Value,
) -> Result<ParameterValue> {
    match (var.var_type, value) {
        (VariableType::Enumeration, toml::Value::String(item)) => enumeration_item(fmu, var, item),
        _ => convert_value(var, value),
    }
}

/// The number of Enumeration item `item` of `var`, or an error listing the items.
pub(super) fn enumeration_item(
    fmu: &LoadedFmu,
    var: &VariableInfo,
    item: &str,
) -> Result<ParameterValue> {
    let items = fmu.enumeration_items(&var.name);
    match items.iter().find(|(name, _)| name == item) {
        Some(&(_, number)) => Ok(ParameterValue::Integer(number)),
        None => {
            let names: Vec<&str> = items.iter().map(|(n, _)| n.as_str()).collect();
            bail!(
                "enumeration item {item:?} is not one of {:?}'s items ({})",
                var.name,
                names.join(", ")
            )
        }
    }
}

/// Resolve step: every `[[connection]]` to output/input pairs (connect-by-name expanded),
/// checked for compatible types and for inputs driven twice.
pub(super) fn resolve_connections(
    scenario: &Scenario,
    fmus: &[LoadedFmu],
    instances: &[InstancePlan],
) -> Result<(Vec<Edge>, Drivers)> {
    let source = scenario.source.display().to_string();
    let instance_index: HashMap<String, usize> = instances
        .iter()
        .enumerate()
        .map(|(i, p)| (p.name.clone(), i))
        .collect();
    let var_of = |instance: usize, name: &str| -> Option<&VariableInfo> {
        fmus[instances[instance].fmu].variable(name)
    };
    let mut edges: Vec<Edge> = Vec::new();
    for (i, c) in scenario.connections.iter().enumerate() {
        let field = format!("scenario {source}: connection[{i}]");
        match (VarRef::parse(&c.from), VarRef::parse(&c.to)) {
            (Some(from), Some(to)) => {
                let a = instance_index[&from.instance];
                let b = instance_index[&to.instance];
                let out = var_of(a, &from.variable)
                    .filter(|v| v.is_output())
                    .ok_or_else(|| {
                        anyhow!(
                            "{field}.from: FMU '{}' has no output named {:?}",
                            from.instance,
                            from.variable
                        )
                    })?;
                let inp = var_of(b, &to.variable)
                    .filter(|v| v.is_input())
                    .ok_or_else(|| {
                        anyhow!(
                            "{field}.to: FMU '{}' has no input named {:?}",
                            to.instance,
                            to.variable
                        )
                    })?;
                edges.push(Edge {
                    from: a,
                    output: out.clone(),
                    to: b,
                    input: inp.clone(),
                    field,
                });
            }
            _ => {
                let a = instance_index[&c.from];
                let b = instance_index[&c.to];
                let before = edges.len();
                for out in fmus[instances[a].fmu]
                    .variables
                    .iter()
                    .filter(|v| v.is_output())
                {
                    if let Some(inp) = var_of(b, &out.name).filter(|v| v.is_input()) {
                        edges.push(Edge {
                            from: a,
                            output: out.clone(),
                            to: b,
                            input: inp.clone(),
                            field: field.clone(),
                        });
                    }
                }
                if edges.len() == before {
                    bail!(
                        "{field}: connect-by-name found no output of '{}' with the name of an input of '{}'",
                        c.from,
                        c.to
                    );
                }
            }
        }
    }
    let drivers = check_connections(&edges, instances)?;
    Ok((edges, drivers))
}

/// Every connection joins compatible types and drives an input no other connection drives.
pub(super) fn check_connections(edges: &[Edge], instances: &[InstancePlan]) -> Result<Drivers> {
    for e in edges {
        if !compatible(e.output.var_type, e.input.var_type) {
            bail!(
                "{}: cannot connect {:?} ({:?}) to {:?} ({:?})",
                e.field,
                e.output.name,
                e.output.var_type,
                e.input.name,
                e.input.var_type
            );
        }
    }
    let mut driven: Drivers = HashMap::new();
    for e in edges {
        if let Some(previous) = driven.insert((e.to, e.input.value_reference), e.field.clone()) {
            bail!(
                "{}: input {:?} of '{}' is already driven by {previous}",
                e.field,
                e.input.name,
                instances[e.to].name
            );
        }
    }
    Ok(driven)
}

pub(super) fn compatible(from: VariableType, to: VariableType) -> bool {
    use VariableType::*;
    matches!(
        (from, to),
        (Real, Real) | (Integer | Enumeration, Integer | Enumeration) | (Boolean, Boolean)
    )
}

/// A variable a scenario may set before initialisation: a parameter or an input.
pub(super) fn settable<'a>(fmu: &'a LoadedFmu, name: &str) -> Result<&'a VariableInfo> {
    let var = fmu.variable(name).ok_or_else(|| {
        let mut names: Vec<&str> = fmu
            .variables
            .iter()
            .filter(|v| v.is_parameter())
            .map(|v| v.name.as_str())
            .collect();
        names.sort_unstable();
        anyhow!(
            "FMU {} has no variable named {name:?} (its parameters: {})",
            fmu.path.display(),
            names.join(", ")
        )
    })?;
    if !(var.is_parameter() || var.is_input()) {
        bail!(
            "{name:?} of FMU {} has causality {}; only parameters and inputs can be set",
            fmu.path.display(),
            var.causality
        );
    }
    Ok(var)
}

/// Convert a TOML value to what `var` takes; the error says what was expected.
pub fn convert_value(var: &VariableInfo, value: &toml::Value) -> Result<ParameterValue> {
    Ok(match (var.var_type, value) {
        (VariableType::Real, toml::Value::Float(x)) => ParameterValue::Real(*x),
        (VariableType::Real, toml::Value::Integer(x)) => ParameterValue::Real(*x as f64),
        (VariableType::Integer | VariableType::Enumeration, toml::Value::Integer(x)) => {
            ParameterValue::Integer(
                i32::try_from(*x).map_err(|_| anyhow!("{x} does not fit a 32-bit fmi2Integer"))?,
            )
        }
        (VariableType::Boolean, toml::Value::Boolean(b)) => ParameterValue::Boolean(*b),
        (VariableType::String, toml::Value::String(s)) => ParameterValue::String(s.clone()),
        (t, v) => bail!(
            "{:?} is a {t:?} variable; a {} value ({v}) does not fit",
            var.name,
            v.type_str()
        ),
    })
}

/// Instances in the order they must receive inputs: Kahn's algorithm, ties and cycles resolved
/// by declaration order.
pub(super) fn topological_order(count: usize, edges: &[Edge]) -> Vec<usize> {
    let mut indegree = vec![0usize; count];
    let mut pairs: Vec<(usize, usize)> = edges
        .iter()
        .map(|e| (e.from, e.to))
        .filter(|(a, b)| a != b)
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    for &(_, b) in &pairs {
        indegree[b] += 1;
    }
    let mut order = Vec::with_capacity(count);
    let mut done = vec![false; count];
    while order.len() < count {
        // The first ready instance in declaration order; in a cycle, the first one left.
        let next = (0..count)
            .find(|&i| !done[i] && indegree[i] == 0)
            .or_else(|| (0..count).find(|&i| !done[i]))
            .expect("some instance is left");
        done[next] = true;
        order.push(next);
        for &(a, b) in &pairs {
            if a == next && !done[b] {
                indegree[b] = indegree[b].saturating_sub(1);
            }
        }
    }
    order
}
