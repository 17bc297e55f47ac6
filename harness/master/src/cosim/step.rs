//! The step loop: instantiate, set the parameters, initialise, exchange inputs and outputs at
//! each communication point, record, step.

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};

use super::columns::{Columns, StagedRows};
use super::load::settable;
use super::{
    describe_fmu, InstancePlan, ParameterValue, Plan, RunOptions, RunResult, Slot, Source,
    MAX_RECORDED_VALUES,
};
use crate::fmu::{VariableInfo, VariableType};
use crate::instance::{FmuInstance, InstanceError};
use manoeuvres::{ManoeuvreRun, VehicleMotion};

impl Plan {
    /// Run the scenario once on the calling thread. `progress` gets the fraction done.
    pub fn run(&self, options: &RunOptions, mut progress: impl FnMut(f64)) -> Result<RunResult> {
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

        // Instantiate on this thread; the instances borrow `self.fmus`, and dropping them
        // terminates (when stepping and no call failed) and frees them.
        let mut instances = Vec::with_capacity(self.instances.len());
        for (index, plan) in self.instances.iter().enumerate() {
            let fmi_name = format!("{}{}", plan.name, options.instance_suffix);
            let instance = FmuInstance::new(&self.fmus[plan.fmu], &fmi_name, self.version)
                .map_err(|e| self.fmu_error(index, e))?;
            instances.push(instance);
        }
        let result = self.run_instances(
            &mut instances,
            &overrides,
            manoeuvre.as_mut(),
            steps,
            stop_time,
            &mut progress,
        );
        drop(instances);
        let mut result = result?;
        result.total_wall_time = wall_start.elapsed().as_secs_f64();
        Ok(result)
    }

    /// `error` of instance `index`, naming the instance and its FMU.
    fn fmu_error(&self, index: usize, error: InstanceError) -> anyhow::Error {
        anyhow!("{}: {error}", describe_fmu(self, index))
    }

    fn run_instances(
        &self,
        instances: &mut [FmuInstance],
        overrides: &[Vec<(VariableInfo, ParameterValue)>],
        mut manoeuvre: Option<&mut ManoeuvreRun>,
        steps: u64,
        stop_time: f64,
        progress: &mut impl FnMut(f64),
    ) -> Result<RunResult> {
        let scenario = &self.scenario;
        let t0 = scenario.start_time;

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
                instance
                    .set_parameter(&var.name, &value)
                    .map_err(|e| self.fmu_error(index, e))?;
            }
        }
        for (index, instance) in instances.iter_mut().enumerate() {
            instance
                .enter_initialization_mode(t0, stop_time)
                .map_err(|e| self.fmu_error(index, e))?;
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
        )?;
        for (index, instance) in instances.iter_mut().enumerate() {
            instance
                .exit_initialization_mode()
                .map_err(|e| self.fmu_error(index, e))?;
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
                    .do_step(t, h)
                    .map_err(|e| self.fmu_error(index, e))?;
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
        instances: &mut [FmuInstance],
        caches: &mut [Vec<f64>],
        buffers: &mut ExchangeBuffers,
        manoeuvre: Option<&mut ManoeuvreRun>,
        t: f64,
    ) -> Result<()> {
        let manoeuvre = match manoeuvre {
            Some(m) => {
                let motion = match &self.feedback {
                    Some(fb) => {
                        let mut v = [0.0; 3];
                        instances[fb.instance]
                            .get_reals(&fb.value_references, &mut v)
                            .map_err(|e| {
                                self.fmu_error(fb.instance, e)
                                    .context("reading the manoeuvre feedback")
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
                    .set_reals(&plan.inputs.real.0, &b.real_in)
                    .map_err(|e| self.fmu_error(index, e))?;
            }
            if !plan.inputs.integer.0.is_empty() {
                for (value, source) in b.int_in.iter_mut().zip(&plan.inputs.integer.1) {
                    *value = value_of(source, caches).round() as i32;
                }
                instance
                    .set_integers(&plan.inputs.integer.0, &b.int_in)
                    .map_err(|e| self.fmu_error(index, e))?;
            }
            if !plan.inputs.boolean.0.is_empty() {
                for (value, source) in b.bool_in.iter_mut().zip(&plan.inputs.boolean.1) {
                    *value = value_of(source, caches) != 0.0;
                }
                instance
                    .set_booleans(&plan.inputs.boolean.0, &b.bool_in)
                    .map_err(|e| self.fmu_error(index, e))?;
            }
            let cache = &mut caches[index];
            if !plan.read_groups.real.0.is_empty() {
                instance
                    .get_reals(&plan.read_groups.real.0, &mut b.real_out)
                    .map_err(|e| self.fmu_error(index, e))?;
                for (value, &slot) in b.real_out.iter().zip(&plan.read_groups.real.1) {
                    cache[slot] = *value;
                }
            }
            if !plan.read_groups.integer.0.is_empty() {
                instance
                    .get_integers(&plan.read_groups.integer.0, &mut b.int_out)
                    .map_err(|e| self.fmu_error(index, e))?;
                for (value, &slot) in b.int_out.iter().zip(&plan.read_groups.integer.1) {
                    cache[slot] = f64::from(*value);
                }
            }
            if !plan.read_groups.boolean.0.is_empty() {
                instance
                    .get_booleans(&plan.read_groups.boolean.0, &mut b.bool_out)
                    .map_err(|e| self.fmu_error(index, e))?;
                for (value, &slot) in b.bool_out.iter().zip(&plan.read_groups.boolean.1) {
                    cache[slot] = f64::from(u8::from(*value));
                }
            }
        }
        Ok(())
    }
}

struct InstanceBuffers {
    real_in: Vec<f64>,
    int_in: Vec<i32>,
    bool_in: Vec<bool>,
    real_out: Vec<f64>,
    int_out: Vec<i32>,
    bool_out: Vec<bool>,
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
                    bool_in: vec![false; p.inputs.boolean.0.len()],
                    real_out: vec![0.0; p.read_groups.real.0.len()],
                    int_out: vec![0; p.read_groups.integer.0.len()],
                    bool_out: vec![false; p.read_groups.boolean.0.len()],
                })
                .collect(),
        }
    }
}
