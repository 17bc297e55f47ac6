//! The FMI 3.0 Co-Simulation functions, generic over the model; [`crate::export_fmi3!`] exports
//! them as C symbols beside the FMI 2.0 ones, so one library serves both archives.
//!
//! They run on the plumbing of [`crate::api`]: the same instance, state machine, live-handle
//! list, `catch_unwind` frame, logging, range admission and FMU-state snapshots (FMI 3.0
//! sections 2.2 and 4.2). What FMI 3 adds or names differently:
//!
//! - `fmi3EnterInitializationMode` takes the experiment (FMI 2's `fmi2SetupExperiment`).
//! - Types: Real variables are `Float64`, Integers `Int32`, enumerations `Int64`, Booleans
//!   `Boolean` (C `bool`); a getter or setter of a type the FMU has no variable of refuses every
//!   value reference with `fmi3Error`. `nValues` must be the number of scalar elements the value
//!   references hold (an array counts its elements).
//! - The FMI 3-only variables ([`crate::Fmi3Variable`]) are outputs, read through
//!   `fmi3GetFloat64`/`fmi3GetInt32` only.
//! - `fmi3DoStep` never returns early and never needs event handling (no event mode,
//!   `hasEventMode` is not declared): `eventModeUsed = true` at instantiation is refused.
//! - Functions of capabilities the FMU does not declare (event mode, configuration mode,
//!   clocks, directional and adjoint derivatives, output derivatives, Model Exchange and
//!   Scheduled Execution instances) answer `fmi3Error` with a log line naming the capability.

use std::ffi::c_char;

use crate::api::{
    check_arrays, check_internal_step_size, create_instance, deserialize_fmu_state_as,
    find_variable, free_fmu_state_as, get_fmu_state_as, references, refresh_initial_outputs,
    serialize_fmu_state_as, serialized_fmu_state_size_as, set_fmu_state_as, with_instance, Outcome,
    ANY_STATE, MASK_DO_STEP, MASK_ENTER_INITIALIZATION_MODE, MASK_EXIT_INITIALIZATION_MODE,
    MASK_GET, MASK_RESET, MASK_SET, MASK_TERMINATE,
};
use crate::ffi3::*;
use crate::instance::{log_message, Logger, MachineState};
use crate::variables::{ValueType, VariableInfo, VariableStore};
use crate::{CoSimulationModel, Fmi3Kind};

/// `fmi3GetVersion`: "3.0".
pub fn get_version() -> *const c_char {
    c"3.0".as_ptr()
}

/// `fmi3InstantiateCoSimulation`.
///
/// # Safety
/// The strings are null or NUL-terminated; the callbacks are null or the master's.
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate_co_simulation<M: CoSimulationModel>(
    instance_name: Fmi3String,
    instantiation_token: Fmi3String,
    resource_path: Fmi3String,
    logging_on: Fmi3Boolean,
    event_mode_used: Fmi3Boolean,
    environment: Fmi3InstanceEnvironment,
    log_message: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    let logger = Logger::Fmi3 {
        environment,
        log_message,
    };
    // Early return is the FMU's choice (FMI 3.0, 4.2.1): it never returns early, so
    // `earlyReturnAllowed` and the intermediate-update callback need no handling.
    let refusal = (event_mode_used != FMI3_FALSE).then(|| {
        format!(
            "eventModeUsed is true; {} does not declare hasEventMode (it has no events)",
            M::MODEL_IDENTIFIER
        )
    });
    // SAFETY: null or NUL-terminated (caller contract).
    unsafe {
        create_instance::<M>(
            "fmi3InstantiateCoSimulation",
            "instantiationToken",
            logger,
            instance_name,
            instantiation_token,
            resource_path,
            logging_on != FMI3_FALSE,
            refusal,
        )
    }
}

/// `fmi3InstantiateModelExchange` and `fmi3InstantiateScheduledExecution`: the FMU declares
/// Co-Simulation only, so these log why and return NULL.
///
/// # Safety
/// `instance_name` is null or NUL-terminated; the callback is null or the master's.
pub unsafe fn instantiate_other<M: CoSimulationModel>(
    function: &str,
    instance_name: Fmi3String,
    environment: Fmi3InstanceEnvironment,
    log_message_callback: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    let logger = Logger::Fmi3 {
        environment,
        log_message: log_message_callback,
    };
    let _ = crate::api::guarded(|| {
        // SAFETY: null or NUL-terminated (caller contract).
        let name = unsafe { crate::api::optional_str(instance_name) }.unwrap_or_default();
        log_message(
            &logger,
            &crate::instance::c_string(&name),
            Fmi3Status::Error,
            "logStatusError",
            &format!(
                "{function}: {} is a Co-Simulation FMU only; use fmi3InstantiateCoSimulation",
                M::MODEL_IDENTIFIER
            ),
        );
    });
    std::ptr::null_mut()
}

/// `fmi3EnterInitializationMode`: the experiment (FMI 2's fmi2SetupExperiment) and the change
/// of state in one call.
///
/// # Safety
/// Any `instance` is checked against the live instances.
pub unsafe fn enter_initialization_mode<M: CoSimulationModel>(
    instance: Fmi3Instance,
    start_time: f64,
    stop_time_defined: Fmi3Boolean,
    stop_time: f64,
) -> Fmi3Status {
    const FUNCTION: &str = "fmi3EnterInitializationMode";
    unsafe {
        with_instance::<M>(
            instance,
            FUNCTION,
            MASK_ENTER_INITIALIZATION_MODE,
            |instance| {
                if !start_time.is_finite() {
                    return Outcome::Error(format!(
                        "{FUNCTION}: startTime is {start_time}; expected a finite time"
                    ));
                }
                let stop = (stop_time_defined != FMI3_FALSE).then_some(stop_time);
                if let Some(stop) = stop {
                    if stop.is_nan() || stop < start_time {
                        return Outcome::Error(format!(
                            "{FUNCTION}: stopTime {stop} is before startTime {start_time}"
                        ));
                    }
                }
                instance.start_time = start_time;
                instance.stop_time = stop;
                instance.time = start_time;
                instance.last_successful_time = start_time;
                instance.needs_initialization = true;
                instance.state = MachineState::InitializationMode;
                instance.log_event(FUNCTION);
                Outcome::Ok
            },
        )
    }
}

/// `fmi3ExitInitializationMode`: the model checks its parameters and computes its outputs;
/// without event mode the instance goes to Step Mode.
///
/// # Safety
/// Any `instance` is checked against the live instances.
pub unsafe fn exit_initialization_mode<M: CoSimulationModel>(instance: Fmi3Instance) -> Fmi3Status {
    const FUNCTION: &str = "fmi3ExitInitializationMode";
    unsafe {
        with_instance::<M>(
            instance,
            FUNCTION,
            MASK_EXIT_INITIALIZATION_MODE,
            |instance| {
                let start = instance.start_time;
                if let Err(message) = instance.model.initialize(start) {
                    return Outcome::Error(format!("{FUNCTION}: {message}"));
                }
                if let Err(message) = check_internal_step_size(&instance.model) {
                    return Outcome::Error(format!("{FUNCTION}: {message}"));
                }
                instance.needs_initialization = false;
                instance.time = start;
                instance.last_successful_time = start;
                instance.state = MachineState::StepComplete;
                instance.log_event(FUNCTION);
                Outcome::Ok
            },
        )
    }
}

/// `fmi3Terminate`.
///
/// # Safety
/// Any `instance` is checked against the live instances.
pub unsafe fn terminate<M: CoSimulationModel>(instance: Fmi3Instance) -> Fmi3Status {
    unsafe {
        with_instance::<M>(instance, "fmi3Terminate", MASK_TERMINATE, |instance| {
            instance.state = MachineState::Terminated;
            instance.log_event("fmi3Terminate");
            Outcome::Ok
        })
    }
}

/// `fmi3Reset`: back to Instantiated with the start values.
///
/// # Safety
/// Any `instance` is checked against the live instances.
pub unsafe fn reset<M: CoSimulationModel>(instance: Fmi3Instance) -> Fmi3Status {
    unsafe {
        with_instance::<M>(instance, "fmi3Reset", MASK_RESET, |instance| {
            instance.model = M::instantiate(&instance.context);
            instance.state = MachineState::Instantiated;
            instance.start_time = 0.0;
            instance.stop_time = None;
            instance.time = 0.0;
            instance.last_successful_time = 0.0;
            instance.needs_initialization = true;
            instance.log_event("fmi3Reset");
            Outcome::Ok
        })
    }
}

/// The FMI 3 scalar types, as far as the getters and setters tell them apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fmi3Type {
    Float32,
    Float64,
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Int64,
    UInt64,
    Boolean,
    String,
    Binary,
    Clock,
}

/// Where one value reference of a getter's type lives.
enum Target {
    /// A variable of the FMI 2 table, one element.
    Table(&'static VariableInfo),
    /// An FMI 3-only variable of `elements` elements.
    Fmi3Only { elements: usize },
}

/// The variable `vr` names for an FMI 3 getter or setter of `fmi3_type`: Float64 is the FMI 2
/// Real, Int32 the Integer that is no enumeration, Int64 the enumeration, Boolean the Boolean;
/// with `fmi3_only`, also the FMI 3-only variables of that type.
fn resolve<M: CoSimulationModel>(
    function: &str,
    fmi3_type: Fmi3Type,
    vr: u32,
    fmi3_only: bool,
) -> Result<Target, String> {
    let table = |value_type, enumeration: Option<bool>| {
        find_variable::<M>(value_type, vr)
            .filter(|v| {
                let is_enumeration = !v.allowed_values.is_empty();
                enumeration.is_none_or(|e| e == is_enumeration)
            })
            .map(Target::Table)
    };
    let found = match fmi3_type {
        Fmi3Type::Float64 => table(ValueType::Real, None),
        Fmi3Type::Int32 => table(ValueType::Integer, Some(false)),
        Fmi3Type::Int64 => table(ValueType::Integer, Some(true)),
        Fmi3Type::Boolean => table(ValueType::Boolean, None),
        _ => None,
    };
    let extra = || {
        M::FMI3_VARIABLES
            .iter()
            .filter(|v| v.value_reference == vr)
            .find(|v| match v.kind {
                Fmi3Kind::Float64 { .. } | Fmi3Kind::Time => fmi3_type == Fmi3Type::Float64,
                Fmi3Kind::Int32 => fmi3_type == Fmi3Type::Int32,
            })
    };
    if let Some(target) = found {
        return Ok(target);
    }
    match extra() {
        Some(variable) if fmi3_only => Ok(Target::Fmi3Only {
            elements: variable.elements(),
        }),
        Some(variable) => Err(format!(
            "{function}: variable '{}' (valueReference {vr}) is a calculated output; it cannot be set",
            variable.name
        )),
        None => Err(format!(
            "{function}: unknown value reference {vr}; {} has no {fmi3_type:?} variable with it (see modelDescription.xml)",
            M::MODEL_IDENTIFIER
        )),
    }
}

/// The number of scalar elements of `vr[]`, checked against the master's `nValues`.
fn count_elements<M: CoSimulationModel>(
    function: &str,
    fmi3_type: Fmi3Type,
    references: &[u32],
    n_values: usize,
    fmi3_only: bool,
) -> Result<(), String> {
    let mut count = 0usize;
    for &vr in references {
        count += match resolve::<M>(function, fmi3_type, vr, fmi3_only)? {
            Target::Table(_) => 1,
            Target::Fmi3Only { elements } => elements,
        };
    }
    if count == n_values {
        Ok(())
    } else {
        Err(format!(
            "{function}: nValues is {n_values}; the {} value references hold {count} values",
            references.len()
        ))
    }
}

/// Shared body of the FMI 3 getters: checks, then writes each variable's elements in turn.
///
/// # Safety
/// `vr` points to `nvr` elements and `values` to `n_values` (when non-zero).
#[allow(clippy::too_many_arguments)]
unsafe fn get_values<M: CoSimulationModel, T: Copy + Default>(
    instance: Fmi3Instance,
    function: &str,
    fmi3_type: Fmi3Type,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *mut T,
    n_values: usize,
    read: impl Fn(&M, &'static VariableInfo) -> Option<T>,
    read_fmi3: impl Fn(&M, f64, u32, &mut [T]) -> bool,
) -> Fmi3Status {
    unsafe {
        with_instance::<M>(instance, function, MASK_GET, |instance| {
            if let Err(message) = check_arrays(function, nvr, vr, values.is_null()) {
                return Outcome::Error(message);
            }
            if n_values > 0 && values.is_null() {
                return Outcome::Error(format!(
                    "{function}: values[] is NULL but nValues = {n_values}"
                ));
            }
            let references = references(vr, nvr);
            if let Err(message) =
                count_elements::<M>(function, fmi3_type, references, n_values, true)
            {
                return Outcome::Error(message);
            }
            if let Err(message) = refresh_initial_outputs(instance, function) {
                return Outcome::Error(message);
            }
            instance.model.refresh_outputs();
            // SAFETY: `values` holds n_values elements (caller contract, checked above).
            let out: &mut [T] = if n_values == 0 {
                &mut []
            } else {
                std::slice::from_raw_parts_mut(values, n_values)
            };
            let mut at = 0;
            for &reference in references {
                let Ok(target) = resolve::<M>(function, fmi3_type, reference, true) else {
                    continue; // resolved in count_elements
                };
                let done = match target {
                    Target::Table(variable) => match read(&instance.model, variable) {
                        Some(value) => {
                            out[at] = value;
                            at += 1;
                            true
                        }
                        None => false,
                    },
                    Target::Fmi3Only { elements } => {
                        let ok = read_fmi3(
                            &instance.model,
                            instance.time,
                            reference,
                            &mut out[at..at + elements],
                        );
                        at += elements;
                        ok
                    }
                };
                if !done {
                    return Outcome::Error(format!(
                        "{function}: value reference {reference} is in the variable table but not in the model's storage (internal error)"
                    ));
                }
            }
            Outcome::Ok
        })
    }
}

/// `fmi3GetFloat64`: Real variables and the FMI 3-only Float64 arrays.
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn get_float64<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *mut f64,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        get_values::<M, f64>(
            instance,
            "fmi3GetFloat64",
            Fmi3Type::Float64,
            vr,
            nvr,
            values,
            n_values,
            |m, v| m.variables().real(v.value_reference),
            |m, time, r, out| {
                let is_time = M::FMI3_VARIABLES
                    .iter()
                    .any(|v| v.value_reference == r && v.kind == Fmi3Kind::Time);
                match out {
                    [cell] if is_time => {
                        *cell = time;
                        true
                    }
                    _ => m.fmi3_float64(r, out),
                }
            },
        )
    }
}

/// `fmi3GetInt32`: Integer variables that are no enumeration and the FMI 3-only Int32 ones.
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn get_int32<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *mut i32,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        get_values::<M, i32>(
            instance,
            "fmi3GetInt32",
            Fmi3Type::Int32,
            vr,
            nvr,
            values,
            n_values,
            |m, v| m.variables().integer(v.value_reference),
            |m, _, r, out| match (m.fmi3_int32(r), out) {
                (Some(value), [cell]) => {
                    *cell = value;
                    true
                }
                _ => false,
            },
        )
    }
}

/// `fmi3GetInt64`: enumerations (FMI 3.0 accesses them as Int64).
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn get_int64<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *mut i64,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        get_values::<M, i64>(
            instance,
            "fmi3GetInt64",
            Fmi3Type::Int64,
            vr,
            nvr,
            values,
            n_values,
            |m, v| m.variables().integer(v.value_reference).map(i64::from),
            |_, _, _, _| false,
        )
    }
}

/// `fmi3GetBoolean`.
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn get_boolean<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *mut Fmi3Boolean,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        get_values::<M, Fmi3Boolean>(
            instance,
            "fmi3GetBoolean",
            Fmi3Type::Boolean,
            vr,
            nvr,
            values,
            n_values,
            |m, v| m.variables().boolean(v.value_reference).map(u8::from),
            |_, _, _, _| false,
        )
    }
}

/// The getters and setters of types the FMUs have no variable of (Float32, the 8-, 16- and
/// unsigned integers, String, Binary, Clock): an empty call is fine, any value reference is
/// unknown.
///
/// # Safety
/// `vr` points to `nvr` elements.
pub unsafe fn no_variables_of_type<M: CoSimulationModel>(
    instance: Fmi3Instance,
    function: &str,
    fmi3_type: Fmi3Type,
    setter: bool,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values_are_null: bool,
) -> Fmi3Status {
    let mask = if setter { MASK_SET } else { MASK_GET };
    unsafe {
        with_instance::<M>(instance, function, mask, |_| {
            if let Err(message) = check_arrays(function, nvr, vr, values_are_null) {
                return Outcome::Error(message);
            }
            match references(vr, nvr).first() {
                None => Outcome::Ok,
                Some(&reference) => match resolve::<M>(function, fmi3_type, reference, false) {
                    Err(message) => Outcome::Error(message),
                    Ok(_) => Outcome::Error(format!(
                        "{function}: value reference {reference} is not of type {fmi3_type:?}"
                    )),
                },
            }
        })
    }
}

/// Shared body of the FMI 3 setters: the FMI 2 setters' checks and admission (the range
/// clamps, NaN handling and warnings of [`crate::api`]), with the FMI 3 type mapping and the
/// `nValues` check.
///
/// # Safety
/// `vr` points to `nvr` elements and `values` to `n_values` (when non-zero).
#[allow(clippy::too_many_arguments)]
unsafe fn set_values<M: CoSimulationModel, T: Copy>(
    instance: Fmi3Instance,
    function: &str,
    fmi3_type: Fmi3Type,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *const T,
    n_values: usize,
    store: impl Fn(
        &mut Vec<String>,
        &mut Vec<&'static VariableInfo>,
        &mut M::Variables,
        &'static VariableInfo,
        T,
    ) -> bool,
) -> Fmi3Status {
    unsafe {
        with_instance::<M>(instance, function, MASK_SET, |instance| {
            if let Err(message) = check_arrays(function, nvr, vr, values.is_null()) {
                return Outcome::Error(message);
            }
            let references = references(vr, nvr);
            if let Err(message) =
                count_elements::<M>(function, fmi3_type, references, n_values, false)
            {
                return Outcome::Error(message);
            }
            let mut variables = Vec::with_capacity(nvr);
            for &reference in references {
                let variable = match resolve::<M>(function, fmi3_type, reference, false) {
                    Ok(Target::Table(variable)) => variable,
                    Ok(Target::Fmi3Only { .. }) => continue, // refused by resolve
                    Err(message) => return Outcome::Error(message),
                };
                if let Err(message) = crate::api::settable(function, variable, instance.state) {
                    return Outcome::Error(message);
                }
                variables.push(variable);
            }
            let mut warnings = Vec::new();
            let mut adjusted = Vec::new();
            let storage = instance.model.variables_mut();
            for (i, variable) in variables.iter().enumerate() {
                // SAFETY: `values` holds n_values = nvr elements (checked above).
                if !store(
                    &mut warnings,
                    &mut adjusted,
                    storage,
                    variable,
                    *values.add(i),
                ) {
                    return Outcome::Error(format!(
                        "{function}: value reference {} is in the variable table but not in the model's storage (internal error)",
                        variable.value_reference
                    ));
                }
            }
            for variable in adjusted {
                instance.model.value_adjusted(variable);
            }
            if nvr > 0 && instance.state != MachineState::StepComplete {
                instance.needs_initialization = true;
            }
            if warnings.is_empty() {
                Outcome::Ok
            } else {
                Outcome::Warning(format!(
                    "{function}: {}; every other value of the call was applied",
                    warnings.join("; ")
                ))
            }
        })
    }
}

/// Applies an [`crate::api::Admitted`] value: stores it, records a warning and the adjusted
/// variable; `false` when the storage refused it (an internal error).
fn admit_into<T>(
    warnings: &mut Vec<String>,
    adjusted: &mut Vec<&'static VariableInfo>,
    variable: &'static VariableInfo,
    admitted: crate::api::Admitted<T>,
    write: impl FnOnce(T) -> bool,
) -> bool {
    use crate::api::Admitted;
    match admitted {
        Admitted::As(value) => write(value),
        Admitted::Clamped(value, message) => {
            warnings.push(format!("{}: {message}", variable.label()));
            adjusted.push(variable);
            write(value)
        }
        Admitted::Ignored(message) => {
            warnings.push(format!("{}: {message}", variable.label()));
            adjusted.push(variable);
            true
        }
    }
}

/// `fmi3SetFloat64`.
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn set_float64<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *const f64,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        set_values::<M, f64>(
            instance,
            "fmi3SetFloat64",
            Fmi3Type::Float64,
            vr,
            nvr,
            values,
            n_values,
            |warnings, adjusted, storage, variable, value| {
                let admitted = crate::api::admit_real(variable, value);
                admit_into(warnings, adjusted, variable, admitted, |x| {
                    storage.set_real(variable.value_reference, x)
                })
            },
        )
    }
}

/// `fmi3SetInt32`: Integer variables that are no enumeration.
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn set_int32<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *const i32,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        set_values::<M, i32>(
            instance,
            "fmi3SetInt32",
            Fmi3Type::Int32,
            vr,
            nvr,
            values,
            n_values,
            |warnings, adjusted, storage, variable, value| {
                let admitted = crate::api::admit_integer(variable, value);
                admit_into(warnings, adjusted, variable, admitted, |x| {
                    storage.set_integer(variable.value_reference, x)
                })
            },
        )
    }
}

/// `fmi3SetInt64`: enumerations. A value beyond 32 bits is no item of any enumeration here and
/// is ignored with a warning, like any other value that is no item.
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn set_int64<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *const i64,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        set_values::<M, i64>(
            instance,
            "fmi3SetInt64",
            Fmi3Type::Int64,
            vr,
            nvr,
            values,
            n_values,
            |warnings, adjusted, storage, variable, value| {
                let admitted = match i32::try_from(value) {
                    Ok(narrow) => crate::api::admit_integer(variable, narrow),
                    Err(_) => crate::api::Admitted::Ignored(format!(
                        "value {value} is not an item of the enumeration; expected one of {:?}; the variable keeps its value",
                        variable.allowed_values
                    )),
                };
                admit_into(warnings, adjusted, variable, admitted, |x| {
                    storage.set_integer(variable.value_reference, x)
                })
            },
        )
    }
}

/// `fmi3SetBoolean`: any non-zero byte is true.
///
/// # Safety
/// `vr` points to `nvr` elements, `values` to `n_values`.
pub unsafe fn set_boolean<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: *const Fmi3ValueReference,
    nvr: usize,
    values: *const Fmi3Boolean,
    n_values: usize,
) -> Fmi3Status {
    unsafe {
        set_values::<M, Fmi3Boolean>(
            instance,
            "fmi3SetBoolean",
            Fmi3Type::Boolean,
            vr,
            nvr,
            values,
            n_values,
            |_, _, storage, variable, value| {
                storage.set_boolean(variable.value_reference, value != FMI3_FALSE)
            },
        )
    }
}

/// The dependencies of output `vr` (value references of the knowns), or the error message.
fn output_dependencies<M: CoSimulationModel>(
    function: &str,
    vr: u32,
) -> Result<&'static [u32], String> {
    M::OUTPUT_DEPENDENCIES
        .iter()
        .find(|(output, _)| *output == vr)
        .map(|(_, dependencies)| *dependencies)
        .ok_or_else(|| {
            format!(
                "{function}: value reference {vr} is not an output of the ModelStructure of {}",
                M::MODEL_IDENTIFIER
            )
        })
}

/// `fmi3GetNumberOfVariableDependencies`: the dependencies of an output, as the ModelStructure
/// lists them.
///
/// # Safety
/// `n_dependencies` is null or writable.
pub unsafe fn get_number_of_variable_dependencies<M: CoSimulationModel>(
    instance: Fmi3Instance,
    vr: Fmi3ValueReference,
    n_dependencies: *mut usize,
) -> Fmi3Status {
    const FUNCTION: &str = "fmi3GetNumberOfVariableDependencies";
    unsafe {
        with_instance::<M>(instance, FUNCTION, ANY_STATE, |_| {
            if n_dependencies.is_null() {
                return Outcome::Error(format!("{FUNCTION}: nDependencies is NULL"));
            }
            match output_dependencies::<M>(FUNCTION, vr) {
                Ok(dependencies) => {
                    *n_dependencies = dependencies.len();
                    Outcome::Ok
                }
                Err(message) => Outcome::Error(message),
            }
        })
    }
}

/// `fmi3GetVariableDependencies`: every dependency is of kind `dependent` (the ModelStructure
/// gives no `dependenciesKind`), between scalars (element index 0).
///
/// # Safety
/// Each array holds `n_dependencies` elements.
#[allow(clippy::too_many_arguments)]
pub unsafe fn get_variable_dependencies<M: CoSimulationModel>(
    instance: Fmi3Instance,
    dependent: Fmi3ValueReference,
    element_indices_of_dependent: *mut usize,
    independents: *mut Fmi3ValueReference,
    element_indices_of_independents: *mut usize,
    dependency_kinds: *mut Fmi3DependencyKind,
    n_dependencies: usize,
) -> Fmi3Status {
    const FUNCTION: &str = "fmi3GetVariableDependencies";
    unsafe {
        with_instance::<M>(instance, FUNCTION, ANY_STATE, |_| {
            let dependencies = match output_dependencies::<M>(FUNCTION, dependent) {
                Ok(dependencies) => dependencies,
                Err(message) => return Outcome::Error(message),
            };
            if n_dependencies != dependencies.len() {
                return Outcome::Error(format!(
                    "{FUNCTION}: nDependencies is {n_dependencies}; value reference {dependent} has {} (fmi3GetNumberOfVariableDependencies)",
                    dependencies.len()
                ));
            }
            if n_dependencies > 0
                && (element_indices_of_dependent.is_null()
                    || independents.is_null()
                    || element_indices_of_independents.is_null()
                    || dependency_kinds.is_null())
            {
                return Outcome::Error(format!(
                    "{FUNCTION}: an output array is NULL but nDependencies = {n_dependencies}"
                ));
            }
            for (i, &known) in dependencies.iter().enumerate() {
                // SAFETY: each array holds n_dependencies elements (caller contract).
                element_indices_of_dependent.add(i).write(0);
                independents.add(i).write(known);
                element_indices_of_independents.add(i).write(0);
                dependency_kinds.add(i).write(FMI3_DEPENDENCY_DEPENDENT);
            }
            Outcome::Ok
        })
    }
}

/// `fmi3DoStep`: as fmi2DoStep; never returns early, never asks for event handling or to
/// terminate, and reports the time it reached in `lastSuccessfulTime`.
///
/// # Safety
/// The output pointers are null or writable.
#[allow(clippy::too_many_arguments)]
pub unsafe fn do_step<M: CoSimulationModel>(
    instance: Fmi3Instance,
    current_communication_point: f64,
    communication_step_size: f64,
    event_handling_needed: *mut Fmi3Boolean,
    terminate_simulation: *mut Fmi3Boolean,
    early_return: *mut Fmi3Boolean,
    last_successful_time: *mut f64,
) -> Fmi3Status {
    const FUNCTION: &str = "fmi3DoStep";
    unsafe {
        with_instance::<M>(instance, FUNCTION, MASK_DO_STEP, |instance| {
            if event_handling_needed.is_null()
                || terminate_simulation.is_null()
                || early_return.is_null()
                || last_successful_time.is_null()
            {
                return Outcome::Error(format!(
                    "{FUNCTION}: eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL"
                ));
            }
            let t = current_communication_point;
            let h = communication_step_size;
            let outcome = crate::api::step(instance, FUNCTION, t, h);
            // SAFETY: all four checked non-null; the master passes writable locations.
            event_handling_needed.write(FMI3_FALSE);
            terminate_simulation.write(FMI3_FALSE);
            early_return.write(FMI3_FALSE);
            last_successful_time.write(instance.last_successful_time);
            outcome
        })
    }
}

/// A function of a capability the FMU does not declare: `fmi3Error` with a log line.
///
/// # Safety
/// Any `instance` is checked against the live instances.
pub unsafe fn not_declared<M: CoSimulationModel>(
    instance: Fmi3Instance,
    function: &str,
    capability: &str,
) -> Fmi3Status {
    unsafe {
        with_instance::<M>(instance, function, ANY_STATE, |_| {
            Outcome::Error(format!(
                "{function}: not supported: {} does not declare {capability}",
                M::MODEL_IDENTIFIER
            ))
        })
    }
}

/// `fmi3GetFMUState`.
///
/// # Safety
/// As [`crate::api::get_fmu_state`].
pub unsafe fn get_fmu_state<M: CoSimulationModel>(
    instance: Fmi3Instance,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    unsafe { get_fmu_state_as::<M>("fmi3GetFMUState", instance, state) }
}

/// `fmi3SetFMUState`.
///
/// # Safety
/// As [`crate::api::set_fmu_state`].
pub unsafe fn set_fmu_state<M: CoSimulationModel>(
    instance: Fmi3Instance,
    state: Fmi3FmuState,
) -> Fmi3Status {
    unsafe { set_fmu_state_as::<M>("fmi3SetFMUState", instance, state) }
}

/// `fmi3FreeFMUState`.
///
/// # Safety
/// As [`crate::api::free_fmu_state`].
pub unsafe fn free_fmu_state<M: CoSimulationModel>(
    instance: Fmi3Instance,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    unsafe { free_fmu_state_as::<M>("fmi3FreeFMUState", instance, state) }
}

/// `fmi3SerializedFMUStateSize`.
///
/// # Safety
/// As [`crate::api::serialized_fmu_state_size`].
pub unsafe fn serialized_fmu_state_size<M: CoSimulationModel>(
    instance: Fmi3Instance,
    state: Fmi3FmuState,
    size: *mut usize,
) -> Fmi3Status {
    unsafe {
        serialized_fmu_state_size_as::<M>("fmi3SerializedFMUStateSize", instance, state, size)
    }
}

/// `fmi3SerializeFMUState`: the same versioned, checked frame as FMI 2's.
///
/// # Safety
/// As [`crate::api::serialize_fmu_state`].
pub unsafe fn serialize_fmu_state<M: CoSimulationModel>(
    instance: Fmi3Instance,
    state: Fmi3FmuState,
    bytes: *mut Fmi3Byte,
    size: usize,
) -> Fmi3Status {
    unsafe {
        serialize_fmu_state_as::<M>(
            "fmi3SerializeFMUState",
            instance,
            state,
            bytes as *mut _,
            size,
        )
    }
}

/// `fmi3DeserializeFMUState`.
///
/// # Safety
/// As [`crate::api::deserialize_fmu_state`].
pub unsafe fn deserialize_fmu_state<M: CoSimulationModel>(
    instance: Fmi3Instance,
    bytes: *const Fmi3Byte,
    size: usize,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    unsafe {
        deserialize_fmu_state_as::<M>(
            "fmi3DeserializeFMUState",
            instance,
            bytes as *const _,
            size,
            state,
        )
    }
}
