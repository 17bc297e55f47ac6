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
//! Every [`FmuInstance`](crate::instance::FmuInstance) is created on the thread that runs it
//! (inside [`Plan::run`]) and borrows the [`LoadedFmu`] that owns its binary.

//!
//! The module's parts: [`load`] reads the FMUs and resolves the connections, [`bind`] turns
//! the scenario's references into value references and recorded columns, [`step`] runs the
//! loop above and [`columns`] stores what it records.

mod bind;
mod columns;
mod load;
mod step;

#[cfg(test)]
mod fmi_versions;

use std::path::Path;
use std::sync::Mutex;

use anyhow::{Context, Result};

use crate::fmu::{LoadedFmu, VariableInfo, VariableType};
use crate::scenario::{Scenario, VarRef};
use manoeuvres::{Channel, Manoeuvre};

pub use crate::instance::{FmiVersion, ParameterValue};
pub use columns::Columns;
pub use load::{convert_scenario_value, convert_value};

use bind::ScenarioRefs;
use load::{load_instances, resolve_connections, topological_order};

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
    /// The FMI version the runs drive the FMUs through.
    version: FmiVersion,
    /// Loaded archives; declared last so every borrowed use ends before they drop.
    fmus: Vec<LoadedFmu>,
}

/// The most values (rows times columns) one run may record: 800 MB of f64, so that a scenario
/// with a tiny step or a long duration is refused before it exhausts the memory.
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

fn describe_fmu(plan: &Plan, instance: usize) -> String {
    let inst = &plan.instances[instance];
    format!(
        "FMU '{}' ({})",
        inst.name,
        plan.fmus[inst.fmu].path.display()
    )
}

impl Plan {
    /// Load the scenario's FMUs (extracted under `work_dir`) and resolve every name: load the
    /// FMUs, resolve the connections, order the instances, bind inputs, feedback and recording.
    /// The FMI version is the scenario's `fmi_version` (2 unless it says 3).
    pub fn new(scenario: Scenario, fmu_dir: &Path, work_dir: &Path) -> Result<Plan> {
        let version = match scenario.fmi_version {
            3 => FmiVersion::Fmi3,
            _ => FmiVersion::Fmi2,
        };
        Self::with_version(scenario, fmu_dir, work_dir, version)
    }

    /// [`Plan::new`], with the runs driving the FMUs through `version`: for FMI 3.0 each FMU's
    /// archive `<stem>-fmi3.fmu` beside the `.fmu` the scenario names is loaded too, checked to
    /// declare the same variables, and instantiated instead.
    pub fn with_version(
        scenario: Scenario,
        fmu_dir: &Path,
        work_dir: &Path,
        version: FmiVersion,
    ) -> Result<Plan> {
        let manoeuvre = scenario.manoeuvre()?;
        let (mut fmus, instances) = load_instances(&scenario, fmu_dir, work_dir)?;
        if version == FmiVersion::Fmi3 {
            for fmu in &mut fmus {
                let stem = fmu.path.file_stem().unwrap_or_default().to_string_lossy();
                let fmi3_path = fmu.path.with_file_name(format!("{stem}-fmi3.fmu"));
                fmu.load_fmi3(&fmi3_path, work_dir)
                    .with_context(|| format!("scenario {}", scenario.source.display()))?;
            }
        }
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
            version,
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

    /// The FMI version the runs drive the FMUs through.
    pub fn fmi_version(&self) -> FmiVersion {
        self.version
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

    /// Hands a finished run's recording back for the plan's next runs (Monte Carlo campaigns,
    /// benchmarks): they then write into memory that is already mapped instead of faulting in
    /// megabytes of fresh pages per run. Optional; a result that is kept is simply not recycled.
    pub fn recycle(&self, result: RunResult) {
        if let Ok(mut spare) = self.spare_tables.lock() {
            // One spare block per thread that may run concurrently is enough.
            if spare.len() < rayon::current_num_threads() {
                spare.push(result.data.into_block());
            }
        }
    }
}
