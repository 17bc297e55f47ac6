//! The FMI 2.0 functions, generic over the model; [`crate::export_fmi2!`] exports them as C
//! symbols. Each function checks its pointers and the state machine, runs inside
//! `catch_unwind`, logs what goes wrong and moves the instance to the Error state on `fmi2Error`.
//!
//! Allowed states per function (FMI 2.0.4, section 4.2.4, table of the Co-Simulation state
//! machine; StepInProgress/StepCanceled never occur here):

use std::any::TypeId;
use std::cell::Cell;
use std::ffi::{c_char, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Once;

use crate::ffi::*;
use crate::instance::{c_string, log_message, Instance, Logger, MachineState};
use crate::live;
use crate::variables::{Causality, ValueType, Variability, VariableInfo, VariableStore};
use crate::{CoSimulationModel, InstantiationContext, StateReader, StateWriter, StepOutcome};

const INSTANTIATED: u8 = MachineState::Instantiated as u8;
const INITIALIZATION_MODE: u8 = MachineState::InitializationMode as u8;
const STEP_COMPLETE: u8 = MachineState::StepComplete as u8;
const STEP_FAILED: u8 = MachineState::StepFailed as u8;
const TERMINATED: u8 = MachineState::Terminated as u8;
const ERROR: u8 = MachineState::Error as u8;
pub(crate) const ANY_STATE: u8 =
    INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR;

pub const MASK_SET_DEBUG_LOGGING: u8 = ANY_STATE;
pub const MASK_SETUP_EXPERIMENT: u8 = INSTANTIATED;
pub const MASK_ENTER_INITIALIZATION_MODE: u8 = INSTANTIATED;
pub const MASK_EXIT_INITIALIZATION_MODE: u8 = INITIALIZATION_MODE;
pub const MASK_TERMINATE: u8 = STEP_COMPLETE | STEP_FAILED;
pub const MASK_RESET: u8 = ANY_STATE;
pub const MASK_GET: u8 = INITIALIZATION_MODE | STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR;
pub const MASK_SET: u8 = INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE;
pub const MASK_FMU_STATE: u8 = ANY_STATE;
pub const MASK_DIRECTIONAL_DERIVATIVE: u8 = MASK_GET;
pub const MASK_SET_REAL_INPUT_DERIVATIVES: u8 = INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE;
pub const MASK_GET_REAL_OUTPUT_DERIVATIVES: u8 = STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR;
pub const MASK_DO_STEP: u8 = STEP_COMPLETE;
pub const MASK_CANCEL_STEP: u8 = 0;
pub const MASK_GET_STATUS: u8 = STEP_COMPLETE | STEP_FAILED | TERMINATED;

/// What a function body reports; the wrapper logs it and applies the state transition.
pub(crate) enum Outcome {
    Ok,
    Warning(String),
    Discard(String),
    Error(String),
}

thread_local! {
    /// True while this thread is inside an FMI call: the panic hook stays quiet then (the panic
    /// is logged through the master's logger instead). `Cell<bool>` needs no destructor, so
    /// this thread-local registers none (dlclose-safe).
    static INSIDE_FMI_CALL: Cell<bool> = const { Cell::new(false) };
}

static PANIC_HOOK: Once = Once::new();

/// Installs, once per process (per copy of std, i.e. per loaded FMU library), a panic hook
/// that is silent inside FMI calls and defers to the previous hook elsewhere.
pub(crate) fn install_panic_hook() {
    PANIC_HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !INSIDE_FMI_CALL.with(Cell::get) {
                previous(info);
            }
        }));
    });
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(text) = payload.downcast_ref::<&str>() {
        (*text).to_owned()
    } else if let Some(text) = payload.downcast_ref::<String>() {
        text.clone()
    } else {
        String::from("(no message)")
    }
}

/// Runs `body` with `catch_unwind`, flagging the thread as inside an FMI call.
pub(crate) fn guarded<T>(body: impl FnOnce() -> T) -> Result<T, String> {
    let was_inside = INSIDE_FMI_CALL.with(|flag| flag.replace(true));
    let result = catch_unwind(AssertUnwindSafe(body));
    INSIDE_FMI_CALL.with(|flag| flag.set(was_inside));
    result.map_err(|payload| panic_message(payload.as_ref()))
}

/// The common frame of every instance function: null check, state check, catch_unwind,
/// logging and the transition to Error on fmi2Error.
///
/// # Safety
/// No call on the same instance runs concurrently (FMI 2.0.4, 2.1.5). Any `c` is checked
/// against the live instances ([`crate::live`]).
pub(crate) unsafe fn with_instance<M: CoSimulationModel>(
    c: Fmi2Component,
    function: &str,
    allowed: u8,
    body: impl FnOnce(&mut Instance<M>) -> Outcome,
) -> Fmi2Status {
    // Null, freed or not ours: no instance, hence no logger to report through (crate::live).
    let Some(address) = live::lookup(c, TypeId::of::<M>()) else {
        return Fmi2Status::Error;
    };
    // SAFETY: `live` lists only instances of M from `instantiate` that are not freed yet; the
    // standard forbids concurrent calls on one instance.
    let instance = unsafe { &mut *(address as *mut Instance<M>) };
    let result = guarded(|| {
        if instance.state as u8 & allowed == 0 {
            return Outcome::Error(format!(
                "{function}: called in state {:?}; allowed in: {}",
                instance.state,
                MachineState::names(allowed)
            ));
        }
        body(&mut *instance)
    });
    let outcome = result.unwrap_or_else(|message| {
        Outcome::Error(format!(
            "{function}: internal error (panic: {message}); the instance is now in the Error state"
        ))
    });
    match outcome {
        Outcome::Ok => Fmi2Status::Ok,
        Outcome::Warning(message) => {
            instance.log_status(Fmi2Status::Warning, &message);
            Fmi2Status::Warning
        }
        Outcome::Discard(message) => {
            instance.log_status(Fmi2Status::Discard, &message);
            Fmi2Status::Discard
        }
        Outcome::Error(message) => {
            instance.log_status(Fmi2Status::Error, &message);
            instance.state = MachineState::Error;
            Fmi2Status::Error
        }
    }
}

/// `fmi2GetTypesPlatform`: "default".
pub fn get_types_platform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`: "2.0".
pub fn get_version() -> *const c_char {
    c"2.0".as_ptr()
}

/// Reads a C string argument; `None` for null or invalid UTF-8 (reported by the caller).
///
/// # Safety
/// `text` is null or a NUL-terminated string.
pub(crate) unsafe fn optional_str(text: *const c_char) -> Option<String> {
    if text.is_null() {
        None
    } else {
        // SAFETY: non-null and NUL-terminated by the caller's contract.
        Some(
            unsafe { CStr::from_ptr(text) }
                .to_string_lossy()
                .into_owned(),
        )
    }
}

/// `fmi2Instantiate`.
///
/// # Safety
/// Pointers are null or valid per the FMI 2.0 standard.
pub unsafe fn instantiate<M: CoSimulationModel>(
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    fmu_guid: Fmi2String,
    fmu_resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    if functions.is_null() {
        return std::ptr::null_mut();
    }
    // SAFETY: non-null, points to the master's callback struct.
    let logger = Logger::Fmi2(unsafe { *functions });
    let refusal = (fmu_type != FMI2_CO_SIMULATION).then(|| {
        format!(
            "fmuType is {fmu_type} ({}); {} supports only fmi2CoSimulation (1)",
            if fmu_type == FMI2_MODEL_EXCHANGE {
                "fmi2ModelExchange"
            } else {
                "unknown"
            },
            M::MODEL_IDENTIFIER
        )
    });
    // SAFETY: the standard requires NUL-terminated strings or null.
    unsafe {
        create_instance::<M>(
            "fmi2Instantiate",
            "fmuGUID",
            logger,
            instance_name,
            fmu_guid,
            fmu_resource_location,
            logging_on != FMI2_FALSE,
            refusal,
        )
    }
}

/// The instantiation both interfaces share: checks the name and the GUID (FMI 3's
/// instantiation token), refuses with `refusal` when the caller found an argument it cannot
/// serve, logs through `logger` and lists the new instance ([`crate::live`]); null on failure.
///
/// # Safety
/// The strings are null or NUL-terminated.
// The arguments are those of the two instantiation functions, plus the names for messages.
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn create_instance<M: CoSimulationModel>(
    function: &str,
    guid_argument: &str,
    logger: Logger,
    instance_name: *const c_char,
    guid: *const c_char,
    resource_location: *const c_char,
    logging_on: bool,
    refusal: Option<String>,
) -> Fmi2Component {
    install_panic_hook();
    let result = guarded(|| {
        // SAFETY: null or NUL-terminated (caller contract).
        let name = unsafe { optional_str(instance_name) };
        let guid = unsafe { optional_str(guid) };
        let resource_location = unsafe { optional_str(resource_location) };
        let fail = |message: String| {
            let label = c_string(name.as_deref().unwrap_or(""));
            log_message(
                &logger,
                &label,
                Fmi2Status::Error,
                "logStatusError",
                &format!("{function}: {message}"),
            );
            std::ptr::null_mut()
        };
        let Some(name) = name.clone().filter(|n| !n.is_empty()) else {
            return fail(String::from(
                "instanceName is NULL or empty; expected a non-empty name",
            ));
        };
        if let Some(refusal) = refusal {
            return fail(refusal);
        }
        match guid.as_deref() {
            Some(guid) if guid == M::GUID => {}
            other => {
                return fail(format!(
                    "{} is {}; expected \"{}\" (that of this binary's model description)",
                    guid_argument,
                    other.map_or(String::from("NULL"), |g| format!("\"{g}\"")),
                    M::GUID
                ))
            }
        }
        let context = InstantiationContext {
            instance_name: name,
            resource_location,
        };
        let instance = Box::new(Instance::<M>::new(context, logger, logging_on));
        instance.log_event(&format!(
            "{function}: instance of {} created",
            M::MODEL_IDENTIFIER
        ));
        live::register(Box::into_raw(instance) as usize, TypeId::of::<M>())
    });
    result.unwrap_or_else(|message| {
        let label = c_string("");
        log_message(
            &logger,
            &label,
            Fmi2Status::Error,
            "logStatusError",
            &format!("{function}: internal error (panic: {message})"),
        );
        std::ptr::null_mut()
    })
}

/// `fmi2FreeInstance`.
///
/// # Safety
/// No other call on the same instance runs concurrently. Any `c` is checked against the live
/// instances ([`crate::live`]): a freed or foreign one is ignored.
pub unsafe fn free_instance<M: CoSimulationModel>(c: Fmi2Component) {
    unsafe { free_instance_as::<M>("fmi2FreeInstance", c) }
}

/// The body of [`free_instance`], with the calling function's name (FMI 2 or FMI 3).
///
/// # Safety
/// As [`free_instance`].
pub unsafe fn free_instance_as<M: CoSimulationModel>(function: &str, c: Fmi2Component) {
    // Null, freed already or not ours: nothing to free (crate::live).
    let Some(address) = live::unregister(c, TypeId::of::<M>()) else {
        return;
    };
    // SAFETY: created by Box::into_raw in `instantiate`, and unlisted just now, so this is the
    // only owner.
    let instance = unsafe { Box::from_raw(address as *mut Instance<M>) };
    let _ = guarded(move || {
        instance.log_event(function);
        drop(instance);
    });
}

/// `fmi2SetDebugLogging`.
///
/// # Safety
/// `categories` holds `n_categories` C strings.
pub unsafe fn set_debug_logging<M: CoSimulationModel>(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    unsafe {
        set_debug_logging_as::<M>(
            "fmi2SetDebugLogging",
            c,
            logging_on != FMI2_FALSE,
            n_categories,
            categories,
        )
    }
}

/// The body of [`set_debug_logging`], with the calling function's name (FMI 2 or FMI 3).
///
/// # Safety
/// `categories` holds `n_categories` C strings.
pub unsafe fn set_debug_logging_as<M: CoSimulationModel>(
    function: &str,
    c: Fmi2Component,
    logging_on: bool,
    n_categories: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_SET_DEBUG_LOGGING, |instance| {
            if n_categories > 0 && categories.is_null() {
                return Outcome::Error(format!(
                    "{function}: categories[] is NULL but nCategories > 0"
                ));
            }
            let mut names = Vec::with_capacity(n_categories);
            for i in 0..n_categories {
                // SAFETY: `categories` holds n_categories entries.
                match optional_str(*categories.add(i)) {
                    Some(name) => names.push(name),
                    None => return Outcome::Error(format!("{function}: categories[{i}] is NULL")),
                }
            }
            let unknown = instance.set_categories(logging_on, &names);
            if unknown.is_empty() {
                Outcome::Ok
            } else {
                Outcome::Warning(format!(
                    "{function}: unknown log category '{}' ignored; the others were applied; known: {}",
                    unknown.join("', '"),
                    M::LOG_CATEGORIES.join(", ")
                ))
            }
        })
    }
}

/// `fmi2SetupExperiment`.
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn setup_experiment<M: CoSimulationModel>(
    c: Fmi2Component,
    _tolerance_defined: Fmi2Boolean,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: Fmi2Boolean,
    stop_time: f64,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(
            c,
            "fmi2SetupExperiment",
            MASK_SETUP_EXPERIMENT,
            |instance| {
                if !start_time.is_finite() {
                    return Outcome::Error(format!(
                        "fmi2SetupExperiment: startTime is {start_time}; expected a finite time"
                    ));
                }
                let stop = (stop_time_defined != FMI2_FALSE).then_some(stop_time);
                if let Some(stop) = stop {
                    if stop.is_nan() || stop < start_time {
                        return Outcome::Error(format!(
                            "fmi2SetupExperiment: stopTime {stop} is before startTime {start_time}"
                        ));
                    }
                }
                instance.start_time = start_time;
                instance.stop_time = stop;
                instance.time = start_time;
                instance.last_successful_time = start_time;
                instance.needs_initialization = true;
                Outcome::Ok
            },
        )
    }
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn enter_initialization_mode<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with_instance::<M>(
            c,
            "fmi2EnterInitializationMode",
            MASK_ENTER_INITIALIZATION_MODE,
            |instance| {
                instance.state = MachineState::InitializationMode;
                instance.log_event("fmi2EnterInitializationMode");
                Outcome::Ok
            },
        )
    }
}

/// `fmi2ExitInitializationMode`: the model checks its parameters and computes its outputs.
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn exit_initialization_mode<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with_instance::<M>(
            c,
            "fmi2ExitInitializationMode",
            MASK_EXIT_INITIALIZATION_MODE,
            |instance| {
                let start = instance.start_time;
                if let Err(message) = instance.model.initialize(start) {
                    return Outcome::Error(format!("fmi2ExitInitializationMode: {message}"));
                }
                if let Err(message) = check_internal_step_size(&instance.model) {
                    return Outcome::Error(format!("fmi2ExitInitializationMode: {message}"));
                }
                instance.needs_initialization = false;
                instance.time = start;
                instance.last_successful_time = start;
                instance.state = MachineState::StepComplete;
                instance.log_event("fmi2ExitInitializationMode");
                Outcome::Ok
            },
        )
    }
}

/// `fmi2Terminate`.
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn terminate<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2Terminate", MASK_TERMINATE, |instance| {
            instance.state = MachineState::Terminated;
            instance.log_event("fmi2Terminate");
            Outcome::Ok
        })
    }
}

/// `fmi2Reset`: back to Instantiated with the start values.
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn reset<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2Reset", MASK_RESET, |instance| {
            instance.model = M::instantiate(&instance.context);
            instance.state = MachineState::Instantiated;
            instance.start_time = 0.0;
            instance.stop_time = None;
            instance.time = 0.0;
            instance.last_successful_time = 0.0;
            instance.needs_initialization = true;
            instance.log_event("fmi2Reset");
            Outcome::Ok
        })
    }
}

/// Checks the array arguments of a get/set call.
pub(crate) fn check_arrays(
    function: &str,
    nvr: usize,
    vr: *const Fmi2ValueReference,
    value_is_null: bool,
) -> Result<(), String> {
    if nvr > 0 && vr.is_null() {
        return Err(format!("{function}: vr[] is NULL but nvr = {nvr}"));
    }
    if nvr > 0 && value_is_null {
        return Err(format!("{function}: value[] is NULL but nvr = {nvr}"));
    }
    Ok(())
}

/// The table row of `(value_type, value_reference)`. The generated direct index
/// ([`VariableStore::variable_row`]) answers in one step; the row it names is confirmed, so a
/// model whose `VARIABLES` is not the generated table still gets the right answer, by binary
/// search.
#[inline]
pub(crate) fn find_variable<M: CoSimulationModel>(
    value_type: ValueType,
    value_reference: u32,
) -> Option<&'static VariableInfo> {
    let indexed = M::Variables::variable_row(value_type, value_reference)
        .and_then(|row| M::VARIABLES.get(row))
        .filter(|row| row.value_type == value_type && row.value_reference == value_reference);
    indexed.or_else(|| VariableInfo::find(M::VARIABLES, value_type, value_reference))
}

#[inline]
pub(crate) fn lookup<M: CoSimulationModel>(
    function: &str,
    value_type: ValueType,
    value_reference: u32,
) -> Result<&'static VariableInfo, String> {
    find_variable::<M>(value_type, value_reference)
        .ok_or_else(|| unknown_reference::<M>(function, value_type, value_reference))
}

#[cold]
#[inline(never)]
fn unknown_reference<M: CoSimulationModel>(
    function: &str,
    value_type: ValueType,
    value_reference: u32,
) -> String {
    format!(
        "{function}: unknown value reference {value_reference}; {} has no {value_type:?} variable with it (see modelDescription.xml)",
        M::MODEL_IDENTIFIER
    )
}

/// The master's `vr[]` as a slice (`nvr` = 0 may come with a null pointer).
///
/// # Safety
/// `vr` points to `nvr` elements when `nvr > 0`, and is non-null then ([`check_arrays`]).
pub(crate) unsafe fn references<'a>(
    vr: *const Fmi2ValueReference,
    nvr: usize,
) -> &'a [Fmi2ValueReference] {
    if nvr == 0 {
        &[]
    } else {
        // SAFETY: non-null and nvr elements long (caller contract).
        unsafe { std::slice::from_raw_parts(vr, nvr) }
    }
}

/// Makes the outputs consistent with the parameters before they are read in
/// initialisation mode.
pub(crate) fn refresh_initial_outputs<M: CoSimulationModel>(
    instance: &mut Instance<M>,
    function: &str,
) -> Result<(), String> {
    if instance.state == MachineState::InitializationMode && instance.needs_initialization {
        let start = instance.start_time;
        instance
            .model
            .initialize(start)
            .map_err(|message| format!("{function}: {message}"))?;
        instance.needs_initialization = false;
    }
    Ok(())
}

/// Shared body of the getters.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements when `nvr > 0`.
pub(crate) unsafe fn get_values<M: CoSimulationModel, T>(
    c: Fmi2Component,
    function: &str,
    value_type: ValueType,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut T,
    read: impl Fn(&M::Variables, u32) -> Option<T>,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_GET, |instance| {
            if let Err(message) = check_arrays(function, nvr, vr, value.is_null()) {
                return Outcome::Error(message);
            }
            if let Err(message) = refresh_initial_outputs(instance, function) {
                return Outcome::Error(message);
            }
            instance.model.refresh_outputs();
            let variables = instance.model.variables();
            for (i, &reference) in references(vr, nvr).iter().enumerate() {
                // The generated storage answers exactly the value references of its type, so a
                // read needs no look-up in the table; the table only explains a failed read.
                match read(variables, reference) {
                    // SAFETY: `value` holds nvr elements (caller contract, checked non-null).
                    Some(v) => value.add(i).write(v),
                    None => {
                        return Outcome::Error(match lookup::<M>(function, value_type, reference) {
                            Err(unknown) => unknown,
                            Ok(_) => format!(
                                "{function}: value reference {reference} is in the variable table but not in the model's storage (internal error)"
                            ),
                        })
                    }
                }
            }
            Outcome::Ok
        })
    }
}

/// `fmi2GetReal`.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn get_real<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut f64,
) -> Fmi2Status {
    unsafe {
        get_values::<M, f64>(c, "fmi2GetReal", ValueType::Real, vr, nvr, value, |v, r| {
            v.real(r)
        })
    }
}

/// `fmi2GetInteger` (also enumerations).
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn get_integer<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    unsafe {
        get_values::<M, Fmi2Integer>(
            c,
            "fmi2GetInteger",
            ValueType::Integer,
            vr,
            nvr,
            value,
            |v, r| v.integer(r),
        )
    }
}

/// `fmi2GetBoolean`.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn get_boolean<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        get_values::<M, Fmi2Boolean>(
            c,
            "fmi2GetBoolean",
            ValueType::Boolean,
            vr,
            nvr,
            value,
            |v, r| v.boolean(r).map(|b| if b { FMI2_TRUE } else { FMI2_FALSE }),
        )
    }
}

/// `fmi2GetString`: these FMUs have no String variables, so any value reference is unknown.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn get_string<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2String,
) -> Fmi2Status {
    unsafe {
        get_values::<M, Fmi2String>(
            c,
            "fmi2GetString",
            ValueType::String,
            vr,
            nvr,
            value,
            |_, _| None,
        )
    }
}

/// Whether `variable` may be set in `state` (FMI 2.0.4 section 2.2.7 and the state table):
/// before the end of initialisation, parameters and inputs; afterwards inputs and tunable
/// parameters.
#[inline]
pub(crate) fn settable(
    function: &str,
    variable: &VariableInfo,
    state: MachineState,
) -> Result<(), String> {
    let initializing = matches!(
        state,
        MachineState::Instantiated | MachineState::InitializationMode
    );
    let ok = match variable.causality {
        Causality::Input => true,
        Causality::Parameter => initializing || variable.variability == Variability::Tunable,
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(not_settable(function, variable))
    }
}

/// The message of a refused [`settable`] (kept out of the per-value path).
#[cold]
#[inline(never)]
fn not_settable(function: &str, variable: &VariableInfo) -> String {
    let what = match variable.causality {
        Causality::Parameter => format!(
            "a {:?} parameter; it can only be set before fmi2ExitInitializationMode",
            variable.variability
        ),
        other => format!("of causality {other:?}; only inputs and parameters can be set"),
    };
    format!("{function}: {} is {what}", variable.label())
}

/// What the setters make of one value (a master must learn of an adjusted value, and one bad value
/// must not lose the others of the call): a value within its
/// variable's range is stored as it is; one outside is clamped where a nearby value means the
/// same thing (Reals and plain Integers), or ignored where no value is near (a NaN parameter, an
/// enumeration value that is no item); both with a warning naming the variable and the value.
pub(crate) enum Admitted<T> {
    As(T),
    Clamped(T, String),
    Ignored(String),
}

/// Shared body of the setters. The value references and whether each variable may be set are
/// checked for every value before any is applied (a misuse is an fmi2Error and applies nothing);
/// then every value is admitted ([`Admitted`]) and stored, and the call answers fmi2Warning with
/// one log line if any was clamped or ignored.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements when `nvr > 0`.
// The arguments mirror the C signature plus the per-type check and store.
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn set_values<M: CoSimulationModel, T: Copy>(
    c: Fmi2Component,
    function: &str,
    value_type: ValueType,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const T,
    admit: impl Fn(&VariableInfo, T) -> Admitted<T>,
    write: impl Fn(&mut M::Variables, u32, T) -> bool,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_SET, |instance| {
            if let Err(message) = check_arrays(function, nvr, vr, value.is_null()) {
                return Outcome::Error(message);
            }
            let references = references(vr, nvr);
            for &reference in references {
                let variable = match lookup::<M>(function, value_type, reference) {
                    Ok(variable) => variable,
                    Err(message) => return Outcome::Error(message),
                };
                if let Err(message) = settable(function, variable, instance.state) {
                    return Outcome::Error(message);
                }
            }
            let mut warnings = Vec::new();
            let mut adjusted = Vec::new();
            let variables = instance.model.variables_mut();
            for (i, &reference) in references.iter().enumerate() {
                // Found in the first pass, so the look-up cannot fail here.
                let Ok(variable) = lookup::<M>(function, value_type, reference) else {
                    continue;
                };
                // SAFETY: `value` holds nvr elements (caller contract, checked non-null).
                let stored = match admit(variable, *value.add(i)) {
                    Admitted::As(stored) => stored,
                    Admitted::Clamped(stored, message) => {
                        warnings.push(format!("{}: {message}", variable.label()));
                        adjusted.push(variable);
                        stored
                    }
                    Admitted::Ignored(message) => {
                        warnings.push(format!("{}: {message}", variable.label()));
                        adjusted.push(variable);
                        continue;
                    }
                };
                if !write(variables, reference, stored) {
                    return Outcome::Error(format!(
                        "{function}: value reference {reference} is in the variable table but not in the model's storage (internal error)"
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

#[inline]
pub(crate) fn admit_real(variable: &VariableInfo, value: f64) -> Admitted<f64> {
    if value.is_nan() {
        // A NaN input means "no sample" (sensor dropout); the model decides what to do.
        return if variable.causality == Causality::Input {
            Admitted::As(value)
        } else {
            Admitted::Ignored(not_finite(value))
        };
    }
    if value >= variable.min && value <= variable.max {
        return Admitted::As(value);
    }
    if value.is_infinite() && variable.causality == Causality::Input {
        return Admitted::As(value);
    }
    let clamped = value.clamp(variable.min, variable.max);
    if clamped.is_finite() {
        Admitted::Clamped(clamped, out_of_range(variable, value, clamped))
    } else {
        Admitted::Ignored(not_finite(value))
    }
}

#[inline]
pub(crate) fn admit_integer(variable: &VariableInfo, value: Fmi2Integer) -> Admitted<Fmi2Integer> {
    let wide = f64::from(value);
    let in_range = wide >= variable.min && wide <= variable.max;
    if variable.allowed_values.is_empty() {
        if in_range {
            return Admitted::As(value);
        }
        // min/max of an Integer are integers (widened to f64), so the clamped value is exact.
        let clamped = wide.clamp(variable.min, variable.max) as Fmi2Integer;
        return Admitted::Clamped(clamped, out_of_range(variable, value, clamped));
    }
    if in_range && variable.allowed_values.contains(&value) {
        Admitted::As(value)
    } else {
        // No item is "near" another one (the estimator kinds, the vehicle models): keep the
        // current item rather than pick one the master did not ask for.
        Admitted::Ignored(not_an_item(variable, value))
    }
}

// The messages of an adjusted value, kept out of the per-value path.

#[cold]
#[inline(never)]
fn not_finite(value: f64) -> String {
    format!("value {value} is not a finite number; the variable keeps its value")
}

#[cold]
#[inline(never)]
fn out_of_range(
    variable: &VariableInfo,
    value: impl std::fmt::Display,
    clamped: impl std::fmt::Display,
) -> String {
    format!(
        "value {value} is outside its range [{}, {}]; clamped to {clamped}",
        variable.min, variable.max
    )
}

#[cold]
#[inline(never)]
fn not_an_item(variable: &VariableInfo, value: Fmi2Integer) -> String {
    format!(
        "value {value} is not an item of the enumeration; expected one of {:?}; the variable keeps its value",
        variable.allowed_values
    )
}

/// `fmi2SetReal`.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn set_real<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const f64,
) -> Fmi2Status {
    unsafe {
        set_values::<M, f64>(
            c,
            "fmi2SetReal",
            ValueType::Real,
            vr,
            nvr,
            value,
            admit_real,
            |v, r, x| v.set_real(r, x),
        )
    }
}

/// `fmi2SetInteger` (also enumerations).
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn set_integer<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    unsafe {
        set_values::<M, Fmi2Integer>(
            c,
            "fmi2SetInteger",
            ValueType::Integer,
            vr,
            nvr,
            value,
            admit_integer,
            |v, r, x| v.set_integer(r, x),
        )
    }
}

/// `fmi2SetBoolean`: any non-zero value is true.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn set_boolean<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        set_values::<M, Fmi2Boolean>(
            c,
            "fmi2SetBoolean",
            ValueType::Boolean,
            vr,
            nvr,
            value,
            |_, x| Admitted::As(x),
            |v, r, x| v.set_boolean(r, x != FMI2_FALSE),
        )
    }
}

/// `fmi2SetString`: no String variables, so any value reference is unknown.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements.
pub unsafe fn set_string<M: CoSimulationModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2String,
) -> Fmi2Status {
    unsafe {
        set_values::<M, Fmi2String>(
            c,
            "fmi2SetString",
            ValueType::String,
            vr,
            nvr,
            value,
            |_, x| Admitted::As(x),
            |_, _, _| false,
        )
    }
}

/// An in-memory FMU state (what `fmi2FMUstate` points to).
struct Snapshot<M: CoSimulationModel> {
    state: MachineState,
    start_time: f64,
    stop_time: Option<f64>,
    time: f64,
    last_successful_time: f64,
    needs_initialization: bool,
    model: M,
}

impl<M: CoSimulationModel> Snapshot<M> {
    fn of(instance: &Instance<M>) -> Self {
        Self {
            state: instance.state,
            start_time: instance.start_time,
            stop_time: instance.stop_time,
            time: instance.time,
            last_successful_time: instance.last_successful_time,
            needs_initialization: instance.needs_initialization,
            model: instance.model.clone(),
        }
    }

    fn restore(&self, instance: &mut Instance<M>) {
        instance.state = self.state;
        instance.start_time = self.start_time;
        instance.stop_time = self.stop_time;
        instance.time = self.time;
        instance.last_successful_time = self.last_successful_time;
        instance.needs_initialization = self.needs_initialization;
        instance.model = self.model.clone();
    }

    fn serialize(&self) -> Result<Vec<u8>, String> {
        let mut writer = StateWriter::framed();
        writer.bytes(M::GUID.as_bytes());
        writer.u8(self.state as u8);
        writer.f64(self.start_time);
        writer.bool(self.stop_time.is_some());
        writer.f64(self.stop_time.unwrap_or(0.0));
        writer.f64(self.time);
        writer.f64(self.last_successful_time);
        writer.bool(self.needs_initialization);
        self.model.variables().write_state(&mut writer);
        self.model.write_state(&mut writer)?;
        Ok(writer.into_framed_bytes())
    }

    fn deserialize(bytes: &[u8], context: &InstantiationContext) -> Result<Self, String> {
        let mut reader = StateReader::framed(bytes).map_err(|e| e.message)?;
        let guid = reader.bytes("GUID").map_err(|e| e.message)?;
        if guid != M::GUID.as_bytes() {
            return Err(format!(
                "the serialized state belongs to GUID \"{}\"; expected \"{}\"",
                String::from_utf8_lossy(guid),
                M::GUID
            ));
        }
        let state_bits = reader.u8("machine state").map_err(|e| e.message)?;
        let state = MachineState::from_bits(state_bits)
            .ok_or_else(|| format!("invalid machine state {state_bits} in the serialized state"))?;
        let start_time = reader.f64("start time").map_err(|e| e.message)?;
        let has_stop = reader.bool("stop time defined").map_err(|e| e.message)?;
        let stop = reader.f64("stop time").map_err(|e| e.message)?;
        let time = reader.f64("time").map_err(|e| e.message)?;
        let last_successful_time = reader.f64("last successful time").map_err(|e| e.message)?;
        let needs_initialization = reader.bool("needs initialization").map_err(|e| e.message)?;
        let mut model = M::instantiate(context);
        model
            .variables_mut()
            .read_state(&mut reader)
            .map_err(|e| e.message)?;
        model.read_state(&mut reader).map_err(|e| e.message)?;
        if !reader.is_at_end() {
            return Err(format!(
                "{} bytes left over after the serialized state; expected none",
                reader.remaining()
            ));
        }
        Ok(Self {
            state,
            start_time,
            stop_time: has_stop.then_some(stop),
            time,
            last_successful_time,
            needs_initialization,
            model,
        })
    }
}

/// A new FMU state holding `snapshot`: a handle listed in [`crate::live`] like a component, so
/// that a freed or foreign state is refused rather than read.
fn new_state<M: CoSimulationModel>(snapshot: Snapshot<M>) -> Fmi2FmuState {
    live::register(
        Box::into_raw(Box::new(snapshot)) as usize,
        TypeId::of::<Snapshot<M>>(),
    ) as Fmi2FmuState
}

/// The snapshot of `state` if it is a live FMU state of this FMU, else the error outcome for
/// `function`.
///
/// # Safety
/// No other call uses the same state concurrently.
unsafe fn live_state<'a, M: CoSimulationModel>(
    state: Fmi2FmuState,
    function: &str,
) -> Result<&'a mut Snapshot<M>, Outcome> {
    match live::lookup(state as Fmi2Component, TypeId::of::<Snapshot<M>>()) {
        // SAFETY: listed, so a Box<Snapshot<M>> from `new_state` that is not freed yet.
        Some(address) => Ok(unsafe { &mut *(address as *mut Snapshot<M>) }),
        None => Err(Outcome::Error(format!(
            "{function}: FMUstate is not an FMU state of this FMU (freed already, or from \
             elsewhere)"
        ))),
    }
}

/// `fmi2GetFMUstate`: a copy of the whole instance state; overwrites `*state` if non-null.
///
/// # Safety
/// `state` is null or writable. A non-null `*state` is checked against the live FMU states.
pub unsafe fn get_fmu_state<M: CoSimulationModel>(
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    unsafe { get_fmu_state_as::<M>("fmi2GetFMUstate", c, state) }
}

/// The body of [`get_fmu_state`], with the name of the calling function (FMI 2 or FMI 3) for messages.
///
/// # Safety
/// As [`get_fmu_state`].
pub(crate) unsafe fn get_fmu_state_as<M: CoSimulationModel>(
    function: &str,
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_FMU_STATE, |instance| {
            if state.is_null() {
                return Outcome::Error(format!("{function}: FMUstate is NULL"));
            }
            // The snapshot holds the outputs as a read now would see them, so its serialized
            // bytes do not depend on whether the outputs were read before.
            instance.model.refresh_outputs();
            let snapshot = Snapshot::of(instance);
            if (*state).is_null() {
                *state = new_state(snapshot);
            } else {
                match live_state::<M>(*state, function) {
                    Ok(stored) => *stored = snapshot,
                    Err(outcome) => return outcome,
                }
            }
            Outcome::Ok
        })
    }
}

/// `fmi2SetFMUstate`: the instance continues exactly from the stored state (including its
/// state-machine state, so this also recovers from Error).
///
/// # Safety
/// Any `state` is checked against the live FMU states.
pub unsafe fn set_fmu_state<M: CoSimulationModel>(
    c: Fmi2Component,
    state: Fmi2FmuState,
) -> Fmi2Status {
    unsafe { set_fmu_state_as::<M>("fmi2SetFMUstate", c, state) }
}

/// The body of [`set_fmu_state`], with the name of the calling function (FMI 2 or FMI 3) for messages.
///
/// # Safety
/// As [`set_fmu_state`].
pub(crate) unsafe fn set_fmu_state_as<M: CoSimulationModel>(
    function: &str,
    c: Fmi2Component,
    state: Fmi2FmuState,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_FMU_STATE, |instance| {
            if state.is_null() {
                return Outcome::Error(format!("{function}: FMUstate is NULL"));
            }
            match live_state::<M>(state, function) {
                Ok(snapshot) => {
                    snapshot.restore(instance);
                    Outcome::Ok
                }
                Err(outcome) => outcome,
            }
        })
    }
}

/// `fmi2FreeFMUstate`.
///
/// # Safety
/// `state` is null or writable; a non-null `*state` is checked against the live FMU states.
pub unsafe fn free_fmu_state<M: CoSimulationModel>(
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    unsafe { free_fmu_state_as::<M>("fmi2FreeFMUstate", c, state) }
}

/// The body of [`free_fmu_state`], with the name of the calling function (FMI 2 or FMI 3) for messages.
///
/// # Safety
/// As [`free_fmu_state`].
pub(crate) unsafe fn free_fmu_state_as<M: CoSimulationModel>(
    function: &str,
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_FMU_STATE, |_| {
            if state.is_null() {
                return Outcome::Error(format!("{function}: FMUstate is NULL"));
            }
            if (*state).is_null() {
                return Outcome::Ok;
            }
            let Some(address) =
                live::unregister(*state as Fmi2Component, TypeId::of::<Snapshot<M>>())
            else {
                return Outcome::Error(format!(
                    "{function}: FMUstate is not an FMU state of this FMU (freed already, \
                     or from elsewhere)"
                ));
            };
            // SAFETY: created by Box::into_raw in `new_state`, unlisted just now.
            drop(Box::from_raw(address as *mut Snapshot<M>));
            *state = std::ptr::null_mut();
            Outcome::Ok
        })
    }
}

/// `fmi2SerializedFMUstateSize`.
///
/// # Safety
/// `size` is null or writable; any `state` is checked against the live FMU states.
pub unsafe fn serialized_fmu_state_size<M: CoSimulationModel>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    unsafe { serialized_fmu_state_size_as::<M>("fmi2SerializedFMUstateSize", c, state, size) }
}

/// The body of [`serialized_fmu_state_size`], with the name of the calling function (FMI 2 or FMI 3) for messages.
///
/// # Safety
/// As [`serialized_fmu_state_size`].
pub(crate) unsafe fn serialized_fmu_state_size_as<M: CoSimulationModel>(
    function: &str,
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_FMU_STATE, |_| {
            if state.is_null() || size.is_null() {
                return Outcome::Error(format!("{function}: FMUstate or size is NULL"));
            }
            let snapshot = match live_state::<M>(state, function) {
                Ok(snapshot) => snapshot,
                Err(outcome) => return outcome,
            };
            match snapshot.serialize() {
                Ok(bytes) => {
                    *size = bytes.len();
                    Outcome::Ok
                }
                Err(message) => Outcome::Error(format!("{function}: {message}")),
            }
        })
    }
}

/// `fmi2SerializeFMUstate`: `size` must be what fmi2SerializedFMUstateSize returned.
///
/// # Safety
/// `bytes` has room for `size` bytes; any `state` is checked against the live FMU states.
pub unsafe fn serialize_fmu_state<M: CoSimulationModel>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    bytes: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    unsafe { serialize_fmu_state_as::<M>("fmi2SerializeFMUstate", c, state, bytes, size) }
}

/// The body of [`serialize_fmu_state`], with the name of the calling function (FMI 2 or FMI 3) for messages.
///
/// # Safety
/// As [`serialize_fmu_state`].
pub(crate) unsafe fn serialize_fmu_state_as<M: CoSimulationModel>(
    function: &str,
    c: Fmi2Component,
    state: Fmi2FmuState,
    bytes: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_FMU_STATE, |_| {
            if state.is_null() || bytes.is_null() {
                return Outcome::Error(format!("{function}: FMUstate or serializedState is NULL"));
            }
            let snapshot = match live_state::<M>(state, function) {
                Ok(snapshot) => snapshot,
                Err(outcome) => return outcome,
            };
            let serialized = match snapshot.serialize() {
                Ok(bytes) => bytes,
                Err(message) => return Outcome::Error(format!("{function}: {message}")),
            };
            if serialized.len() != size {
                return Outcome::Error(format!(
                    "{function}: size is {size}; expected {} (the serialized size of this state)",
                    serialized.len()
                ));
            }
            std::ptr::copy_nonoverlapping(serialized.as_ptr(), bytes as *mut u8, size);
            Outcome::Ok
        })
    }
}

/// `fmi2DeSerializeFMUstate`: always creates a new FMU state in `*state`.
///
/// # Safety
/// `bytes` holds `size` bytes; `state` is writable.
pub unsafe fn deserialize_fmu_state<M: CoSimulationModel>(
    c: Fmi2Component,
    bytes: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    unsafe { deserialize_fmu_state_as::<M>("fmi2DeSerializeFMUstate", c, bytes, size, state) }
}

/// The body of [`deserialize_fmu_state`], with the name of the calling function (FMI 2 or FMI 3) for messages.
///
/// # Safety
/// As [`deserialize_fmu_state`].
pub(crate) unsafe fn deserialize_fmu_state_as<M: CoSimulationModel>(
    function: &str,
    c: Fmi2Component,
    bytes: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, function, MASK_FMU_STATE, |instance| {
            if bytes.is_null() || state.is_null() {
                return Outcome::Error(format!("{function}: serializedState or FMUstate is NULL"));
            }
            let slice = std::slice::from_raw_parts(bytes as *const u8, size);
            match Snapshot::<M>::deserialize(slice, &instance.context) {
                Ok(snapshot) => {
                    *state = new_state(snapshot);
                    Outcome::Ok
                }
                Err(message) => Outcome::Error(format!("{function}: {message}")),
            }
        })
    }
}

/// `fmi2GetDirectionalDerivative`: not provided (providesDirectionalDerivative=false).
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn get_directional_derivative<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with_instance::<M>(
            c,
            "fmi2GetDirectionalDerivative",
            MASK_DIRECTIONAL_DERIVATIVE,
            |_| {
                Outcome::Error(String::from(
                    "fmi2GetDirectionalDerivative: not supported (providesDirectionalDerivative=\"false\")",
                ))
            },
        )
    }
}

/// `fmi2SetRealInputDerivatives`: not supported (canInterpolateInputs=false).
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn set_real_input_derivatives<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with_instance::<M>(
            c,
            "fmi2SetRealInputDerivatives",
            MASK_SET_REAL_INPUT_DERIVATIVES,
            |_| {
                Outcome::Error(String::from(
                    "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs=\"false\")",
                ))
            },
        )
    }
}

/// `fmi2GetRealOutputDerivatives`: not supported (maxOutputDerivativeOrder=0).
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn get_real_output_derivatives<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with_instance::<M>(
            c,
            "fmi2GetRealOutputDerivatives",
            MASK_GET_REAL_OUTPUT_DERIVATIVES,
            |_| {
                Outcome::Error(String::from(
                    "fmi2GetRealOutputDerivatives: not supported (maxOutputDerivativeOrder=\"0\")",
                ))
            },
        )
    }
}

/// `fmi2DoStep`.
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn do_step<M: CoSimulationModel>(
    c: Fmi2Component,
    current_communication_point: f64,
    communication_step_size: f64,
    _no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2DoStep", MASK_DO_STEP, |instance| {
            step(
                instance,
                "fmi2DoStep",
                current_communication_point,
                communication_step_size,
            )
        })
    }
}

/// The step both interfaces take, with `function` naming the caller in messages.
pub(crate) fn step<M: CoSimulationModel>(
    instance: &mut crate::Instance<M>,
    function: &str,
    t: f64,
    h: f64,
) -> Outcome {
    if !(h > 0.0 && h.is_finite()) {
        return Outcome::Error(format!(
            "{function}: communicationStepSize is {h}; expected a finite step > 0"
        ));
    }
    let tolerance = crate::TIME_TOLERANCE * instance.time.abs().max(1.0);
    if !t.is_finite() || (t - instance.time).abs() > tolerance {
        return Outcome::Error(format!(
            "{function}: currentCommunicationPoint is {t:?} but the last step ended at {:?}; \
             expected the same time (tolerance {tolerance:e})",
            instance.time
        ));
    }
    if let Some(stop) = instance.stop_time {
        if t + h > stop + crate::TIME_TOLERANCE * stop.abs().max(1.0) {
            return Outcome::Error(format!(
                "{function}: the step ends at {:?}, after the stopTime {stop:?} given at initialisation",
                t + h
            ));
        }
    }
    if let Err(message) = check_work_of_step(&instance.model, h) {
        instance.state = MachineState::StepFailed;
        return Outcome::Discard(format!("{function} at t = {t}: {message}"));
    }
    match instance.model.do_step(t, h) {
        StepOutcome::Ok => {
            instance.time = t + h;
            instance.last_successful_time = t + h;
            Outcome::Ok
        }
        StepOutcome::Warning(message) => {
            instance.time = t + h;
            instance.last_successful_time = t + h;
            Outcome::Warning(format!("{function} at t = {t}: {message}"))
        }
        StepOutcome::Notice(message) => {
            instance.time = t + h;
            instance.last_successful_time = t + h;
            instance.log_notice(&format!("{function} at t = {t}: {message}"));
            Outcome::Ok
        }
        StepOutcome::Discard(message) => {
            instance.state = MachineState::StepFailed;
            Outcome::Discard(format!("{function} at t = {t}: {message}"))
        }
        StepOutcome::Error(message) => Outcome::Error(format!("{function} at t = {t}: {message}")),
    }
}

/// Refuses an internal step size that is not finite and positive or below the model's minimum
/// (a parameter that would make a step loop without bound).
pub(crate) fn check_internal_step_size<M: CoSimulationModel>(model: &M) -> Result<(), String> {
    match model.internal_step_size() {
        Some(size) if !(size.is_finite() && size >= M::MIN_INTERNAL_STEP_SIZE) => Err(format!(
            "the parameters give an internal step of {size:e} s; expected a finite step of at least {:e} s",
            M::MIN_INTERNAL_STEP_SIZE
        )),
        _ => Ok(()),
    }
}

/// Refuses a communication step that would take more than `M::MAX_INTERNAL_STEPS` internal
/// steps, before the model runs, so that no call blocks a master for minutes.
pub(crate) fn check_work_of_step<M: CoSimulationModel>(
    model: &M,
    step_size: f64,
) -> Result<(), String> {
    let Some(size) = model.internal_step_size() else {
        return Ok(());
    };
    check_internal_step_size(model)?;
    let steps = (step_size / size).ceil();
    if steps <= M::MAX_INTERNAL_STEPS as f64 {
        Ok(())
    } else {
        Err(format!(
            "a communication step of {step_size} s takes {steps:e} internal steps of {size:e} s, more than the {} one call may take; take communication steps of at most {:e} s",
            M::MAX_INTERNAL_STEPS,
            size * M::MAX_INTERNAL_STEPS as f64
        ))
    }
}

/// `fmi2CancelStep`: there is never an asynchronous step to cancel.
///
/// # Safety
/// `c` is a live instance of `M`.
pub unsafe fn cancel_step<M: CoSimulationModel>(c: Fmi2Component) -> Fmi2Status {
    unsafe { with_instance::<M>(c, "fmi2CancelStep", MASK_CANCEL_STEP, |_| Outcome::Ok) }
}

/// `fmi2GetStatus`: only meaningful after fmi2Pending, which never happens: fmi2Discard.
///
/// # Safety
/// `value` is null or writable.
pub unsafe fn get_status<M: CoSimulationModel>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Status,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2GetStatus", MASK_GET_STATUS, |_| {
            if value.is_null() {
                return Outcome::Error(String::from("fmi2GetStatus: value is NULL"));
            }
            Outcome::Discard(format!(
                "fmi2GetStatus: no status of kind {kind}: doStep never runs asynchronously"
            ))
        })
    }
}

/// `fmi2GetRealStatus`: fmi2LastSuccessfulTime is the end of the last completed step.
///
/// # Safety
/// `value` is null or writable.
pub unsafe fn get_real_status<M: CoSimulationModel>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut f64,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2GetRealStatus", MASK_GET_STATUS, |instance| {
            if value.is_null() {
                return Outcome::Error(String::from("fmi2GetRealStatus: value is NULL"));
            }
            if kind == FMI2_LAST_SUCCESSFUL_TIME {
                *value = instance.last_successful_time;
                Outcome::Ok
            } else {
                Outcome::Discard(format!(
                    "fmi2GetRealStatus: no Real status of kind {kind}; only fmi2LastSuccessfulTime (2)"
                ))
            }
        })
    }
}

/// `fmi2GetIntegerStatus`: FMI 2.0 defines no Integer status: fmi2Discard.
///
/// # Safety
/// `value` is null or writable.
pub unsafe fn get_integer_status<M: CoSimulationModel>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2GetIntegerStatus", MASK_GET_STATUS, |_| {
            if value.is_null() {
                return Outcome::Error(String::from("fmi2GetIntegerStatus: value is NULL"));
            }
            Outcome::Discard(format!(
                "fmi2GetIntegerStatus: no Integer status of kind {kind}"
            ))
        })
    }
}

/// `fmi2GetBooleanStatus`: fmi2Terminated is false (the FMU never asks to stop).
///
/// # Safety
/// `value` is null or writable.
pub unsafe fn get_boolean_status<M: CoSimulationModel>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2GetBooleanStatus", MASK_GET_STATUS, |_| {
            if value.is_null() {
                return Outcome::Error(String::from("fmi2GetBooleanStatus: value is NULL"));
            }
            if kind == FMI2_TERMINATED {
                *value = FMI2_FALSE;
                Outcome::Ok
            } else {
                Outcome::Discard(format!(
                    "fmi2GetBooleanStatus: no Boolean status of kind {kind}; only fmi2Terminated (3)"
                ))
            }
        })
    }
}

/// `fmi2GetStringStatus`: no pending asynchronous step, so no status text: fmi2Discard.
///
/// # Safety
/// `value` is null or writable.
pub unsafe fn get_string_status<M: CoSimulationModel>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2String,
) -> Fmi2Status {
    unsafe {
        with_instance::<M>(c, "fmi2GetStringStatus", MASK_GET_STATUS, |_| {
            if value.is_null() {
                return Outcome::Error(String::from("fmi2GetStringStatus: value is NULL"));
            }
            Outcome::Discard(format!(
                "fmi2GetStringStatus: no String status of kind {kind}: doStep never runs asynchronously"
            ))
        })
    }
}
