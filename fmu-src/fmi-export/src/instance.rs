//! One FMU instance: the model, the FMI state machine, time bookkeeping and the logger.

use std::ffi::{c_char, CString};

use crate::ffi::{Fmi2CallbackFunctions, Fmi2Status};
use crate::ffi3::{Fmi3InstanceEnvironment, Fmi3LogMessageCallback};
use crate::{CoSimulationModel, InstantiationContext};

/// The master's logger, as the interface the instance was created through passes it.
#[derive(Clone, Copy)]
pub(crate) enum Logger {
    /// FMI 2.0: the variadic `fmi2CallbackLogger` of the callback struct.
    Fmi2(Fmi2CallbackFunctions),
    /// FMI 3.0: `fmi3LogMessageCallback` with the instance environment.
    Fmi3 {
        environment: Fmi3InstanceEnvironment,
        log_message: Fmi3LogMessageCallback,
    },
}

/// Which FMI version's functions created (and therefore drive) an instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interface {
    Fmi2,
    Fmi3,
}

/// The states of the FMI 2.0 Co-Simulation state machine this implementation can be in
/// (StepInProgress and StepCanceled do not occur: steps are never asynchronous). The values are
/// bits so that the allowed states of a function form a mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum MachineState {
    Instantiated = 1,
    InitializationMode = 2,
    StepComplete = 4,
    StepFailed = 8,
    Terminated = 16,
    Error = 32,
}

impl MachineState {
    pub(crate) fn from_bits(bits: u8) -> Option<Self> {
        [
            Self::Instantiated,
            Self::InitializationMode,
            Self::StepComplete,
            Self::StepFailed,
            Self::Terminated,
            Self::Error,
        ]
        .into_iter()
        .find(|state| *state as u8 == bits)
    }

    /// Names of the states in a mask, for messages.
    pub(crate) fn names(mask: u8) -> String {
        let names: Vec<String> = [
            Self::Instantiated,
            Self::InitializationMode,
            Self::StepComplete,
            Self::StepFailed,
            Self::Terminated,
            Self::Error,
        ]
        .into_iter()
        .filter(|state| mask & (*state as u8) != 0)
        .map(|state| format!("{state:?}"))
        .collect();
        if names.is_empty() {
            String::from("no state of this FMU (it never runs asynchronous steps)")
        } else {
            names.join(", ")
        }
    }
}

/// Log categories the plumbing uses; they must appear in the model description's LogCategories.
pub(crate) const CATEGORY_EVENTS: &str = "logEvents";
pub(crate) const CATEGORY_WARNING: &str = "logStatusWarning";
pub(crate) const CATEGORY_DISCARD: &str = "logStatusDiscard";
pub(crate) const CATEGORY_ERROR: &str = "logStatusError";
pub(crate) const CATEGORY_FATAL: &str = "logStatusFatal";
pub(crate) const CATEGORY_ALL: &str = "logAll";

/// An FMU instance (what `fmi2Component` points to).
pub struct Instance<M: CoSimulationModel> {
    pub(crate) context: InstantiationContext,
    name: CString,
    logger: Logger,
    /// Which of `M::LOG_CATEGORIES` are switched on (bit i = category i).
    enabled_categories: u64,
    pub(crate) state: MachineState,
    pub(crate) start_time: f64,
    pub(crate) stop_time: Option<f64>,
    /// The communication point the next fmi2DoStep must start at.
    pub(crate) time: f64,
    pub(crate) last_successful_time: f64,
    /// Variables changed in Instantiated/InitializationMode since the model last initialised.
    pub(crate) needs_initialization: bool,
    pub(crate) model: M,
}

impl<M: CoSimulationModel> Instance<M> {
    pub(crate) fn new(context: InstantiationContext, logger: Logger, logging_on: bool) -> Self {
        let name = c_string(&context.instance_name);
        let model = M::instantiate(&context);
        Self {
            context,
            name,
            logger,
            enabled_categories: if logging_on { u64::MAX } else { 0 },
            state: MachineState::Instantiated,
            start_time: 0.0,
            stop_time: None,
            time: 0.0,
            last_successful_time: 0.0,
            needs_initialization: true,
            model,
        }
    }

    /// The model, for tests and benchmarks that hold an instance.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The FMI version whose functions created the instance.
    pub fn interface(&self) -> Interface {
        match self.logger {
            Logger::Fmi2(_) => Interface::Fmi2,
            Logger::Fmi3 { .. } => Interface::Fmi3,
        }
    }

    /// The current state of the state machine.
    pub fn machine_state(&self) -> MachineState {
        self.state
    }

    fn category_enabled(&self, category: &str) -> bool {
        M::LOG_CATEGORIES
            .iter()
            .position(|name| *name == category)
            .is_some_and(|index| index < 64 && self.enabled_categories & (1 << index) != 0)
    }

    /// Enables or disables categories (fmi2SetDebugLogging). An empty list means all. The known
    /// categories are applied; the unknown ones (e.g. the standard's `logSingularLinearSystems`,
    /// which a model without linear systems does not list) are returned so that the caller can
    /// warn about them, and are otherwise ignored, so that a master asking for a standard
    /// category keeps a usable instance.
    pub(crate) fn set_categories(&mut self, on: bool, categories: &[String]) -> Vec<String> {
        let mut mask = 0u64;
        let mut unknown = Vec::new();
        if categories.is_empty() {
            mask = u64::MAX;
        }
        for category in categories {
            match M::LOG_CATEGORIES.iter().position(|name| name == category) {
                Some(_) if category == CATEGORY_ALL => mask = u64::MAX,
                Some(index) if index < 64 => mask |= 1 << index,
                _ => unknown.push(category.clone()),
            }
        }
        if on {
            self.enabled_categories |= mask;
        } else {
            self.enabled_categories &= !mask;
        }
        unknown
    }

    /// Logs an event (only when logging is switched on for logEvents).
    pub(crate) fn log_event(&self, message: &str) {
        if self.category_enabled(CATEGORY_EVENTS) || self.category_enabled(CATEGORY_ALL) {
            log_message(
                &self.logger,
                &self.name,
                Fmi2Status::Ok,
                CATEGORY_EVENTS,
                message,
            );
        }
    }

    /// Logs a notice: status OK, warning category, shown unless the master switched logging
    /// on and left that category off (as warnings are).
    pub(crate) fn log_notice(&self, message: &str) {
        if self.enabled_categories == 0 || self.category_enabled(CATEGORY_WARNING) {
            log_message(
                &self.logger,
                &self.name,
                Fmi2Status::Ok,
                CATEGORY_WARNING,
                message,
            );
        }
    }

    /// Logs a message that comes with a non-OK status. Errors and fatal errors are always
    /// logged (a misuse must leave a trace); warnings and discards unless the master switched
    /// logging on and then turned their category off — with logging off they are still shown,
    /// because the master would otherwise see a status without a reason.
    pub(crate) fn log_status(&self, status: Fmi2Status, message: &str) {
        let category = match status {
            Fmi2Status::Warning => CATEGORY_WARNING,
            Fmi2Status::Discard => CATEGORY_DISCARD,
            Fmi2Status::Fatal => CATEGORY_FATAL,
            _ => CATEGORY_ERROR,
        };
        let show = match status {
            Fmi2Status::Error | Fmi2Status::Fatal => true,
            _ => self.enabled_categories == 0 || self.category_enabled(category),
        };
        if show {
            log_message(&self.logger, &self.name, status, category, message);
        }
    }
}

/// A C string of `text`, with interior NUL bytes replaced so that nothing is cut off.
pub(crate) fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', "\\0")).unwrap_or_default()
}

/// Calls the master's logger: FMI 2 as `logger(env, instance, status, category, "%s",
/// message)`, FMI 3 as `logMessage(env, status, category, message)` (whose callback names no
/// instance: the environment identifies it).
pub(crate) fn log_message(
    logger: &Logger,
    instance_name: &CString,
    status: Fmi2Status,
    category: &str,
    message: &str,
) {
    let category = c_string(category);
    let message = c_string(message);
    match *logger {
        Logger::Fmi2(callbacks) => {
            let Some(logger) = callbacks.logger else {
                return;
            };
            const FORMAT: &[u8] = b"%s\0";
            // SAFETY: the logger is the master's fmi2CallbackLogger; every pointer is a valid
            // NUL-terminated string that outlives the call, and "%s" consumes exactly the one
            // argument.
            unsafe {
                logger(
                    callbacks.component_environment,
                    instance_name.as_ptr(),
                    status,
                    category.as_ptr(),
                    FORMAT.as_ptr() as *const c_char,
                    message.as_ptr(),
                );
            }
        }
        Logger::Fmi3 {
            environment,
            log_message,
        } => {
            let Some(log_message) = log_message else {
                return;
            };
            // SAFETY: the master's fmi3LogMessageCallback with the environment it gave to
            // fmi3InstantiateCoSimulation; both strings are NUL-terminated and outlive the call.
            unsafe { log_message(environment, status, category.as_ptr(), message.as_ptr()) }
        }
    }
}
