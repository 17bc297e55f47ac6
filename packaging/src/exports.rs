//! Checks that a built shared library exports the whole FMI 2.0 and FMI 3.0 Co-Simulation APIs
//! (one library serves both archives).
//!
//! Importers such as fmpy bind every common and co-simulation function when they load the library
//! and refuse it if one is missing, so a missing export must stop packaging, not a user's tool.

use std::ffi::{c_char, CStr};
use std::path::Path;

use anyhow::{bail, Context, Result};

/// FMI 2.0.4, sections 2.1 (common) and 4.2 (co-simulation).
pub const FMI2_CO_SIMULATION_FUNCTIONS: [&str; 34] = [
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
];

/// Every function of FMI 3.0's `fmi3Functions.h`: fmpy binds them all when it loads an FMI 3
/// library, whichever interface it uses (the Model Exchange and Scheduled Execution ones answer
/// fmi3Error in these Co-Simulation FMUs).
pub const FMI3_FUNCTIONS: [&str; 75] = [
    "fmi3GetVersion",
    "fmi3SetDebugLogging",
    "fmi3InstantiateModelExchange",
    "fmi3InstantiateCoSimulation",
    "fmi3InstantiateScheduledExecution",
    "fmi3FreeInstance",
    "fmi3EnterInitializationMode",
    "fmi3ExitInitializationMode",
    "fmi3EnterEventMode",
    "fmi3Terminate",
    "fmi3Reset",
    "fmi3GetFloat32",
    "fmi3GetFloat64",
    "fmi3GetInt8",
    "fmi3GetUInt8",
    "fmi3GetInt16",
    "fmi3GetUInt16",
    "fmi3GetInt32",
    "fmi3GetUInt32",
    "fmi3GetInt64",
    "fmi3GetUInt64",
    "fmi3GetBoolean",
    "fmi3GetString",
    "fmi3GetBinary",
    "fmi3GetClock",
    "fmi3SetFloat32",
    "fmi3SetFloat64",
    "fmi3SetInt8",
    "fmi3SetUInt8",
    "fmi3SetInt16",
    "fmi3SetUInt16",
    "fmi3SetInt32",
    "fmi3SetUInt32",
    "fmi3SetInt64",
    "fmi3SetUInt64",
    "fmi3SetBoolean",
    "fmi3SetString",
    "fmi3SetBinary",
    "fmi3SetClock",
    "fmi3GetNumberOfVariableDependencies",
    "fmi3GetVariableDependencies",
    "fmi3GetFMUState",
    "fmi3SetFMUState",
    "fmi3FreeFMUState",
    "fmi3SerializedFMUStateSize",
    "fmi3SerializeFMUState",
    "fmi3DeserializeFMUState",
    "fmi3GetDirectionalDerivative",
    "fmi3GetAdjointDerivative",
    "fmi3EnterConfigurationMode",
    "fmi3ExitConfigurationMode",
    "fmi3GetIntervalDecimal",
    "fmi3GetIntervalFraction",
    "fmi3GetShiftDecimal",
    "fmi3GetShiftFraction",
    "fmi3SetIntervalDecimal",
    "fmi3SetIntervalFraction",
    "fmi3SetShiftDecimal",
    "fmi3SetShiftFraction",
    "fmi3EvaluateDiscreteStates",
    "fmi3UpdateDiscreteStates",
    "fmi3EnterStepMode",
    "fmi3GetOutputDerivatives",
    "fmi3DoStep",
    "fmi3EnterContinuousTimeMode",
    "fmi3CompletedIntegratorStep",
    "fmi3SetTime",
    "fmi3SetContinuousStates",
    "fmi3GetContinuousStateDerivatives",
    "fmi3GetEventIndicators",
    "fmi3GetContinuousStates",
    "fmi3GetNominalsOfContinuousStates",
    "fmi3GetNumberOfEventIndicators",
    "fmi3GetNumberOfContinuousStates",
    "fmi3ActivateModelPartition",
];

/// Loads the library, checks every export and that fmi2GetVersion answers "2.0",
/// fmi3GetVersion "3.0" and fmi2GetTypesPlatform "default" (the header the binary was built against).
pub fn check_library(path: &Path) -> Result<()> {
    // SAFETY: loading runs the library's initialisers; the library is our own FMU build, which has
    // no load-time side effects beyond Rust's runtime set-up.
    let library = unsafe { libloading::Library::new(path) }
        .with_context(|| format!("{}: cannot be loaded", path.display()))?;
    let result = check_loaded(path, &library);
    // Never dlclose: unloading is what the FMU's own tests exercise (1,000 cycles under fmpy); this
    // short-lived tool must not fail on, or mask, an unload problem while it only inspects exports.
    std::mem::forget(library);
    result
}

fn check_loaded(path: &Path, library: &libloading::Library) -> Result<()> {
    let missing: Vec<&str> = FMI2_CO_SIMULATION_FUNCTIONS
        .iter()
        .chain(FMI3_FUNCTIONS.iter())
        .copied()
        // SAFETY: only the symbol's presence is checked; the pointer is not called.
        .filter(|name| unsafe { library.get::<*const ()>(name.as_bytes()) }.is_err())
        .collect();
    if !missing.is_empty() {
        bail!(
            "{}: does not export {} of the FMI 2.0 and 3.0 co-simulation functions: {}",
            path.display(),
            missing.len(),
            missing.join(", ")
        );
    }
    type StringFunction = unsafe extern "C" fn() -> *const c_char;
    for (function, expected) in [
        ("fmi2GetVersion", "2.0"),
        ("fmi2GetTypesPlatform", "default"),
        ("fmi3GetVersion", "3.0"),
    ] {
        // SAFETY: these functions take no arguments and return a static C string (FMI 2.0
        // §2.1.4, FMI 3.0 §2.3.1).
        let answer = unsafe {
            let symbol = library.get::<StringFunction>(function.as_bytes())?;
            let pointer = symbol();
            if pointer.is_null() {
                bail!("{}: {function} returned a null pointer", path.display());
            }
            CStr::from_ptr(pointer).to_string_lossy().into_owned()
        };
        if answer != expected {
            bail!(
                "{}: {function} returned {answer:?}, expected {expected:?}",
                path.display()
            );
        }
    }
    Ok(())
}
