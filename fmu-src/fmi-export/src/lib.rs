//! FMI 2.0 and FMI 3.0 Co-Simulation plumbing, written once for both FMUs.
//!
//! An FMU crate is a short file of equations: it includes the variable table generated from its
//! modelDescription.xml (crate `model-description`, build-time), implements
//! [`CoSimulationModel`] and expands [`export_fmi2!`], which defines every FMI 2.0 common and
//! co-simulation function as a `#[no_mangle] extern "C"` symbol of that crate (symbols of an
//! rlib are not exported reliably from a cdylib, so the functions are generated inside it):
//!
//! ```ignore
//! include!(concat!(env!("OUT_DIR"), "/model_description.rs"));
//! #[derive(Clone)]
//! pub struct MyModel { variables: Variables, /* internal state */ }
//! impl fmi_export::CoSimulationModel for MyModel { /* instantiate, initialize, do_step, … */ }
//! fmi_export::export_fmi2!(MyModel);
//! ```
//!
//! [`export_fmi3!`] defines the FMI 3.0 functions beside them ([`api3`]), on the same
//! instance, state machine, checks, logging and FMU-state frames, so one library serves an FMI
//! 2.0 and an FMI 3.0 archive and both answer bit-identically.
//!
//! What the plumbing guarantees (FMI 2.0.4, sections 2.1 and 4.2; FMI 3.0 likewise, see
//! [`api3`] for what it names differently):
//!
//! - **State machine.** Each call is checked against the states the standard allows it in
//!   (the masks in [`api`]); a call in another state answers `fmi2Error` with a log line
//!   "fmi2X: called in state S; allowed in …".
//! - **Errors.** Every `fmi2Error` is logged (always, whatever `loggingOn` says) and moves the
//!   instance to the *Error* state, as the standard specifies; from there `fmi2Reset`,
//!   `fmi2SetFMUstate` (back to a stored state), the getters and `fmi2FreeInstance` are allowed.
//!   `fmi2Discard` is used where the standard allows it: a step the model cannot complete in
//!   `fmi2DoStep` (state *StepFailed*), and status queries that have no answer (`fmi2GetStatus`
//!   without an asynchronous step).
//! - **Values out of range** in `fmi2SetReal`/`fmi2SetInteger` answer `fmi2Warning` with a log
//!   line naming the variable and the value, and every other value of the call is applied: a
//!   Real or Integer outside its min/max is clamped to the nearer bound; a NaN parameter and an
//!   enumeration value that is no item are ignored (the variable keeps its value). A NaN or
//!   infinite *input* is stored as it is, without a warning: it means "sample missing".
//! - **Unknown log categories** in `fmi2SetDebugLogging` answer `fmi2Warning` with a log line
//!   and are ignored; the known ones of the call are applied and the instance stays usable.
//! - **Checks.** Null pointers, unknown value references (per base type), wrong GUID, wrong
//!   fmuType, `communicationStepSize <= 0` or non-finite, a `currentCommunicationPoint` that
//!   does not continue the last step (relative tolerance [`TIME_TOLERANCE`]: masters send
//!   0.009999999999999998 for 0.01), a step beyond a defined stopTime, setting a fixed parameter
//!   after initialisation or an output at any time.
//! - **Stale components.** The `fmi2Component` a master holds is a handle listed with its
//!   instance ([`live`]): a call with one that is freed already or was never an instance of this
//!   library answers `fmi2Error` (unlogged: the logger belongs to the instance), and
//!   `fmi2FreeInstance` ignores it. FMI++ 2.1 frees in `terminate()` and again in its destructor.
//!   FMU states likewise: a freed or foreign one answers `fmi2Error` with a log line.
//! - **Logging.** Through the master's logger, always as `logger(env, name, status, category,
//!   "%s", message)`; categories logEvents, logStatusWarning, logStatusDiscard, logStatusError,
//!   logStatusFatal, logAll.
//! - **No panic crosses `extern "C"`**: every entry is wrapped in `catch_unwind`; a panic is
//!   logged with its message and answered with `fmi2Error` (Error state). The crate has no
//!   thread-local with a destructor; the one thread-local flag is a `Cell<bool>`.
//! - **Work per call.** A model that steps internally names its internal step size
//!   ([`CoSimulationModel::internal_step_size`]); a size that is not finite, not positive or
//!   below [`CoSimulationModel::MIN_INTERNAL_STEP_SIZE`] is refused at initialisation
//!   (`fmi2Error`), and a communication step that would take more than
//!   [`CoSimulationModel::MAX_INTERNAL_STEPS`] internal steps answers `fmi2Discard` before the
//!   model runs (checked again on every call, so a restored state cannot bypass it).
//! - **FMU state.** Get/Set/Free copy the whole model (Clone); serialisation writes the
//!   variables and the model's internal state with [`StateWriter`] (f64 by bit pattern), so a
//!   restored or deserialized state continues bit-identically; the bytes are framed with a
//!   format version, their length and a checksum, and anything that does not match is refused.

pub mod api;
pub mod api3;
mod export3;
pub mod ffi;
pub mod ffi3;
#[cfg(feature = "testing")]
pub mod fuzzing;
#[cfg(feature = "testing")]
pub mod fuzzing3;
mod instance;
pub mod live;
mod state;
#[cfg(feature = "testing")]
pub mod testing;
mod variables;

pub use instance::{Instance, Interface, MachineState};
pub use state::{fnv1a_64, StateError, StateReader, StateWriter, STATE_FORMAT_VERSION};
pub use variables::{
    dense_row, Causality, ValueType, Variability, VariableInfo, VariableStore, NO_ROW,
};

/// A variable of the FMI 3.0 interface only (value references from 1000): an array, or a
/// scalar that describes one, which the FMI 2.0 model description cannot express. The table is
/// generated from the FMU's FMI 3 supplement (`modelDescription/<model>.fmi3.xml`, see the
/// `model-description` crate), which also enters the generated FMI 3 model description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fmi3Variable {
    pub name: &'static str,
    pub value_reference: u32,
    pub kind: Fmi3Kind,
}

/// The type of an [`Fmi3Variable`]: the independent variable, or a calculated output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fmi3Kind {
    /// The independent variable (time) FMI 3.0 requires, a Float64 scalar: the plumbing
    /// answers it with the instance's current time.
    Time,
    /// A `Float64` array with these fixed dimensions (row-major, FMI 3.0 2.4.7.1).
    Float64 { dimensions: &'static [usize] },
    /// An `Int32` scalar.
    Int32,
}

impl Fmi3Variable {
    /// Number of scalar elements the variable holds.
    pub fn elements(&self) -> usize {
        match self.kind {
            Fmi3Kind::Float64 { dimensions } => dimensions.iter().product(),
            Fmi3Kind::Int32 | Fmi3Kind::Time => 1,
        }
    }
}

/// Relative tolerance when comparing a master's communication point with the end of the last
/// step: `|t_master - t_fmu| <= TIME_TOLERANCE * max(1, |t_fmu|)`.
pub const TIME_TOLERANCE: f64 = 1e-9;

/// What `fmi2Instantiate` received, for models that need it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InstantiationContext {
    pub instance_name: String,
    pub resource_location: Option<String>,
}

/// How a `do_step` ended.
#[derive(Debug, Clone, PartialEq)]
pub enum StepOutcome {
    /// The step was completed.
    Ok,
    /// The step was completed, but something is not quite right (logged, `fmi2Warning`).
    Warning(String),
    /// The step was completed and returns `fmi2OK`; the message is logged in the warning
    /// category with status OK. For what a user should read but a master need not act on:
    /// importers such as FMI++ stop advancing their clock after a step that answers
    /// `fmi2Warning`.
    Notice(String),
    /// The step could not be completed (`fmi2Discard`, state StepFailed); the model kept its
    /// last consistent values.
    Discard(String),
    /// The model cannot continue (`fmi2Error`, state Error).
    Error(String),
}

/// One FMU's equations. The plumbing calls these only in states where the standard allows it,
/// with value references and ranges already checked against [`CoSimulationModel::VARIABLES`].
pub trait CoSimulationModel: Clone + Send + Sized + 'static {
    /// The generated `Variables` struct.
    type Variables: VariableStore;
    /// The modelIdentifier (generated `MODEL_IDENTIFIER`).
    const MODEL_IDENTIFIER: &'static str;
    /// The GUID fmi2Instantiate must receive (generated `GUID`).
    const GUID: &'static str;
    /// The generated variable table, sorted by (value type, value reference).
    const VARIABLES: &'static [VariableInfo];
    /// The LogCategories of the model description (generated `LOG_CATEGORIES`).
    const LOG_CATEGORIES: &'static [&'static str];

    /// The most internal steps one `fmi2DoStep` may take: a call whose
    /// communication step would take more, `ceil(step_size / internal_step_size)`, answers
    /// `fmi2Discard` with a message before the model runs, so that no call blocks a master for
    /// minutes. 100 000 internal steps of a Kalman filter take well under a second.
    const MAX_INTERNAL_STEPS: u64 = 100_000;

    /// The shortest internal step a model may be configured with; an internal step size
    /// below it (or not finite and positive) is refused at initialisation with a message.
    /// No vehicle signal needs a sampling faster than 1 GHz.
    const MIN_INTERNAL_STEP_SIZE: f64 = 1e-9;

    /// The length of the model's internal steps with the current parameters (e.g. a sensor
    /// sample period), checked at initialisation and before every `do_step` against
    /// [`CoSimulationModel::MIN_INTERNAL_STEP_SIZE`] and
    /// [`CoSimulationModel::MAX_INTERNAL_STEPS`]; `None` (the default) for a model that takes
    /// one internal step per communication step.
    fn internal_step_size(&self) -> Option<f64> {
        None
    }

    /// Told after fmi2SetReal/fmi2SetInteger stored a value other than the one sent (clamped
    /// into the variable's range) or ignored it (the call answered fmi2Warning, see the setters),
    /// so that the model can say so in its own outputs too (the estimator's `status` bit
    /// 1024). The default does nothing.
    fn value_adjusted(&mut self, _variable: &'static VariableInfo) {}

    /// The FMI 3-only variables (generated `FMI3_VARIABLES`; none by default).
    const FMI3_VARIABLES: &'static [Fmi3Variable] = &[];

    /// The dependencies of each output of the ModelStructure, as value references of the
    /// knowns (generated `OUTPUT_DEPENDENCIES`), for fmi3GetVariableDependencies.
    const OUTPUT_DEPENDENCIES: &'static [(u32, &'static [u32])] = &[];

    /// Fills `values` (of [`Fmi3Variable::elements`] length) with the FMI 3-only `Float64`
    /// variable `value_reference`, after [`CoSimulationModel::refresh_outputs`]; `false` when
    /// the model has no such variable.
    fn fmi3_float64(&self, _value_reference: u32, _values: &mut [f64]) -> bool {
        false
    }

    /// The FMI 3-only `Int32` variable `value_reference`, after
    /// [`CoSimulationModel::refresh_outputs`]; `None` when the model has no such variable.
    fn fmi3_int32(&self, _value_reference: u32) -> Option<i32> {
        None
    }

    /// A fresh instance holding the start values (fmi2Instantiate, fmi2Reset).
    fn instantiate(context: &InstantiationContext) -> Self;

    fn variables(&self) -> &Self::Variables;
    fn variables_mut(&mut self) -> &mut Self::Variables;

    /// Checks the parameters, builds the internal model and computes the outputs at
    /// `start_time`. Called when initialisation mode is left, and before outputs are read in
    /// initialisation mode after a change; must therefore be repeatable. An `Err` message names
    /// the offending parameter and what was expected.
    fn initialize(&mut self, start_time: f64) -> Result<(), String>;

    /// Advances from `current_time` by `step_size` (> 0, already checked) using the inputs as
    /// currently set, and updates the outputs. Must not allocate on the heap in the normal path.
    fn do_step(&mut self, current_time: f64, step_size: f64) -> StepOutcome;

    /// Brings outputs a model computes lazily up to date. Called before any variable is read
    /// (fmi2Get*) and before fmi2GetFMUstate; a model that updates its outputs in `do_step`
    /// keeps this default, which does nothing.
    fn refresh_outputs(&mut self) {}

    /// Appends the internal state (everything beyond the variables) for fmi2SerializeFMUstate;
    /// `Err` (a message) when this state cannot be serialized.
    fn write_state(&self, writer: &mut StateWriter) -> Result<(), String>;

    /// Restores what [`CoSimulationModel::write_state`] wrote, into an instance created by
    /// [`CoSimulationModel::instantiate`] whose variables have already been restored.
    fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError>;
}

/// Defines every FMI 2.0 common and co-simulation function for `$model` as an exported C symbol
/// of the crate that expands it. Expand it once, in the FMU's cdylib crate.
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        /// FMI 2.0 `fmi2GetTypesPlatform`.
        #[no_mangle]
        pub extern "C" fn fmi2GetTypesPlatform() -> *const ::std::ffi::c_char {
            $crate::api::get_types_platform()
        }

        /// FMI 2.0 `fmi2GetVersion`.
        #[no_mangle]
        pub extern "C" fn fmi2GetVersion() -> *const ::std::ffi::c_char {
            $crate::api::get_version()
        }

        /// FMI 2.0 `fmi2SetDebugLogging`.
        ///
        /// # Safety
        /// `c` is an instance of this FMU; `categories` holds `n_categories` C strings.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetDebugLogging(
            c: $crate::ffi::Fmi2Component,
            logging_on: $crate::ffi::Fmi2Boolean,
            n_categories: usize,
            categories: *const $crate::ffi::Fmi2String,
        ) -> $crate::ffi::Fmi2Status {
            unsafe {
                $crate::api::set_debug_logging::<$model>(c, logging_on, n_categories, categories)
            }
        }

        /// FMI 2.0 `fmi2Instantiate`.
        ///
        /// # Safety
        /// Pointers are null or valid C strings / callback structs, as the standard requires.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2Instantiate(
            instance_name: $crate::ffi::Fmi2String,
            fmu_type: $crate::ffi::Fmi2Type,
            fmu_guid: $crate::ffi::Fmi2String,
            fmu_resource_location: $crate::ffi::Fmi2String,
            functions: *const $crate::ffi::Fmi2CallbackFunctions,
            visible: $crate::ffi::Fmi2Boolean,
            logging_on: $crate::ffi::Fmi2Boolean,
        ) -> $crate::ffi::Fmi2Component {
            unsafe {
                $crate::api::instantiate::<$model>(
                    instance_name,
                    fmu_type,
                    fmu_guid,
                    fmu_resource_location,
                    functions,
                    visible,
                    logging_on,
                )
            }
        }

        /// FMI 2.0 `fmi2FreeInstance`.
        ///
        /// # Safety
        /// `c` is null or an instance of this FMU that is not used afterwards.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2FreeInstance(c: $crate::ffi::Fmi2Component) {
            unsafe { $crate::api::free_instance::<$model>(c) }
        }

        /// FMI 2.0 `fmi2SetupExperiment`.
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetupExperiment(
            c: $crate::ffi::Fmi2Component,
            tolerance_defined: $crate::ffi::Fmi2Boolean,
            tolerance: f64,
            start_time: f64,
            stop_time_defined: $crate::ffi::Fmi2Boolean,
            stop_time: f64,
        ) -> $crate::ffi::Fmi2Status {
            unsafe {
                $crate::api::setup_experiment::<$model>(
                    c,
                    tolerance_defined,
                    tolerance,
                    start_time,
                    stop_time_defined,
                    stop_time,
                )
            }
        }

        /// FMI 2.0 `fmi2EnterInitializationMode`.
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2EnterInitializationMode(
            c: $crate::ffi::Fmi2Component,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::enter_initialization_mode::<$model>(c) }
        }

        /// FMI 2.0 `fmi2ExitInitializationMode`.
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2ExitInitializationMode(
            c: $crate::ffi::Fmi2Component,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::exit_initialization_mode::<$model>(c) }
        }

        /// FMI 2.0 `fmi2Terminate`.
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2Terminate(
            c: $crate::ffi::Fmi2Component,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::terminate::<$model>(c) }
        }

        /// FMI 2.0 `fmi2Reset`.
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2Reset(
            c: $crate::ffi::Fmi2Component,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::reset::<$model>(c) }
        }

        /// FMI 2.0 `fmi2GetReal`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetReal(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *mut f64,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_real::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetInteger`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetInteger(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::ffi::Fmi2Integer,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_integer::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetBoolean`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetBoolean(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::ffi::Fmi2Boolean,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_boolean::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetString`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetString(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::ffi::Fmi2String,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_string::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetReal`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetReal(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *const f64,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::set_real::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetInteger`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetInteger(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::ffi::Fmi2Integer,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::set_integer::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetBoolean`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetBoolean(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::ffi::Fmi2Boolean,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::set_boolean::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2SetString`.
        ///
        /// # Safety
        /// `vr` and `value` point to `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetString(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::ffi::Fmi2String,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::set_string::<$model>(c, vr, nvr, value) }
        }

        /// FMI 2.0 `fmi2GetFMUstate`.
        ///
        /// # Safety
        /// `state` points to an `fmi2FMUstate` (null or from this FMU).
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetFMUstate(
            c: $crate::ffi::Fmi2Component,
            state: *mut $crate::ffi::Fmi2FmuState,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_fmu_state::<$model>(c, state) }
        }

        /// FMI 2.0 `fmi2SetFMUstate`.
        ///
        /// # Safety
        /// `state` is an FMU state of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetFMUstate(
            c: $crate::ffi::Fmi2Component,
            state: $crate::ffi::Fmi2FmuState,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::set_fmu_state::<$model>(c, state) }
        }

        /// FMI 2.0 `fmi2FreeFMUstate`.
        ///
        /// # Safety
        /// `state` points to an `fmi2FMUstate` (null or from this FMU).
        #[no_mangle]
        pub unsafe extern "C" fn fmi2FreeFMUstate(
            c: $crate::ffi::Fmi2Component,
            state: *mut $crate::ffi::Fmi2FmuState,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::free_fmu_state::<$model>(c, state) }
        }

        /// FMI 2.0 `fmi2SerializedFMUstateSize`.
        ///
        /// # Safety
        /// `state` is an FMU state of this FMU; `size` is writable.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
            c: $crate::ffi::Fmi2Component,
            state: $crate::ffi::Fmi2FmuState,
            size: *mut usize,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::serialized_fmu_state_size::<$model>(c, state, size) }
        }

        /// FMI 2.0 `fmi2SerializeFMUstate`.
        ///
        /// # Safety
        /// `bytes` has room for `size` bytes.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SerializeFMUstate(
            c: $crate::ffi::Fmi2Component,
            state: $crate::ffi::Fmi2FmuState,
            bytes: *mut $crate::ffi::Fmi2Byte,
            size: usize,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::serialize_fmu_state::<$model>(c, state, bytes, size) }
        }

        /// FMI 2.0 `fmi2DeSerializeFMUstate`.
        ///
        /// # Safety
        /// `bytes` holds `size` bytes; `state` is writable.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
            c: $crate::ffi::Fmi2Component,
            bytes: *const $crate::ffi::Fmi2Byte,
            size: usize,
            state: *mut $crate::ffi::Fmi2FmuState,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::deserialize_fmu_state::<$model>(c, bytes, size, state) }
        }

        /// FMI 2.0 `fmi2GetDirectionalDerivative` (not provided: answers fmi2Error).
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
            c: $crate::ffi::Fmi2Component,
            unknown: *const $crate::ffi::Fmi2ValueReference,
            n_unknown: usize,
            known: *const $crate::ffi::Fmi2ValueReference,
            n_known: usize,
            dv_known: *const f64,
            dv_unknown: *mut f64,
        ) -> $crate::ffi::Fmi2Status {
            let _ = (unknown, n_unknown, known, n_known, dv_known, dv_unknown);
            unsafe { $crate::api::get_directional_derivative::<$model>(c) }
        }

        /// FMI 2.0 `fmi2SetRealInputDerivatives` (canInterpolateInputs=false: fmi2Error).
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            order: *const $crate::ffi::Fmi2Integer,
            value: *const f64,
        ) -> $crate::ffi::Fmi2Status {
            let _ = (vr, nvr, order, value);
            unsafe { $crate::api::set_real_input_derivatives::<$model>(c) }
        }

        /// FMI 2.0 `fmi2GetRealOutputDerivatives` (maxOutputDerivativeOrder=0: fmi2Error).
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
            c: $crate::ffi::Fmi2Component,
            vr: *const $crate::ffi::Fmi2ValueReference,
            nvr: usize,
            order: *const $crate::ffi::Fmi2Integer,
            value: *mut f64,
        ) -> $crate::ffi::Fmi2Status {
            let _ = (vr, nvr, order, value);
            unsafe { $crate::api::get_real_output_derivatives::<$model>(c) }
        }

        /// FMI 2.0 `fmi2DoStep`.
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2DoStep(
            c: $crate::ffi::Fmi2Component,
            current_communication_point: f64,
            communication_step_size: f64,
            no_set_fmu_state_prior_to_current_point: $crate::ffi::Fmi2Boolean,
        ) -> $crate::ffi::Fmi2Status {
            unsafe {
                $crate::api::do_step::<$model>(
                    c,
                    current_communication_point,
                    communication_step_size,
                    no_set_fmu_state_prior_to_current_point,
                )
            }
        }

        /// FMI 2.0 `fmi2CancelStep` (steps are never asynchronous: fmi2Error).
        ///
        /// # Safety
        /// `c` is an instance of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2CancelStep(
            c: $crate::ffi::Fmi2Component,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::cancel_step::<$model>(c) }
        }

        /// FMI 2.0 `fmi2GetStatus`.
        ///
        /// # Safety
        /// `value` is writable.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetStatus(
            c: $crate::ffi::Fmi2Component,
            kind: $crate::ffi::Fmi2StatusKind,
            value: *mut $crate::ffi::Fmi2Status,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_status::<$model>(c, kind, value) }
        }

        /// FMI 2.0 `fmi2GetRealStatus`.
        ///
        /// # Safety
        /// `value` is writable.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetRealStatus(
            c: $crate::ffi::Fmi2Component,
            kind: $crate::ffi::Fmi2StatusKind,
            value: *mut f64,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_real_status::<$model>(c, kind, value) }
        }

        /// FMI 2.0 `fmi2GetIntegerStatus`.
        ///
        /// # Safety
        /// `value` is writable.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetIntegerStatus(
            c: $crate::ffi::Fmi2Component,
            kind: $crate::ffi::Fmi2StatusKind,
            value: *mut $crate::ffi::Fmi2Integer,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_integer_status::<$model>(c, kind, value) }
        }

        /// FMI 2.0 `fmi2GetBooleanStatus`.
        ///
        /// # Safety
        /// `value` is writable.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetBooleanStatus(
            c: $crate::ffi::Fmi2Component,
            kind: $crate::ffi::Fmi2StatusKind,
            value: *mut $crate::ffi::Fmi2Boolean,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_boolean_status::<$model>(c, kind, value) }
        }

        /// FMI 2.0 `fmi2GetStringStatus`.
        ///
        /// # Safety
        /// `value` is writable.
        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetStringStatus(
            c: $crate::ffi::Fmi2Component,
            kind: $crate::ffi::Fmi2StatusKind,
            value: *mut $crate::ffi::Fmi2String,
        ) -> $crate::ffi::Fmi2Status {
            unsafe { $crate::api::get_string_status::<$model>(c, kind, value) }
        }
    };
}
