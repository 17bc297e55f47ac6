//! [`FmuInstance`]: one Co-Simulation instance of a [`LoadedFmu`], the calls a master makes on
//! it, in the order FMI allows them: instantiate, set parameters, enter and exit
//! initialisation, then at each communication point set inputs, get outputs and do a step. The
//! co-simulation loop ([`crate::cosim`]) and a caller that feeds recorded signals (the
//! harness's replay) both drive FMUs through it.
//!
//! Names are checked against the FMU's variable table and values against the variable's type
//! before anything reaches the FMU; the per-step calls take value references resolved once. A
//! failed call quotes what the FMU logged for the instance ([`crate::fmu_log`]). Dropping the
//! instance terminates it when it is stepping and no call failed (the FMI 2.0 Co-Simulation
//! state machine, section 4.2.4, allows fmi2Terminate between steps), forgets its log and frees
//! it.

mod error;
mod value;
mod versions;

pub use error::{InstanceError, StepOutcome};
pub use value::ParameterValue;
pub use versions::FmiVersion;

use std::ffi::CString;

use crate::fmu::{LoadedFmu, VariableInfo, VariableType};
use crate::fmu_log;
use versions::Versioned;

/// Where an instance is in the FMI state machine, as far as [`Drop`] needs to know.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Instantiated,
    Initialising,
    Stepping,
    /// A call answered Discard, Error or Fatal: the instance is only freed.
    Failed,
}

/// One instance of `fmu`; it borrows the [`LoadedFmu`], which owns the extracted binary, so it
/// cannot outlive it.
pub struct FmuInstance<'a> {
    fmu: &'a LoadedFmu,
    /// The instance name given to fmi2Instantiate, under which its log messages arrive.
    name: String,
    stage: Stage,
    inner: Versioned,
}

impl<'a> FmuInstance<'a> {
    /// Instantiates `fmu` for Co-Simulation as `name` through `version`, with logging on (the
    /// messages go to [`fmu_log`], installed here).
    pub fn new(
        fmu: &'a LoadedFmu,
        name: &str,
        version: FmiVersion,
    ) -> Result<FmuInstance<'a>, InstanceError> {
        fmu_log::install();
        let inner = Versioned::new(fmu, name, version).map_err(|status| InstanceError::Call {
            call: "instantiate".into(),
            status,
            logged: fmu_log::take_recent(name),
        })?;
        Ok(FmuInstance {
            fmu,
            name: name.to_string(),
            stage: Stage::Instantiated,
            inner,
        })
    }

    /// Sets parameter (or input) `name` before initialisation; the variable table gives its
    /// value reference and type, which `value` must fit (an Enumeration takes its item's
    /// number).
    pub fn set_parameter(
        &mut self,
        name: &str,
        value: &ParameterValue,
    ) -> Result<(), InstanceError> {
        let fmu = self.fmu;
        let settable = |v: &VariableInfo| v.is_parameter() || v.is_input();
        let var = fmu
            .variable(name)
            .filter(|v| settable(v))
            .ok_or_else(|| no_variable(fmu, name, "parameter or input", settable))?;
        if !value.fits(var.var_type) {
            return Err(InstanceError::WrongType {
                name: name.to_string(),
                var_type: var.var_type,
                value: value.clone(),
            });
        }
        let answer = self.set_typed(var, value);
        self.check(answer, || format!("setting parameter {name:?} = {value:?}"))
    }

    /// Sets `value`, which fits `var`'s type, through that type's setter.
    fn set_typed(&mut self, var: &VariableInfo, value: &ParameterValue) -> Result<(), String> {
        let vr = [var.value_reference];
        match value {
            ParameterValue::Real(x) => self.inner.set_real(&vr, &[*x]),
            ParameterValue::Integer(i) => self.inner.set_integer(&vr, &[*i]),
            ParameterValue::Boolean(b) => self.inner.set_boolean(&vr, &[*b]),
            ParameterValue::String(s) => {
                let c = CString::new(s.as_str())
                    .map_err(|_| format!("the string {s:?} contains a NUL byte"))?;
                self.inner.set_string(&vr, &[c])
            }
        }
    }

    /// The value reference of Real input `name`, for [`FmuInstance::set_reals`].
    pub fn real_input(&self, name: &str) -> Result<u32, InstanceError> {
        let real_input = |v: &VariableInfo| v.is_input() && v.var_type == VariableType::Real;
        self.fmu
            .variable(name)
            .filter(|v| real_input(v))
            .map(|v| v.value_reference)
            .ok_or_else(|| no_variable(self.fmu, name, "Real input", real_input))
    }

    /// fmi2SetupExperiment (no tolerance, stop time `stop`) and fmi2EnterInitializationMode, or
    /// fmi3EnterInitializationMode.
    pub fn enter_initialization_mode(
        &mut self,
        start: f64,
        stop: f64,
    ) -> Result<(), InstanceError> {
        let answer = self.inner.enter_initialization_mode(start, stop);
        self.check(answer, || "enter initialisation mode".into())?;
        self.stage = Stage::Initialising;
        Ok(())
    }

    pub fn exit_initialization_mode(&mut self) -> Result<(), InstanceError> {
        let answer = self.inner.exit_initialization_mode();
        self.check(answer, || "exit initialisation mode".into())?;
        self.stage = Stage::Stepping;
        Ok(())
    }

    pub fn set_reals(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), InstanceError> {
        self.call(["fmi2SetReal", "fmi3SetFloat64"], |i| {
            i.set_real(vrs, values)
        })
    }

    pub fn get_reals(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<(), InstanceError> {
        self.call(["fmi2GetReal", "fmi3GetFloat64"], |i| {
            i.get_real(vrs, values)
        })
    }

    /// Integers and Enumerations (FMI 3.0: Int32 and Int64).
    pub fn set_integers(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), InstanceError> {
        self.call(["fmi2SetInteger", "fmi3SetInt32/Int64"], |i| {
            i.set_integer(vrs, values)
        })
    }

    /// Integers and Enumerations (FMI 3.0: Int32 and Int64).
    pub fn get_integers(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<(), InstanceError> {
        self.call(["fmi2GetInteger", "fmi3GetInt32/Int64"], |i| {
            i.get_integer(vrs, values)
        })
    }

    pub fn set_booleans(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), InstanceError> {
        self.call(["fmi2SetBoolean", "fmi3SetBoolean"], |i| {
            i.set_boolean(vrs, values)
        })
    }

    pub fn get_booleans(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<(), InstanceError> {
        self.call(["fmi2GetBoolean", "fmi3GetBoolean"], |i| {
            i.get_boolean(vrs, values)
        })
    }

    /// The communication step from `t` to `t + h`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, InstanceError> {
        let answer = self.inner.do_step(t, h);
        let function = self.inner.function(["fmi2DoStep", "fmi3DoStep"]);
        self.check(answer, || format!("{function}(t = {t} s, h = {h} s)"))
    }

    /// `f` on the instance, a call of the FMI function `functions[0]` (FMI 2.0) or
    /// `functions[1]` (FMI 3.0).
    fn call<T>(
        &mut self,
        functions: [&'static str; 2],
        f: impl FnOnce(&mut Versioned) -> Result<T, String>,
    ) -> Result<T, InstanceError> {
        let answer = f(&mut self.inner);
        let function = self.inner.function(functions);
        self.check(answer, || function.to_string())
    }

    /// `answer` as the API's result; a failure marks the instance failed and quotes its log.
    fn check<T>(
        &mut self,
        answer: Result<T, String>,
        call: impl FnOnce() -> String,
    ) -> Result<T, InstanceError> {
        answer.map_err(|status| {
            self.stage = Stage::Failed;
            InstanceError::Call {
                call: call(),
                status,
                logged: fmu_log::take_recent(&self.name),
            }
        })
    }
}

impl Drop for FmuInstance<'_> {
    fn drop(&mut self) {
        if self.stage == Stage::Stepping {
            // The run is over either way; the FMU logs what went wrong, if anything.
            let _ = self.inner.terminate();
        }
        fmu_log::forget(&self.name);
    }
}

/// The error for `name`, listing the variables of `fmu` that `kind` accepts.
fn no_variable(
    fmu: &LoadedFmu,
    name: &str,
    wanted: &'static str,
    kind: impl Fn(&VariableInfo) -> bool,
) -> InstanceError {
    let mut known: Vec<&str> = (fmu.variables.iter())
        .filter(|v| kind(v))
        .map(|v| v.name.as_str())
        .collect();
    known.sort_unstable();
    InstanceError::NoVariable {
        name: name.to_string(),
        wanted,
        known: known.join(", "),
    }
}
