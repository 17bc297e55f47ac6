//! One FMU instance driven through FMI 2.0 or FMI 3.0 with the same calls, so that nothing above
//! knows which. FMI 3.0 names the types differently (FMI 3.0 section 2.4): Real values are
//! Float64, Integers Int32 and Enumerations Int64. Errors are the `fmi` crate's, as text.

use fmi::fmi2::binding::fmi2Boolean;
use fmi::fmi2::instance::{CoSimulation as _, Common as _, InstanceCS as Fmi2Instance};
use fmi::fmi2::Fmi2Res;
use fmi::fmi3::instance::InstanceCS as Fmi3Instance;
use fmi::fmi3::{CoSimulation as _, Fmi3Res, GetSet as _};
use fmi::traits::FmiInstance;

use super::StepOutcome;
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

/// An instance of either version.
// One per FMU per run: the size difference costs nothing per step, and boxing would add an
// indirection to every call of the hot loop.
#[allow(clippy::large_enum_variant)]
pub(super) enum Versioned {
    Fmi2 {
        instance: Fmi2Instance,
        /// fmi2Boolean (a C int) copies of the Booleans of one call, kept to allocate once.
        booleans: Vec<fmi2Boolean>,
    },
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

impl Versioned {
    /// Instantiates `fmu` for Co-Simulation through `version`, with logging on.
    pub(super) fn new(fmu: &LoadedFmu, name: &str, version: FmiVersion) -> Result<Self, String> {
        use fmi::fmi3::Fmi3Model as _;
        match version {
            FmiVersion::Fmi2 => {
                let instance = fmu
                    .import()
                    .instantiate_cs(name, false, true)
                    .map_err(text)?;
                Ok(Versioned::Fmi2 {
                    instance,
                    booleans: Vec::new(),
                })
            }
            FmiVersion::Fmi3 => {
                let archive = fmu.fmi3().ok_or_else(|| {
                    format!("{}: no FMI 3.0 archive was loaded", fmu.path.display())
                })?;
                let instance = archive
                    .import()
                    .instantiate_cs(name, false, true, false, false, &[])
                    .map_err(text)?;
                Ok(Versioned::Fmi3 {
                    instance,
                    enumerations: archive.enumerations.clone(),
                })
            }
        }
    }

    /// Of a call's FMI function names `[in FMI 2.0, in FMI 3.0]`, the one this instance calls.
    pub(super) fn function(&self, names: [&'static str; 2]) -> &'static str {
        match self {
            Versioned::Fmi2 { .. } => names[0],
            Versioned::Fmi3 { .. } => names[1],
        }
    }

    pub(super) fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, .. } => {
                instance.set_real(vrs, values).map(drop).map_err(text)
            }
            Versioned::Fmi3 { instance, .. } => {
                instance.set_float64(vrs, values).map(drop).map_err(text)
            }
        }
    }

    pub(super) fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, .. } => {
                instance.get_real(vrs, values).map(drop).map_err(text)
            }
            Versioned::Fmi3 { instance, .. } => {
                instance.get_float64(vrs, values).map(drop).map_err(text)
            }
        }
    }

    pub(super) fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, .. } => {
                instance.set_integer(vrs, values).map(drop).map_err(text)
            }
            Versioned::Fmi3 {
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
            Versioned::Fmi2 { instance, .. } => {
                instance.get_integer(vrs, values).map(drop).map_err(text)
            }
            Versioned::Fmi3 {
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

    pub(super) fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, booleans } => {
                booleans.clear();
                booleans.extend(values.iter().map(|&v| fmi2Boolean::from(v)));
                instance.set_boolean(vrs, booleans).map(drop).map_err(text)
            }
            Versioned::Fmi3 { instance, .. } => {
                instance.set_boolean(vrs, values).map(drop).map_err(text)
            }
        }
    }

    pub(super) fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, booleans } => {
                booleans.clear();
                booleans.resize(values.len(), 0);
                instance.get_boolean(vrs, booleans).map_err(text)?;
                for (value, &flag) in values.iter_mut().zip(booleans.iter()) {
                    *value = flag != 0;
                }
                Ok(())
            }
            Versioned::Fmi3 { instance, .. } => {
                instance.get_boolean(vrs, values).map(drop).map_err(text)
            }
        }
    }

    pub(super) fn set_string(&mut self, vrs: &[u32], values: &[std::ffi::CString]) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, .. } => instance.set_string(vrs, values).map_err(text),
            Versioned::Fmi3 { instance, .. } => instance.set_string(vrs, values).map_err(text),
        }
    }

    /// fmi2SetupExperiment and fmi2EnterInitializationMode, or fmi3EnterInitializationMode.
    pub(super) fn enter_initialization_mode(&mut self, start: f64, stop: f64) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, .. } => {
                FmiInstance::enter_initialization_mode(instance, None, start, Some(stop))
                    .map(drop)
                    .map_err(text)
            }
            Versioned::Fmi3 { instance, .. } => {
                FmiInstance::enter_initialization_mode(instance, None, start, Some(stop))
                    .map(drop)
                    .map_err(text)
            }
        }
    }

    pub(super) fn exit_initialization_mode(&mut self) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, .. } => FmiInstance::exit_initialization_mode(instance)
                .map(drop)
                .map_err(text),
            Versioned::Fmi3 { instance, .. } => FmiInstance::exit_initialization_mode(instance)
                .map(drop)
                .map_err(text),
        }
    }

    pub(super) fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, String> {
        match self {
            Versioned::Fmi2 { instance, .. } => match instance.do_step(t, h, true) {
                Ok(Fmi2Res::OK) => Ok(StepOutcome::Ok),
                Ok(Fmi2Res::Warning) => Ok(StepOutcome::Warning),
                Ok(Fmi2Res::Pending) => Ok(StepOutcome::Pending),
                Err(e) => Err(text(e)),
            },
            Versioned::Fmi3 { instance, .. } => {
                let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
                let answer = instance.do_step(
                    t,
                    h,
                    true,
                    &mut event,
                    &mut terminate,
                    &mut early,
                    &mut last,
                );
                match answer {
                    Ok(Fmi3Res::OK) => Ok(StepOutcome::Ok),
                    Ok(Fmi3Res::Warning) => Ok(StepOutcome::Warning),
                    Err(e) => Err(text(e)),
                }
            }
        }
    }

    pub(super) fn terminate(&mut self) -> Outcome {
        match self {
            Versioned::Fmi2 { instance, .. } => {
                FmiInstance::terminate(instance).map(drop).map_err(text)
            }
            Versioned::Fmi3 { instance, .. } => {
                FmiInstance::terminate(instance).map(drop).map_err(text)
            }
        }
    }
}
