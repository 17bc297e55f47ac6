//! One FMU instance of a run, driven through FMI 2.0 or FMI 3.0 with the same calls: the step
//! loop does not know which. FMI 3.0 names the types differently (FMI 3.0 section 2.4): Real
//! values are Float64, Integers Int32 and Enumerations Int64.

use fmi::fmi2::binding::fmi2Boolean;
use fmi::fmi2::instance::{CoSimulation as _, Common as _, InstanceCS as Fmi2Instance};
use fmi::fmi3::instance::InstanceCS as Fmi3Instance;
use fmi::fmi3::{CoSimulation as _, GetSet as _};
use fmi::traits::FmiInstance;

use crate::fmu::LoadedFmu;

/// Which FMI version a run drives its FMUs through.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FmiVersion {
    /// The `.fmu` archives the scenario names.
    #[default]
    Fmi2,
    /// The FMI 3.0 archive beside each, `<stem>-fmi3.fmu`.
    Fmi3,
}

/// An instance of either version; errors are the `fmi` crate's, as text.
// One per FMU per run, in a vector: the size difference costs nothing per step, and boxing
// would add an indirection to every call of the hot loop.
#[allow(clippy::large_enum_variant)]
pub(super) enum RunInstance {
    Fmi2(Fmi2Instance),
    Fmi3 {
        instance: Fmi3Instance,
        /// Sorted value references of the Enumeration variables (Int64 in FMI 3.0).
        enumerations: Vec<u32>,
    },
}

type Outcome = Result<(), String>;

fn text(error: impl std::fmt::Display) -> String {
    error.to_string()
}

impl RunInstance {
    /// Instantiates `fmu` for Co-Simulation through `version`.
    pub(super) fn new(fmu: &LoadedFmu, name: &str, version: FmiVersion) -> Result<Self, String> {
        use fmi::fmi3::Fmi3Model as _;
        match version {
            FmiVersion::Fmi2 => fmu
                .import()
                .instantiate_cs(name, false, true)
                .map(RunInstance::Fmi2)
                .map_err(text),
            FmiVersion::Fmi3 => {
                let archive = fmu.fmi3().ok_or_else(|| {
                    format!("{}: no FMI 3.0 archive was loaded", fmu.path.display())
                })?;
                let instance = archive
                    .import()
                    .instantiate_cs(name, false, true, false, false, &[])
                    .map_err(text)?;
                Ok(RunInstance::Fmi3 {
                    instance,
                    enumerations: archive.enumerations.clone(),
                })
            }
        }
    }

    pub(super) fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.set_real(vrs, values).map(drop).map_err(text),
            RunInstance::Fmi3 { instance, .. } => {
                instance.set_float64(vrs, values).map(drop).map_err(text)
            }
        }
    }

    pub(super) fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.get_real(vrs, values).map(drop).map_err(text),
            RunInstance::Fmi3 { instance, .. } => {
                instance.get_float64(vrs, values).map(drop).map_err(text)
            }
        }
    }

    pub(super) fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.set_integer(vrs, values).map(drop).map_err(text),
            RunInstance::Fmi3 {
                instance,
                enumerations,
            } => {
                if !vrs.iter().any(|vr| enumerations.binary_search(vr).is_ok()) {
                    return instance.set_int32(vrs, values).map(drop).map_err(text);
                }
                for (vr, value) in vrs.iter().zip(values) {
                    let done = if enumerations.binary_search(vr).is_ok() {
                        instance.set_int64(&[*vr], &[i64::from(*value)])
                    } else {
                        instance.set_int32(&[*vr], &[*value])
                    };
                    done.map_err(text)?;
                }
                Ok(())
            }
        }
    }

    pub(super) fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.get_integer(vrs, values).map(drop).map_err(text),
            RunInstance::Fmi3 {
                instance,
                enumerations,
            } => {
                if !vrs.iter().any(|vr| enumerations.binary_search(vr).is_ok()) {
                    return instance.get_int32(vrs, values).map(drop).map_err(text);
                }
                for (vr, value) in vrs.iter().zip(values.iter_mut()) {
                    if enumerations.binary_search(vr).is_ok() {
                        let mut wide = [0i64];
                        instance.get_int64(&[*vr], &mut wide).map_err(text)?;
                        *value = i32::try_from(wide[0])
                            .map_err(|_| format!("enumeration value {} beyond 32 bits", wide[0]))?;
                    } else {
                        instance
                            .get_int32(&[*vr], std::slice::from_mut(value))
                            .map_err(text)?;
                    }
                }
                Ok(())
            }
        }
    }

    pub(super) fn set_boolean(&mut self, vrs: &[u32], values: &[fmi2Boolean]) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.set_boolean(vrs, values).map(drop).map_err(text),
            RunInstance::Fmi3 { instance, .. } => {
                let flags: Vec<bool> = values.iter().map(|&v| v != 0).collect();
                instance.set_boolean(vrs, &flags).map(drop).map_err(text)
            }
        }
    }

    pub(super) fn get_boolean(&mut self, vrs: &[u32], values: &mut [fmi2Boolean]) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.get_boolean(vrs, values).map(drop).map_err(text),
            RunInstance::Fmi3 { instance, .. } => {
                let mut flags = vec![false; values.len()];
                instance.get_boolean(vrs, &mut flags).map_err(text)?;
                for (value, flag) in values.iter_mut().zip(flags) {
                    *value = fmi2Boolean::from(flag);
                }
                Ok(())
            }
        }
    }

    pub(super) fn set_string(&mut self, vrs: &[u32], values: &[std::ffi::CString]) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.set_string(vrs, values).map_err(text),
            RunInstance::Fmi3 { instance, .. } => instance.set_string(vrs, values).map_err(text),
        }
    }

    pub(super) fn enter_initialization_mode(&mut self, start: f64, stop: f64) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => {
                FmiInstance::enter_initialization_mode(i, None, start, Some(stop))
                    .map(drop)
                    .map_err(text)
            }
            RunInstance::Fmi3 { instance, .. } => {
                FmiInstance::enter_initialization_mode(instance, None, start, Some(stop))
                    .map(drop)
                    .map_err(text)
            }
        }
    }

    pub(super) fn exit_initialization_mode(&mut self) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => FmiInstance::exit_initialization_mode(i)
                .map(drop)
                .map_err(text),
            RunInstance::Fmi3 { instance, .. } => FmiInstance::exit_initialization_mode(instance)
                .map(drop)
                .map_err(text),
        }
    }

    pub(super) fn do_step(&mut self, t: f64, h: f64) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => i.do_step(t, h, true).map(drop).map_err(text),
            RunInstance::Fmi3 { instance, .. } => {
                let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
                instance
                    .do_step(
                        t,
                        h,
                        true,
                        &mut event,
                        &mut terminate,
                        &mut early,
                        &mut last,
                    )
                    .map(drop)
                    .map_err(text)
            }
        }
    }

    pub(super) fn terminate(&mut self) -> Outcome {
        match self {
            RunInstance::Fmi2(i) => FmiInstance::terminate(i).map(drop).map_err(text),
            RunInstance::Fmi3 { instance, .. } => {
                FmiInstance::terminate(instance).map(drop).map_err(text)
            }
        }
    }
}
