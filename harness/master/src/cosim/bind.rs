//! Bind step: the scenario's references turned into value references, read slots, manoeuvre
//! inputs, overrides, the manoeuvre's feedback and the recorded columns.

use anyhow::{anyhow, bail, Result};

use super::load::{Drivers, Edge};
use super::{Feedback, InputOverride, Plan, Slot, Source};
use crate::fmu::{VariableInfo, VariableType};
use crate::scenario::{Scenario, VarRef};
use manoeuvres::Channel;

/// The three variables of `[manoeuvre.feedback]`, in the order the driver reads them.
const FEEDBACK_FIELDS: [&str; 3] = ["longitudinal_velocity", "lateral_velocity", "yaw_rate"];

/// Every "inst.variable" reference of the scenario and every channel name, parsed once in the
/// resolve step; the bind steps take them as they are (a malformed one is refused here, naming
/// its field, though `Scenario::validate` has refused it already).
pub(super) struct ScenarioRefs {
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
    pub(super) fn parse(scenario: &Scenario) -> Result<Self> {
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
    /// Each connection's sink input reads its source's output slot.
    pub(super) fn bind_connections(&mut self, edges: &[Edge]) {
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
    pub(super) fn bind_manoeuvre_inputs(
        &mut self,
        refs: &ScenarioRefs,
        driven: &mut Drivers,
    ) -> Result<()> {
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
    pub(super) fn bind_overrides(&mut self, refs: &ScenarioRefs) -> Result<()> {
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
    pub(super) fn bind_feedback(&mut self, refs: &ScenarioRefs) -> Result<()> {
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
    pub(super) fn bind_recording(&mut self, refs: &ScenarioRefs) -> Result<()> {
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
}
