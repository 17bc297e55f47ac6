//! The co-simulation master for FMI 2.0 Co-Simulation FMUs.
//!
//! Algorithm at each communication point `t_n = t0 + n h` (never accumulated):
//! 1. a closed-loop manoeuvre reads the vehicle motion it needs (its `feedback` variables, values
//!    of the FMU state at `t_n`) and computes its signals for `t_n`;
//! 2. the FMU instances are visited in topological order of the connections (sources before
//!    sinks, declaration order among equals): each gets its manoeuvre inputs and its connected
//!    inputs — read from upstream instances *after* those received their inputs of `t_n`, so an
//!    output with direct feed-through (e.g. the measured lateral acceleration, which depends on
//!    the steering angle) reaches the downstream FMU within the same step — and then its needed
//!    outputs are read;
//! 3. the row of recorded values at `t_n` is stored;
//! 4. every instance does `fmi2DoStep(t_n, t_{n+1} - t_n)`.
//!
//! Connections that close a cycle cannot all be satisfied this way: the instances of a cycle are
//! visited in declaration order and a connection pointing backwards in that order delivers the
//! source's output of `t_n` computed with its inputs of `t_{n-1}` (documented in
//! `harness/scenarios/README.md`).
//!
//! Every `fmi::fmi2::instance::Instance` is created on the thread that runs it (inside
//! [`Plan::run`]) and dropped before the [`LoadedFmu`] that owns its `Fmi2Import`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use fmi::fmi2::binding::fmi2Boolean;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::FmiInstance;

use crate::fmu::{LoadedFmu, VariableInfo, VariableType};
use crate::fmu_log;
use crate::scenario::{Scenario, VarRef};
use crate::ssv::{read_parameter_file, SsvValue};
use manoeuvres::{Channel, Manoeuvre, ManoeuvreRun, VehicleMotion};

/// The scenario with its FMUs loaded (each distinct .fmu file once) and every name resolved.
pub struct Plan {
    pub scenario: Scenario,
    pub manoeuvre: Option<Manoeuvre>,
    instances: Vec<InstancePlan>,
    /// Instance indices in the order they receive inputs and step.
    order: Vec<usize>,
    columns: Vec<String>,
    record: Vec<Slot>,
    feedback: Option<Feedback>,
    /// Recording blocks of finished runs handed back by [`Plan::recycle`], for the next runs.
    spare_tables: Mutex<Vec<Vec<f64>>>,
    /// Loaded archives; declared last so every borrowed use ends before they drop.
    fmus: Vec<LoadedFmu>,
}

/// The most values (rows times columns) one run may record: 800 MB of f64 (issue 15, point 6).
pub const MAX_RECORDED_VALUES: u64 = 100_000_000;

struct Feedback {
    instance: usize,
    value_references: [u32; 3],
}

#[derive(Debug, Clone, Copy)]
enum Source {
    Channel(Channel),
    Upstream { instance: usize, slot: usize },
}

#[derive(Debug, Clone, Copy)]
enum Slot {
    Read { instance: usize, slot: usize },
    Channel(Channel),
    PoseX,
    PoseY,
    PoseYaw,
}

#[derive(Debug, Clone, PartialEq)]
pub enum ParameterValue {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

/// What one [[fmu]] entry does at each step, with value references resolved.
struct InstancePlan {
    name: String,
    fmu: usize,
    parameters: Vec<(VariableInfo, ParameterValue)>,
    /// Manoeuvre channels bound to parameters (e.g. initial_speed -> vx0), set before init.
    parameter_signals: Vec<(VariableInfo, Channel)>,
    inputs: TypedGroup<Source>,
    /// Variables read after the inputs are set; `reads[slot]`.
    reads: Vec<(u32, VariableType)>,
    read_groups: TypedGroup<usize>,
    /// `[[override]]` windows on this instance's Real inputs.
    overrides: Vec<InputOverride>,
}

/// One `[[override]]` target: `inputs.real` entry `position` gets `value` at the communication
/// points `t` with `from <= t <= to` (half a step beyond the first and last covered point).
#[derive(Debug, Clone, Copy)]
struct InputOverride {
    position: usize,
    from: f64,
    to: f64,
    value: f64,
}

/// Value references split by C type, each with what goes with it.
struct TypedGroup<T> {
    real: (Vec<u32>, Vec<T>),
    integer: (Vec<u32>, Vec<T>),
    boolean: (Vec<u32>, Vec<T>),
}

impl<T> Default for TypedGroup<T> {
    fn default() -> Self {
        TypedGroup {
            real: (Vec::new(), Vec::new()),
            integer: (Vec::new(), Vec::new()),
            boolean: (Vec::new(), Vec::new()),
        }
    }
}

impl<T> TypedGroup<T> {
    fn push(&mut self, var_type: VariableType, vr: u32, item: T) {
        let group = match var_type {
            VariableType::Real => &mut self.real,
            VariableType::Integer | VariableType::Enumeration => &mut self.integer,
            VariableType::Boolean => &mut self.boolean,
            VariableType::String => unreachable!("strings are refused when planning"),
        };
        group.0.push(vr);
        group.1.push(item);
    }
}

/// Changes applied to one run without editing the scenario (Monte Carlo seeds, CLI overrides).
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Appended to every instance name given to fmi2Instantiate (unique names per thread).
    pub instance_suffix: String,
    /// Parameter values that replace or extend the scenario's.
    pub overrides: Vec<(VarRef, ParameterValue)>,
}

/// Everything one run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    pub scenario: String,
    pub times: Vec<f64>,
    pub columns: Vec<String>,
    /// `data[column][row]`.
    pub data: Columns,
    /// Mean wall time of one fmi2DoStep per instance [s].
    pub step_wall_time: Vec<(String, f64)>,
    /// Wall time of the whole run including instantiation [s].
    pub total_wall_time: f64,
}

impl RunResult {
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| &self.data[i])
    }
}

/// The recorded values of a run, `table[column][row]`, column after column in one block.
///
/// One block, so that a campaign can hand it back ([`Plan::recycle`]) for the next run: a run
/// records tens of columns of 10⁴ rows (about 4 MB at 1 ms for 12 s), and memory the process
/// has not used yet is faulted in page by page (a vector per column cost about 1000 page
/// faults, a tenth of a short run's time on a virtual machine).
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    columns: usize,
    rows: usize,
    values: Vec<f64>,
}

impl Columns {
    /// `columns` columns of `rows` values in the memory of `block`. Old values are left in
    /// place: a run overwrites every cell (one that fails returns no table), so zeroing the
    /// megabytes again would be wasted.
    pub(crate) fn reusing(mut block: Vec<f64>, columns: usize, rows: usize) -> Self {
        assert!(rows > 0, "a table of recorded columns has at least one row");
        block.truncate(columns * rows);
        block.resize(columns * rows, 0.0);
        Columns {
            columns,
            rows,
            values: block,
        }
    }

    /// Number of columns.
    pub fn len(&self) -> usize {
        self.columns
    }

    pub fn is_empty(&self) -> bool {
        self.columns == 0
    }

    /// Number of rows (communication points) of every column.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The columns in order.
    pub fn iter(&self) -> std::slice::ChunksExact<'_, f64> {
        self.values.chunks_exact(self.rows)
    }

    /// Writes consecutive rows, given row after row in `rows_major` (`self.len()` values each),
    /// so that the last of them is row `last_row`.
    fn write_rows(&mut self, last_row: usize, rows_major: &[f64]) {
        if self.columns == 0 {
            return;
        }
        let count = rows_major.len() / self.columns;
        let first_row = last_row + 1 - count;
        for (column, block) in self.values.chunks_exact_mut(self.rows).enumerate() {
            let cells = &mut block[first_row..=last_row];
            for (cell, row) in cells.iter_mut().zip(rows_major.chunks_exact(self.columns)) {
                *cell = row[column];
            }
        }
    }
}

impl std::ops::Index<usize> for Columns {
    type Output = [f64];

    fn index(&self, column: usize) -> &[f64] {
        assert!(
            column < self.columns,
            "column {column} of a table of {} columns",
            self.columns
        );
        &self.values[column * self.rows..(column + 1) * self.rows]
    }
}

impl<'a> IntoIterator for &'a Columns {
    type Item = &'a [f64];
    type IntoIter = std::slice::ChunksExact<'a, f64>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// A few recorded rows, row after row, before they go into the column-major table together.
///
/// Writing each communication point straight into tens of columns touches as many cache lines
/// 100 kB apart per step, about half a microsecond per step; a block of rows is written as
/// short contiguous runs per column instead.
struct StagedRows {
    columns: usize,
    values: Vec<f64>,
    rows: usize,
}

impl StagedRows {
    const CAPACITY: usize = 64;

    fn new(columns: usize) -> Self {
        StagedRows {
            columns,
            values: vec![0.0; columns * Self::CAPACITY],
            rows: 0,
        }
    }

    /// The cells of the next row (to be filled).
    fn next_row(&mut self) -> &mut [f64] {
        let start = self.rows * self.columns;
        self.rows += 1;
        &mut self.values[start..start + self.columns]
    }

    fn is_full(&self) -> bool {
        self.rows == Self::CAPACITY
    }

    /// Moves the staged rows into `table`, the last of them being row `last_row`.
    fn write_into(&mut self, table: &mut Columns, last_row: usize) {
        table.write_rows(last_row, &self.values[..self.rows * self.columns]);
        self.rows = 0;
    }
}

fn describe_fmu(plan: &Plan, instance: usize) -> String {
    let inst = &plan.instances[instance];
    format!(
        "FMU '{}' ({})",
        inst.name,
        plan.fmus[inst.fmu].path.display()
    )
}

/// One resolved connection: output `output` of instance `from` drives input `input` of `to`.
struct Edge {
    from: usize,
    output: VariableInfo,
    to: usize,
    input: VariableInfo,
    /// The scenario field it comes from, for messages.
    field: String,
}

/// What drives each `(instance, value reference)` input so far (a scenario field), so that no
/// input is driven twice.
type Drivers = HashMap<(usize, u32), String>;

/// Load step: each distinct .fmu file once, and per `[[fmu]]` entry its parameters checked
/// against the model description.
fn load_instances(
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
fn file_parameters(
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
fn enumeration_item(fmu: &LoadedFmu, var: &VariableInfo, item: &str) -> Result<ParameterValue> {
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
fn resolve_connections(
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
fn check_connections(edges: &[Edge], instances: &[InstancePlan]) -> Result<Drivers> {
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

/// The three variables of `[manoeuvre.feedback]`, in the order the driver reads them.
const FEEDBACK_FIELDS: [&str; 3] = ["longitudinal_velocity", "lateral_velocity", "yaw_rate"];

/// Every "inst.variable" reference of the scenario and every channel name, parsed once in the
/// resolve step; the bind steps take them as they are (a malformed one is refused here, naming
/// its field, though `Scenario::validate` has refused it already).
struct ScenarioRefs {
    /// `[[input]]`: the channel and its targets.
    inputs: Vec<(Channel, Vec<VarRef>)>,
    /// `[[override]]` targets.
    overrides: Vec<Vec<VarRef>>,
    /// `[manoeuvre.feedback]`, in [`FEEDBACK_FIELDS`] order.
    feedback: Option<[VarRef; 3]>,
    /// `[record] variables` patterns.
    record: Vec<VarRef>,
    scores: Vec<ScoreRefs>,
    /// `[[nis]]`: the NIS variable and, when given by name, its degrees of freedom.
    nis: Vec<(VarRef, Option<VarRef>)>,
}

struct ScoreRefs {
    truth: VarRef,
    estimate: VarRef,
    std: Option<VarRef>,
}

impl ScenarioRefs {
    fn parse(scenario: &Scenario) -> Result<Self> {
        let source = scenario.source.display();
        let parse = |field: String, text: &str| {
            VarRef::parse(text).ok_or_else(|| {
                anyhow!("scenario {source}: {field}: {text:?}: expected \"instance.variable\"")
            })
        };
        let list = |field: &str, texts: &[String]| -> Result<Vec<VarRef>> {
            let parse = &parse;
            texts
                .iter()
                .enumerate()
                .map(|(j, text)| parse(format!("{field}[{j}]"), text))
                .collect()
        };
        let mut inputs = Vec::new();
        for (i, input) in scenario.inputs.iter().enumerate() {
            let channel = Channel::from_name(&input.signal).ok_or_else(|| {
                anyhow!(
                    "scenario {source}: input[{i}].signal: no channel {:?}",
                    input.signal
                )
            })?;
            inputs.push((channel, list(&format!("input[{i}].to"), &input.to)?));
        }
        let overrides = (scenario.overrides.iter().enumerate())
            .map(|(i, o)| list(&format!("override[{i}].to"), &o.to))
            .collect::<Result<_>>()?;
        let feedback = match scenario
            .manoeuvre
            .as_ref()
            .and_then(|m| m.feedback.as_ref())
        {
            Some(fb) => {
                let field = |k: usize| format!("manoeuvre.feedback.{}", FEEDBACK_FIELDS[k]);
                Some([
                    parse(field(0), &fb.longitudinal_velocity)?,
                    parse(field(1), &fb.lateral_velocity)?,
                    parse(field(2), &fb.yaw_rate)?,
                ])
            }
            None => None,
        };
        let mut scores = Vec::new();
        for (i, s) in scenario.scores.iter().enumerate() {
            scores.push(ScoreRefs {
                truth: parse(format!("score[{i}].truth"), &s.truth)?,
                estimate: parse(format!("score[{i}].estimate"), &s.estimate)?,
                std: match &s.std {
                    Some(std) => Some(parse(format!("score[{i}].std"), std)?),
                    None => None,
                },
            });
        }
        let mut nis = Vec::new();
        for (i, n) in scenario.nis.iter().enumerate() {
            let dof = match &n.dof {
                toml::Value::String(dof) => Some(parse(format!("nis[{i}].dof"), dof)?),
                _ => None,
            };
            nis.push((parse(format!("nis[{i}].nis"), &n.nis)?, dof));
        }
        Ok(ScenarioRefs {
            inputs,
            overrides,
            feedback,
            record: list("record.variables", &scenario.record.variables)?,
            scores,
            nis,
        })
    }
}

impl Plan {
    /// Load the scenario's FMUs (extracted under `work_dir`) and resolve every name: load the
    /// FMUs, resolve the connections, order the instances, bind inputs, feedback and recording.
    pub fn new(scenario: Scenario, fmu_dir: &Path, work_dir: &Path) -> Result<Plan> {
        let manoeuvre = scenario.manoeuvre()?;
        let (fmus, instances) = load_instances(&scenario, fmu_dir, work_dir)?;
        let (edges, mut driven) = resolve_connections(&scenario, &fmus, &instances)?;
        let refs = ScenarioRefs::parse(&scenario)?;
        let mut plan = Plan {
            manoeuvre,
            order: topological_order(instances.len(), &edges),
            instances,
            columns: Vec::new(),
            record: Vec::new(),
            feedback: None,
            spare_tables: Mutex::new(Vec::new()),
            fmus,
            scenario,
        };
        plan.bind_connections(&edges);
        plan.bind_manoeuvre_inputs(&refs, &mut driven)?;
        plan.bind_overrides(&refs)?;
        plan.bind_feedback(&refs)?;
        plan.bind_recording(&refs)?;
        Ok(plan)
    }

    /// The scenario file, for messages.
    fn source(&self) -> String {
        self.scenario.source.display().to_string()
    }

    /// Each connection's sink input reads its source's output slot.
    fn bind_connections(&mut self, edges: &[Edge]) {
        for e in edges {
            let slot = self.read_slot(e.from, &e.output);
            self.instances[e.to].inputs.push(
                e.input.var_type,
                e.input.value_reference,
                Source::Upstream {
                    instance: e.from,
                    slot,
                },
            );
        }
    }

    /// `[[input]]`: manoeuvre channels to Real inputs (each step) or parameters (before init).
    fn bind_manoeuvre_inputs(&mut self, refs: &ScenarioRefs, driven: &mut Drivers) -> Result<()> {
        let source = self.source();
        for (i, (channel, targets)) in refs.inputs.iter().enumerate() {
            let channel = *channel;
            for (j, r) in targets.iter().enumerate() {
                let field = format!("scenario {source}: input[{i}].to[{j}]");
                let matches = self.matching(r, |v| v.is_input() || v.is_parameter());
                if matches.is_empty() {
                    bail!("{field}: \"{r}\" names no input or parameter of any FMU");
                }
                for (instance, var) in matches {
                    self.bind_channel(instance, var, channel, &field, driven)?;
                }
            }
        }
        Ok(())
    }

    fn bind_channel(
        &mut self,
        instance: usize,
        var: VariableInfo,
        channel: Channel,
        field: &str,
        driven: &mut Drivers,
    ) -> Result<()> {
        if var.var_type != VariableType::Real {
            bail!(
                "{field}: {}.{} is not a Real variable",
                self.instances[instance].name,
                var.name
            );
        }
        if let Some(previous) = driven.insert((instance, var.value_reference), field.to_string()) {
            bail!(
                "{field}: {}.{} is already driven by {previous}",
                self.instances[instance].name,
                var.name
            );
        }
        if var.is_parameter() {
            self.instances[instance]
                .parameter_signals
                .push((var, channel));
        } else {
            self.instances[instance].inputs.push(
                var.var_type,
                var.value_reference,
                Source::Channel(channel),
            );
        }
        Ok(())
    }

    /// `[[override]]`: each target must be a Real input some connection or `[[input]]` drives.
    fn bind_overrides(&mut self, refs: &ScenarioRefs) -> Result<()> {
        let source = self.source();
        let (t0, h) = (self.scenario.start_time, self.scenario.step);
        for (i, section) in self.scenario.overrides.clone().iter().enumerate() {
            let (first, last) = section.points(t0, h);
            let (from, to) = (
                self.scenario.time_of(first) - 0.5 * h,
                self.scenario.time_of(last) + 0.5 * h,
            );
            for (j, r) in refs.overrides[i].iter().enumerate() {
                let field = format!("scenario {source}: override[{i}].to[{j}]");
                let matches = self.matching(r, |v| v.is_input());
                if matches.is_empty() {
                    bail!("{field}: \"{r}\" names no input of any FMU");
                }
                for (instance, var) in matches {
                    let plan = &mut self.instances[instance];
                    let position = plan
                        .inputs
                        .real
                        .0
                        .iter()
                        .position(|&vr| vr == var.value_reference)
                        .ok_or_else(|| {
                            anyhow!(
                                "{field}: {}.{} is not a Real input driven by a connection or an [[input]]",
                                plan.name,
                                var.name
                            )
                        })?;
                    plan.overrides.push(InputOverride {
                        position,
                        from,
                        to,
                        value: section.value,
                    });
                }
            }
        }
        Ok(())
    }

    /// `[manoeuvre.feedback]`: the three Real variables of one FMU a closed-loop driver reads.
    fn bind_feedback(&mut self, refs: &ScenarioRefs) -> Result<()> {
        let source = self.source();
        let Some(feedback) = &refs.feedback else {
            return Ok(());
        };
        let mut vrs = [0u32; 3];
        let mut instances = [0usize; 3];
        for (k, (field, r)) in FEEDBACK_FIELDS.iter().zip(feedback).enumerate() {
            let instance =
                self.instance_index(&r.instance, &format!("manoeuvre.feedback.{field}"))?;
            let var = self
                .var(instance, &r.variable)
                .filter(|v| v.var_type == VariableType::Real)
                .ok_or_else(|| {
                    anyhow!(
                        "scenario {source}: manoeuvre.feedback.{field}: FMU '{}' has no Real variable {:?}",
                        r.instance,
                        r.variable
                    )
                })?;
            instances[k] = instance;
            vrs[k] = var.value_reference;
        }
        if instances.iter().any(|&i| i != instances[0]) {
            bail!(
                "scenario {source}: manoeuvre.feedback: all three variables must come from one FMU"
            );
        }
        self.feedback = Some(Feedback {
            instance: instances[0],
            value_references: vrs,
        });
        Ok(())
    }

    /// The instance called `name`; `field` names the reference for the message.
    fn instance_index(&self, name: &str, field: &str) -> Result<usize> {
        self.instances
            .iter()
            .position(|p| p.name == name)
            .ok_or_else(|| {
                anyhow!(
                    "scenario {}: {field}: no FMU instance {name:?}",
                    self.source()
                )
            })
    }

    /// Recorded columns: the manoeuvre's signals, the driver's pose, then the `[record]`
    /// patterns and everything scores and NIS need, each column once.
    fn bind_recording(&mut self, refs: &ScenarioRefs) -> Result<()> {
        if let Some(m) = self.manoeuvre.clone() {
            for channel in [
                Channel::SteeringAngle,
                Channel::SteeringWheelAngle,
                Channel::DriveTorque,
                Channel::BrakeTorque,
            ] {
                self.add_column(
                    format!("manoeuvre.{}", channel.name()),
                    Slot::Channel(channel),
                );
            }
            if m.needs_feedback() {
                self.add_column("driver.x".into(), Slot::PoseX);
                self.add_column("driver.y".into(), Slot::PoseY);
                self.add_column("driver.yaw".into(), Slot::PoseYaw);
            }
        }
        let mut wanted = self.recorded_patterns(refs)?;
        wanted.extend(self.score_variables(refs)?);
        wanted.extend(self.nis_variables(refs)?);
        for (instance, var) in wanted {
            let column = format!("{}.{}", self.instances[instance].name, var.name);
            if self.columns.contains(&column) {
                continue;
            }
            let slot = self.read_slot(instance, &var);
            self.add_column(column, Slot::Read { instance, slot });
        }
        Ok(())
    }

    /// `(instance, variable)` of every `[record] variables` pattern (`inst.*`: all outputs).
    fn recorded_patterns(&self, refs: &ScenarioRefs) -> Result<Vec<(usize, VariableInfo)>> {
        let source = self.source();
        let mut wanted = Vec::new();
        for (i, r) in refs.record.iter().enumerate() {
            let matches = if r.variable == "*" {
                let mut all = Vec::new();
                for instance in self.instance_indices(&r.instance) {
                    for v in self.fmus[self.instances[instance].fmu].variables.iter() {
                        if v.is_output() && v.var_type != VariableType::String {
                            all.push((instance, v.clone()));
                        }
                    }
                }
                all
            } else {
                self.matching(r, |v| v.var_type != VariableType::String)
            };
            if matches.is_empty() {
                bail!("scenario {source}: record.variables[{i}]: \"{r}\" matches no variable");
            }
            wanted.extend(matches);
        }
        Ok(wanted)
    }

    /// The truth, estimate and standard-deviation variables of every `[[score]]`.
    fn score_variables(&self, refs: &ScenarioRefs) -> Result<Vec<(usize, VariableInfo)>> {
        let source = self.source();
        let mut wanted = Vec::new();
        for (i, score) in refs.scores.iter().enumerate() {
            let field = format!("scenario {source}: score[{i}]");
            let truth = &score.truth;
            let t_inst = self.instance_index(&truth.instance, &format!("score[{i}].truth"))?;
            let var = self.var(t_inst, &truth.variable).ok_or_else(|| {
                anyhow!(
                    "{field}.truth: FMU '{}' has no variable {:?}",
                    truth.instance,
                    truth.variable
                )
            })?;
            wanted.push((t_inst, var.clone()));
            let matches = self.matching(&score.estimate, |_| true);
            if matches.is_empty() {
                bail!(
                    "{field}.estimate: \"{}\" matches no variable",
                    score.estimate
                );
            }
            for (instance, var) in matches {
                let name = &self.instances[instance].name;
                if let Some(std_ref) = &score.std {
                    if std_ref.instance != "*" && std_ref.instance != *name {
                        bail!("{field}.std: \"{std_ref}\" must belong to the estimate's instance '{name}' (or use '*')");
                    }
                    let std = self.var(instance, &std_ref.variable).ok_or_else(|| {
                        anyhow!(
                            "{field}.std: FMU '{name}' has no variable {:?}",
                            std_ref.variable
                        )
                    })?;
                    wanted.push((instance, std.clone()));
                }
                wanted.push((instance, var));
            }
        }
        Ok(wanted)
    }

    /// The NIS (and degrees-of-freedom) variables of every `[[nis]]`.
    fn nis_variables(&self, refs: &ScenarioRefs) -> Result<Vec<(usize, VariableInfo)>> {
        let source = self.source();
        let mut wanted = Vec::new();
        for (i, (nis, dof)) in refs.nis.iter().enumerate() {
            let matches = self.matching(nis, |_| true);
            if matches.is_empty() {
                bail!("scenario {source}: nis[{i}].nis: \"{nis}\" matches no variable");
            }
            for (instance, var) in matches {
                if let Some(d) = dof {
                    let dof_var = self.var(instance, &d.variable).ok_or_else(|| {
                        anyhow!(
                            "scenario {source}: nis[{i}].dof: FMU '{}' has no variable {:?}",
                            self.instances[instance].name,
                            d.variable
                        )
                    })?;
                    wanted.push((instance, dof_var.clone()));
                }
                wanted.push((instance, var));
            }
        }
        Ok(wanted)
    }

    fn add_column(&mut self, name: String, slot: Slot) {
        self.columns.push(name);
        self.record.push(slot);
    }

    fn var(&self, instance: usize, name: &str) -> Option<&VariableInfo> {
        self.fmus[self.instances[instance].fmu].variable(name)
    }

    fn instance_indices(&self, pattern: &str) -> Vec<usize> {
        (0..self.instances.len())
            .filter(|&i| pattern == "*" || self.instances[i].name == pattern)
            .collect()
    }

    /// Instances (by pattern) having variable `r.variable` accepted by `filter`.
    fn matching(
        &self,
        r: &VarRef,
        filter: impl Fn(&VariableInfo) -> bool,
    ) -> Vec<(usize, VariableInfo)> {
        self.instance_indices(&r.instance)
            .into_iter()
            .filter_map(|i| {
                self.var(i, &r.variable)
                    .filter(|v| filter(v))
                    .map(|v| (i, v.clone()))
            })
            .collect()
    }

    /// Slot in `instance`'s read cache for `var`, added when new.
    fn read_slot(&mut self, instance: usize, var: &VariableInfo) -> usize {
        let plan = &mut self.instances[instance];
        if let Some(slot) = plan
            .reads
            .iter()
            .position(|(vr, t)| *vr == var.value_reference && *t == var.var_type)
        {
            return slot;
        }
        plan.reads.push((var.value_reference, var.var_type));
        let slot = plan.reads.len() - 1;
        plan.read_groups
            .push(var.var_type, var.value_reference, slot);
        slot
    }

    /// Recorded column names, in CSV order (after `time`).
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    pub fn instance_names(&self) -> Vec<String> {
        self.instances.iter().map(|i| i.name.clone()).collect()
    }

    /// Instance names in the order they receive inputs and step.
    pub fn step_order(&self) -> Vec<String> {
        self.order
            .iter()
            .map(|&i| self.instances[i].name.clone())
            .collect()
    }

    pub fn loaded_fmus(&self) -> &[LoadedFmu] {
        &self.fmus
    }

    /// The variable `r` names, `None` when there is no such instance or variable.
    pub fn variable_of(&self, r: &VarRef) -> Option<&VariableInfo> {
        let instance = self.instances.iter().find(|p| p.name == r.instance)?;
        self.fmus[instance.fmu].variable(&r.variable)
    }

    /// Run the scenario once on the calling thread. `progress` gets the fraction done.
    pub fn run(&self, options: &RunOptions, mut progress: impl FnMut(f64)) -> Result<RunResult> {
        fmu_log::install();
        let wall_start = Instant::now();
        let scenario = &self.scenario;
        let steps = scenario.step_count()?;
        let stop_time = scenario.time_of(steps);
        // The recording is allocated once per run: bound it before anything is allocated.
        let values = (steps + 1).saturating_mul(self.columns.len().max(1) as u64);
        if values > MAX_RECORDED_VALUES {
            bail!(
                "scenario {}: {} steps of {} recorded columns are {values} values, more than the {MAX_RECORDED_VALUES} a run may record; record fewer variables or take longer steps",
                scenario.source.display(),
                steps,
                self.columns.len()
            );
        }

        // Overrides: resolve before instantiating anything.
        let mut overrides: Vec<Vec<(VariableInfo, ParameterValue)>> =
            vec![Vec::new(); self.instances.len()];
        for (r, value) in &options.overrides {
            let instance = self
                .instances
                .iter()
                .position(|p| p.name == r.instance)
                .ok_or_else(|| anyhow!("override {r}: no FMU instance named {:?}", r.instance))?;
            let var = settable(&self.fmus[self.instances[instance].fmu], &r.variable)
                .with_context(|| format!("override {r}"))?;
            // "--set vehicle.vx0=20" parses as an integer; a Real parameter takes it as 20.0.
            let value = match (var.var_type, value) {
                (VariableType::Real, ParameterValue::Integer(i)) => {
                    ParameterValue::Real(f64::from(*i))
                }
                _ => value.clone(),
            };
            overrides[instance].push((var.clone(), value));
        }

        let mut manoeuvre = self.manoeuvre.clone().map(ManoeuvreRun::new);
        if let Some(m) = manoeuvre.as_mut() {
            m.update(scenario.start_time, None);
        }

        // Instantiate on this thread; `instances` drops before `self.fmus` (borrowed here).
        let mut instances: Vec<InstanceCS> = Vec::with_capacity(self.instances.len());
        let mut fmi_names = Vec::with_capacity(self.instances.len());
        for (index, plan) in self.instances.iter().enumerate() {
            let fmi_name = format!("{}{}", plan.name, options.instance_suffix);
            let instance = self.fmus[plan.fmu]
                .import()
                .instantiate_cs(&fmi_name, false, true)
                .map_err(|e| self.fmu_error(index, &fmi_name, "fmi2Instantiate", &e.to_string()))?;
            instances.push(instance);
            fmi_names.push(fmi_name);
        }
        let result = self.run_instances(
            &mut instances,
            &fmi_names,
            &overrides,
            manoeuvre.as_mut(),
            steps,
            stop_time,
            &mut progress,
        );
        for (instance, name) in instances.iter_mut().zip(&fmi_names) {
            if result.is_ok() {
                let _ = FmiInstance::terminate(instance);
            }
            fmu_log::forget(name);
        }
        drop(instances);
        let mut result = result?;
        result.total_wall_time = wall_start.elapsed().as_secs_f64();
        Ok(result)
    }

    /// Hands a finished run's recording back for the plan's next runs (Monte Carlo campaigns,
    /// benchmarks): they then write into memory that is already mapped instead of faulting in
    /// megabytes of fresh pages per run. Optional; a result that is kept is simply not recycled.
    pub fn recycle(&self, result: RunResult) {
        if let Ok(mut spare) = self.spare_tables.lock() {
            // One spare block per thread that may run concurrently is enough.
            if spare.len() < rayon::current_num_threads() {
                spare.push(result.data.values);
            }
        }
    }

    fn fmu_error(&self, index: usize, fmi_name: &str, call: &str, status: &str) -> anyhow::Error {
        let said = fmu_log::take_recent(fmi_name);
        let said = if said.is_empty() {
            String::new()
        } else {
            format!("; the FMU logged: {}", said.join(" | "))
        };
        anyhow!(
            "{}: {call} failed ({status}){said}",
            describe_fmu(self, index)
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn run_instances(
        &self,
        instances: &mut [InstanceCS],
        fmi_names: &[String],
        overrides: &[Vec<(VariableInfo, ParameterValue)>],
        mut manoeuvre: Option<&mut ManoeuvreRun>,
        steps: u64,
        stop_time: f64,
        progress: &mut impl FnMut(f64),
    ) -> Result<RunResult> {
        let scenario = &self.scenario;
        let t0 = scenario.start_time;
        let err = |index: usize, call: &str, e: &dyn std::fmt::Display| {
            self.fmu_error(index, &fmi_names[index], call, &e.to_string())
        };

        // Parameters, then manoeuvre-bound parameters, then overrides (last wins).
        for (index, plan) in self.instances.iter().enumerate() {
            let instance = &mut instances[index];
            let mut values: Vec<(&VariableInfo, ParameterValue)> = plan
                .parameters
                .iter()
                .map(|(v, p)| (v, p.clone()))
                .collect();
            for (var, channel) in &plan.parameter_signals {
                let value = manoeuvre.as_ref().map_or(0.0, |m| m.value(*channel, t0));
                values.push((var, ParameterValue::Real(value)));
            }
            for (var, value) in &overrides[index] {
                values.push((var, value.clone()));
            }
            for (var, value) in values {
                set_value(instance, var, &value).map_err(|e| {
                    err(
                        index,
                        &format!("setting parameter {:?} = {value:?}", var.name),
                        &e,
                    )
                })?;
            }
        }
        for (index, instance) in instances.iter_mut().enumerate() {
            FmiInstance::enter_initialization_mode(instance, None, t0, Some(stop_time))
                .map_err(|e| err(index, "fmi2SetupExperiment/fmi2EnterInitializationMode", &e))?;
        }
        let mut caches: Vec<Vec<f64>> = self
            .instances
            .iter()
            .map(|p| vec![0.0; p.reads.len()])
            .collect();
        let mut buffers = ExchangeBuffers::new(&self.instances);
        self.exchange(
            instances,
            &mut caches,
            &mut buffers,
            manoeuvre.as_deref_mut(),
            t0,
            &err,
        )?;
        for (index, instance) in instances.iter_mut().enumerate() {
            FmiInstance::exit_initialization_mode(instance)
                .map_err(|e| err(index, "fmi2ExitInitializationMode", &e))?;
        }

        let rows = steps as usize + 1;
        let spare = self
            .spare_tables
            .lock()
            .map(|mut spare| spare.pop())
            .unwrap_or_default()
            .unwrap_or_default();
        let mut data = Columns::reusing(spare, self.columns.len(), rows);
        let mut staged = StagedRows::new(self.columns.len());
        let mut times = Vec::with_capacity(rows);
        let mut step_time = vec![Duration::ZERO; instances.len()];
        let report_every = (steps / 200).max(1);
        for n in 0..=steps {
            let t = scenario.time_of(n);
            self.exchange(
                instances,
                &mut caches,
                &mut buffers,
                manoeuvre.as_deref_mut(),
                t,
                &err,
            )?;
            times.push(t);
            let row = staged.next_row();
            for (cell, slot) in row.iter_mut().zip(&self.record) {
                *cell = match *slot {
                    Slot::Read { instance, slot } => caches[instance][slot],
                    Slot::Channel(channel) => {
                        manoeuvre.as_ref().map_or(0.0, |m| m.value(channel, t))
                    }
                    Slot::PoseX => manoeuvre.as_ref().map_or(0.0, |m| m.pose().x),
                    Slot::PoseY => manoeuvre.as_ref().map_or(0.0, |m| m.pose().y),
                    Slot::PoseYaw => manoeuvre.as_ref().map_or(0.0, |m| m.pose().yaw),
                };
            }
            if staged.is_full() || n == steps {
                staged.write_into(&mut data, n as usize);
            }
            if n == steps {
                break;
            }
            let h = scenario.time_of(n + 1) - t;
            // One clock reading per doStep (plus one before the first): each instance's time
            // is the interval since the previous reading.
            let mut started = Instant::now();
            for &index in &self.order {
                instances[index]
                    .do_step(t, h, true)
                    .map_err(|e| err(index, &format!("fmi2DoStep(t = {t} s, h = {h} s)"), &e))?;
                let finished = Instant::now();
                step_time[index] += finished - started;
                started = finished;
            }
            if n % report_every == 0 {
                progress(n as f64 / steps as f64);
            }
        }
        progress(1.0);
        Ok(RunResult {
            scenario: scenario.name.clone(),
            times,
            columns: self.columns.clone(),
            data,
            step_wall_time: self
                .instances
                .iter()
                .zip(&step_time)
                .map(|(p, d)| (p.name.clone(), d.as_secs_f64() / steps as f64))
                .collect(),
            total_wall_time: 0.0,
        })
    }

    fn exchange(
        &self,
        instances: &mut [InstanceCS],
        caches: &mut [Vec<f64>],
        buffers: &mut ExchangeBuffers,
        manoeuvre: Option<&mut ManoeuvreRun>,
        t: f64,
        err: &dyn Fn(usize, &str, &dyn std::fmt::Display) -> anyhow::Error,
    ) -> Result<()> {
        let manoeuvre = match manoeuvre {
            Some(m) => {
                let motion = match &self.feedback {
                    Some(fb) => {
                        let mut v = [0.0; 3];
                        instances[fb.instance]
                            .get_real(&fb.value_references, &mut v)
                            .map_err(|e| {
                                err(fb.instance, "fmi2GetReal (manoeuvre feedback)", &e)
                            })?;
                        Some(VehicleMotion {
                            longitudinal_velocity: v[0],
                            lateral_velocity: v[1],
                            yaw_rate: v[2],
                        })
                    }
                    None => None,
                };
                m.update(t, motion);
                Some(&*m)
            }
            None => None,
        };
        let value_of = |source: &Source, caches: &[Vec<f64>]| match *source {
            Source::Channel(channel) => manoeuvre.map_or(0.0, |m| m.value(channel, t)),
            Source::Upstream { instance, slot } => caches[instance][slot],
        };
        for &index in &self.order {
            let plan = &self.instances[index];
            let instance = &mut instances[index];
            let b = &mut buffers.per_instance[index];
            if !plan.inputs.real.0.is_empty() {
                for (value, source) in b.real_in.iter_mut().zip(&plan.inputs.real.1) {
                    *value = value_of(source, caches);
                }
                for o in plan.overrides.iter().filter(|o| o.from <= t && t <= o.to) {
                    b.real_in[o.position] = o.value;
                }
                instance
                    .set_real(&plan.inputs.real.0, &b.real_in)
                    .map_err(|e| err(index, "fmi2SetReal (inputs)", &e))?;
            }
            if !plan.inputs.integer.0.is_empty() {
                for (value, source) in b.int_in.iter_mut().zip(&plan.inputs.integer.1) {
                    *value = value_of(source, caches).round() as i32;
                }
                instance
                    .set_integer(&plan.inputs.integer.0, &b.int_in)
                    .map_err(|e| err(index, "fmi2SetInteger (inputs)", &e))?;
            }
            if !plan.inputs.boolean.0.is_empty() {
                for (value, source) in b.bool_in.iter_mut().zip(&plan.inputs.boolean.1) {
                    *value = (value_of(source, caches) != 0.0) as fmi2Boolean;
                }
                instance
                    .set_boolean(&plan.inputs.boolean.0, &b.bool_in)
                    .map_err(|e| err(index, "fmi2SetBoolean (inputs)", &e))?;
            }
            let cache = &mut caches[index];
            if !plan.read_groups.real.0.is_empty() {
                instance
                    .get_real(&plan.read_groups.real.0, &mut b.real_out)
                    .map_err(|e| err(index, "fmi2GetReal", &e))?;
                for (value, &slot) in b.real_out.iter().zip(&plan.read_groups.real.1) {
                    cache[slot] = *value;
                }
            }
            if !plan.read_groups.integer.0.is_empty() {
                instance
                    .get_integer(&plan.read_groups.integer.0, &mut b.int_out)
                    .map_err(|e| err(index, "fmi2GetInteger", &e))?;
                for (value, &slot) in b.int_out.iter().zip(&plan.read_groups.integer.1) {
                    cache[slot] = f64::from(*value);
                }
            }
            if !plan.read_groups.boolean.0.is_empty() {
                instance
                    .get_boolean(&plan.read_groups.boolean.0, &mut b.bool_out)
                    .map_err(|e| err(index, "fmi2GetBoolean", &e))?;
                for (value, &slot) in b.bool_out.iter().zip(&plan.read_groups.boolean.1) {
                    cache[slot] = f64::from(u8::from(*value != 0));
                }
            }
        }
        Ok(())
    }
}

struct InstanceBuffers {
    real_in: Vec<f64>,
    int_in: Vec<i32>,
    bool_in: Vec<fmi2Boolean>,
    real_out: Vec<f64>,
    int_out: Vec<i32>,
    bool_out: Vec<fmi2Boolean>,
}

/// Scratch space allocated once per run, so a step allocates nothing.
struct ExchangeBuffers {
    per_instance: Vec<InstanceBuffers>,
}

impl ExchangeBuffers {
    fn new(plans: &[InstancePlan]) -> Self {
        ExchangeBuffers {
            per_instance: plans
                .iter()
                .map(|p| InstanceBuffers {
                    real_in: vec![0.0; p.inputs.real.0.len()],
                    int_in: vec![0; p.inputs.integer.0.len()],
                    bool_in: vec![0; p.inputs.boolean.0.len()],
                    real_out: vec![0.0; p.read_groups.real.0.len()],
                    int_out: vec![0; p.read_groups.integer.0.len()],
                    bool_out: vec![0; p.read_groups.boolean.0.len()],
                })
                .collect(),
        }
    }
}

fn compatible(from: VariableType, to: VariableType) -> bool {
    use VariableType::*;
    matches!(
        (from, to),
        (Real, Real) | (Integer | Enumeration, Integer | Enumeration) | (Boolean, Boolean)
    )
}

/// A variable a scenario may set before initialisation: a parameter or an input.
fn settable<'a>(fmu: &'a LoadedFmu, name: &str) -> Result<&'a VariableInfo> {
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

fn set_value(instance: &mut InstanceCS, var: &VariableInfo, value: &ParameterValue) -> Result<()> {
    let vr = [var.value_reference];
    match value {
        ParameterValue::Real(x) => instance.set_real(&vr, &[*x]).map(|_| ())?,
        ParameterValue::Integer(x) => instance.set_integer(&vr, &[*x]).map(|_| ())?,
        ParameterValue::Boolean(b) => instance
            .set_boolean(&vr, &[*b as fmi2Boolean])
            .map(|_| ())?,
        ParameterValue::String(s) => {
            let c = std::ffi::CString::new(s.as_str()).context("string contains a NUL byte")?;
            instance.set_string(&vr, &[c])?
        }
    }
    Ok(())
}

/// Instances in the order they must receive inputs: Kahn's algorithm, ties and cycles resolved
/// by declaration order.
fn topological_order(count: usize, edges: &[Edge]) -> Vec<usize> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows staged in blocks land in the right cells, for a row count that is not a multiple
    /// of the block, also in a recycled block holding other values.
    #[test]
    fn staged_rows_fill_every_cell_of_the_table() {
        let (columns, rows) = (3, 2 * StagedRows::CAPACITY + 22);
        for old in [Vec::new(), vec![f64::NAN; columns * rows + 5]] {
            let mut table = Columns::reusing(old, columns, rows);
            let mut staged = StagedRows::new(columns);
            for n in 0..rows {
                for (c, cell) in staged.next_row().iter_mut().enumerate() {
                    *cell = (n * 10 + c) as f64;
                }
                if staged.is_full() || n == rows - 1 {
                    staged.write_into(&mut table, n);
                }
            }
            assert_eq!(table.len(), columns);
            assert_eq!(table.rows(), rows);
            for (c, column) in table.iter().enumerate() {
                let expected: Vec<f64> = (0..rows).map(|n| (n * 10 + c) as f64).collect();
                assert_eq!(column, expected.as_slice(), "column {c}");
            }
        }
    }
}
