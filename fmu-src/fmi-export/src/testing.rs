//! Test and benchmark support (feature `testing`): the FMI 2.0 functions as a table of function
//! pointers — taken either from an FMU crate linked as rlib ([`fmi2_api_of!`]) or from the built
//! shared library loaded with libloading ([`Fmi2Api::load`]) — a logger that records every
//! message, and a small [`Slave`] wrapper. It drives the FMUs exactly through their C ABI.

use std::ffi::{c_char, CStr, CString};
use std::sync::Mutex;

use crate::ffi::*;

/// Every FMI 2.0 common and co-simulation function of one FMU.
#[derive(Clone, Copy)]
pub struct Fmi2Api {
    pub get_types_platform: unsafe extern "C" fn() -> *const c_char,
    pub get_version: unsafe extern "C" fn() -> *const c_char,
    pub set_debug_logging:
        unsafe extern "C" fn(Fmi2Component, Fmi2Boolean, usize, *const Fmi2String) -> Fmi2Status,
    pub instantiate: unsafe extern "C" fn(
        Fmi2String,
        Fmi2Type,
        Fmi2String,
        Fmi2String,
        *const Fmi2CallbackFunctions,
        Fmi2Boolean,
        Fmi2Boolean,
    ) -> Fmi2Component,
    pub free_instance: unsafe extern "C" fn(Fmi2Component),
    pub setup_experiment:
        unsafe extern "C" fn(Fmi2Component, Fmi2Boolean, f64, f64, Fmi2Boolean, f64) -> Fmi2Status,
    pub enter_initialization_mode: unsafe extern "C" fn(Fmi2Component) -> Fmi2Status,
    pub exit_initialization_mode: unsafe extern "C" fn(Fmi2Component) -> Fmi2Status,
    pub terminate: unsafe extern "C" fn(Fmi2Component) -> Fmi2Status,
    pub reset: unsafe extern "C" fn(Fmi2Component) -> Fmi2Status,
    pub get_real: unsafe extern "C" fn(Fmi2Component, *const u32, usize, *mut f64) -> Fmi2Status,
    pub get_integer:
        unsafe extern "C" fn(Fmi2Component, *const u32, usize, *mut Fmi2Integer) -> Fmi2Status,
    pub get_boolean:
        unsafe extern "C" fn(Fmi2Component, *const u32, usize, *mut Fmi2Boolean) -> Fmi2Status,
    pub get_string:
        unsafe extern "C" fn(Fmi2Component, *const u32, usize, *mut Fmi2String) -> Fmi2Status,
    pub set_real: unsafe extern "C" fn(Fmi2Component, *const u32, usize, *const f64) -> Fmi2Status,
    pub set_integer:
        unsafe extern "C" fn(Fmi2Component, *const u32, usize, *const Fmi2Integer) -> Fmi2Status,
    pub set_boolean:
        unsafe extern "C" fn(Fmi2Component, *const u32, usize, *const Fmi2Boolean) -> Fmi2Status,
    pub set_string:
        unsafe extern "C" fn(Fmi2Component, *const u32, usize, *const Fmi2String) -> Fmi2Status,
    pub get_fmu_state: unsafe extern "C" fn(Fmi2Component, *mut Fmi2FmuState) -> Fmi2Status,
    pub set_fmu_state: unsafe extern "C" fn(Fmi2Component, Fmi2FmuState) -> Fmi2Status,
    pub free_fmu_state: unsafe extern "C" fn(Fmi2Component, *mut Fmi2FmuState) -> Fmi2Status,
    pub serialized_fmu_state_size:
        unsafe extern "C" fn(Fmi2Component, Fmi2FmuState, *mut usize) -> Fmi2Status,
    pub serialize_fmu_state:
        unsafe extern "C" fn(Fmi2Component, Fmi2FmuState, *mut Fmi2Byte, usize) -> Fmi2Status,
    pub deserialize_fmu_state: unsafe extern "C" fn(
        Fmi2Component,
        *const Fmi2Byte,
        usize,
        *mut Fmi2FmuState,
    ) -> Fmi2Status,
    pub get_directional_derivative: unsafe extern "C" fn(
        Fmi2Component,
        *const u32,
        usize,
        *const u32,
        usize,
        *const f64,
        *mut f64,
    ) -> Fmi2Status,
    pub set_real_input_derivatives: unsafe extern "C" fn(
        Fmi2Component,
        *const u32,
        usize,
        *const Fmi2Integer,
        *const f64,
    ) -> Fmi2Status,
    pub get_real_output_derivatives: unsafe extern "C" fn(
        Fmi2Component,
        *const u32,
        usize,
        *const Fmi2Integer,
        *mut f64,
    ) -> Fmi2Status,
    pub do_step: unsafe extern "C" fn(Fmi2Component, f64, f64, Fmi2Boolean) -> Fmi2Status,
    pub cancel_step: unsafe extern "C" fn(Fmi2Component) -> Fmi2Status,
    pub get_status:
        unsafe extern "C" fn(Fmi2Component, Fmi2StatusKind, *mut Fmi2Status) -> Fmi2Status,
    pub get_real_status:
        unsafe extern "C" fn(Fmi2Component, Fmi2StatusKind, *mut f64) -> Fmi2Status,
    pub get_integer_status:
        unsafe extern "C" fn(Fmi2Component, Fmi2StatusKind, *mut Fmi2Integer) -> Fmi2Status,
    pub get_boolean_status:
        unsafe extern "C" fn(Fmi2Component, Fmi2StatusKind, *mut Fmi2Boolean) -> Fmi2Status,
    pub get_string_status:
        unsafe extern "C" fn(Fmi2Component, Fmi2StatusKind, *mut Fmi2String) -> Fmi2Status,
}

/// The function table of an FMU crate linked as an rlib: `fmi2_api_of!(ReferenceVehicle)`.
#[macro_export]
macro_rules! fmi2_api_of {
    ($krate:path) => {{
        use $krate as fmu;
        $crate::testing::Fmi2Api {
            get_types_platform: fmu::fmi2GetTypesPlatform,
            get_version: fmu::fmi2GetVersion,
            set_debug_logging: fmu::fmi2SetDebugLogging,
            instantiate: fmu::fmi2Instantiate,
            free_instance: fmu::fmi2FreeInstance,
            setup_experiment: fmu::fmi2SetupExperiment,
            enter_initialization_mode: fmu::fmi2EnterInitializationMode,
            exit_initialization_mode: fmu::fmi2ExitInitializationMode,
            terminate: fmu::fmi2Terminate,
            reset: fmu::fmi2Reset,
            get_real: fmu::fmi2GetReal,
            get_integer: fmu::fmi2GetInteger,
            get_boolean: fmu::fmi2GetBoolean,
            get_string: fmu::fmi2GetString,
            set_real: fmu::fmi2SetReal,
            set_integer: fmu::fmi2SetInteger,
            set_boolean: fmu::fmi2SetBoolean,
            set_string: fmu::fmi2SetString,
            get_fmu_state: fmu::fmi2GetFMUstate,
            set_fmu_state: fmu::fmi2SetFMUstate,
            free_fmu_state: fmu::fmi2FreeFMUstate,
            serialized_fmu_state_size: fmu::fmi2SerializedFMUstateSize,
            serialize_fmu_state: fmu::fmi2SerializeFMUstate,
            deserialize_fmu_state: fmu::fmi2DeSerializeFMUstate,
            get_directional_derivative: fmu::fmi2GetDirectionalDerivative,
            set_real_input_derivatives: fmu::fmi2SetRealInputDerivatives,
            get_real_output_derivatives: fmu::fmi2GetRealOutputDerivatives,
            do_step: fmu::fmi2DoStep,
            cancel_step: fmu::fmi2CancelStep,
            get_status: fmu::fmi2GetStatus,
            get_real_status: fmu::fmi2GetRealStatus,
            get_integer_status: fmu::fmi2GetIntegerStatus,
            get_boolean_status: fmu::fmi2GetBooleanStatus,
            get_string_status: fmu::fmi2GetStringStatus,
        }
    }};
}

impl Fmi2Api {
    /// Looks every function up in a loaded shared library.
    ///
    /// # Safety
    /// The library must be an FMI 2.0 FMU binary; the table must not outlive it.
    pub unsafe fn load(library: &libloading::Library) -> Result<Self, String> {
        macro_rules! symbol {
            ($name:literal) => {{
                // SAFETY: the symbol has the signature the standard gives it, which is the type
                // of the field it is assigned to.
                *unsafe { library.get($name.as_bytes()) }
                    .map_err(|error| format!("symbol {} not found: {error}", $name))?
            }};
        }
        Ok(Self {
            get_types_platform: symbol!("fmi2GetTypesPlatform"),
            get_version: symbol!("fmi2GetVersion"),
            set_debug_logging: symbol!("fmi2SetDebugLogging"),
            instantiate: symbol!("fmi2Instantiate"),
            free_instance: symbol!("fmi2FreeInstance"),
            setup_experiment: symbol!("fmi2SetupExperiment"),
            enter_initialization_mode: symbol!("fmi2EnterInitializationMode"),
            exit_initialization_mode: symbol!("fmi2ExitInitializationMode"),
            terminate: symbol!("fmi2Terminate"),
            reset: symbol!("fmi2Reset"),
            get_real: symbol!("fmi2GetReal"),
            get_integer: symbol!("fmi2GetInteger"),
            get_boolean: symbol!("fmi2GetBoolean"),
            get_string: symbol!("fmi2GetString"),
            set_real: symbol!("fmi2SetReal"),
            set_integer: symbol!("fmi2SetInteger"),
            set_boolean: symbol!("fmi2SetBoolean"),
            set_string: symbol!("fmi2SetString"),
            get_fmu_state: symbol!("fmi2GetFMUstate"),
            set_fmu_state: symbol!("fmi2SetFMUstate"),
            free_fmu_state: symbol!("fmi2FreeFMUstate"),
            serialized_fmu_state_size: symbol!("fmi2SerializedFMUstateSize"),
            serialize_fmu_state: symbol!("fmi2SerializeFMUstate"),
            deserialize_fmu_state: symbol!("fmi2DeSerializeFMUstate"),
            get_directional_derivative: symbol!("fmi2GetDirectionalDerivative"),
            set_real_input_derivatives: symbol!("fmi2SetRealInputDerivatives"),
            get_real_output_derivatives: symbol!("fmi2GetRealOutputDerivatives"),
            do_step: symbol!("fmi2DoStep"),
            cancel_step: symbol!("fmi2CancelStep"),
            get_status: symbol!("fmi2GetStatus"),
            get_real_status: symbol!("fmi2GetRealStatus"),
            get_integer_status: symbol!("fmi2GetIntegerStatus"),
            get_boolean_status: symbol!("fmi2GetBooleanStatus"),
            get_string_status: symbol!("fmi2GetStringStatus"),
        })
    }
}

/// A closure that calls `step(t)` with `t` = 0, `step_size`, 2 `step_size`, … on successive
/// calls: a benchmark body that advances simulated time by one communication step per iteration.
pub fn stepping<T>(step_size: f64, mut step: impl FnMut(f64) -> T) -> impl FnMut() -> T {
    let mut t = 0.0;
    move || {
        let result = step(t);
        t += step_size;
        result
    }
}

/// Median and fastest time of one call, in nanoseconds, of each body in `bodies`, measured
/// with their samples interleaved: each round takes one sample of every body in turn, each
/// sample `calls_per_sample` calls. A load on the machine then hits all bodies alike, so their
/// ratios hold where separate benchmark runs, minutes apart, do not. Also returns, per body, the
/// median over rounds of its time divided by the first body's time in the same round.
pub fn interleaved_timings(
    bodies: &mut [&mut dyn FnMut()],
    rounds: usize,
    calls_per_sample: usize,
) -> Vec<InterleavedTiming> {
    let mut samples = vec![Vec::with_capacity(rounds); bodies.len()];
    for _ in 0..rounds {
        for (body, times) in bodies.iter_mut().zip(samples.iter_mut()) {
            let start = std::time::Instant::now();
            for _ in 0..calls_per_sample {
                body();
            }
            times.push(start.elapsed().as_secs_f64() * 1e9 / calls_per_sample as f64);
        }
    }
    let median = |mut values: Vec<f64>| {
        values.sort_by(f64::total_cmp);
        values[values.len() / 2]
    };
    let first = samples.first().cloned().unwrap_or_default();
    samples
        .into_iter()
        .map(|times| {
            let ratios = times.iter().zip(&first).map(|(t, f)| t / f).collect();
            let fastest = times.iter().copied().fold(f64::INFINITY, f64::min);
            InterleavedTiming {
                median_ns: median(times),
                fastest_ns: fastest,
                median_ratio_to_first: median(ratios),
            }
        })
        .collect()
}

/// One body's result of [`interleaved_timings`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterleavedTiming {
    pub median_ns: f64,
    pub fastest_ns: f64,
    /// Median over rounds of (this body's time / the first body's time in that round).
    pub median_ratio_to_first: f64,
}

/// Rounds of [`DoStepOverhead`]'s interleaved samples.
const OVERHEAD_ROUNDS: usize = 201;

/// The FMU benches' summary after divan's table: per case, the bare model or filter step, the
/// model struct's `do_step` and `fmi2DoStep` through the C ABI, timed interleaved
/// ([`interleaved_timings`]) so that their ratios are not at the mercy of a load that came and
/// went between divan's separate entries. "FMI layer" is fmi2DoStep over the model struct's
/// do_step, paired per round (state machine, argument and time checks, catch_unwind; the
/// plumbing may cost at most 10 %); "over bare step" (from the medians) adds the FMU's own work around the
/// equations or the filter.
pub struct DoStepOverhead;

impl DoStepOverhead {
    /// Prints the header; `what` names the step ("one doStep, h = 1 ms").
    pub fn header(what: &str) -> Self {
        println!();
        println!("Summary: {what}, {OVERHEAD_ROUNDS} interleaved samples per entry, medians in ns");
        println!(
            "{:<28} {:>10} {:>12} {:>12} {:>11} {:>15}",
            "case", "bare step", "model step", "fmi2DoStep", "FMI layer", "over bare step"
        );
        Self
    }

    /// Times and prints one case; each sample makes `calls` calls of each body.
    pub fn row(
        &self,
        label: &str,
        calls: usize,
        model_step: &mut dyn FnMut(),
        fmi2_do_step: &mut dyn FnMut(),
        bare_step: &mut dyn FnMut(),
    ) {
        let t = interleaved_timings(
            &mut [model_step, fmi2_do_step, bare_step],
            OVERHEAD_ROUNDS,
            calls,
        );
        let layer = t[1].median_ratio_to_first - 1.0;
        let over_bare = t[1].median_ns / t[2].median_ns - 1.0;
        let verdict = if layer <= 0.10 { "met" } else { "OVER 10 %" };
        println!(
            "{label:<28} {:>10.0} {:>12.0} {:>12.0} {:>10.1}% {:>14.1}%  {verdict}",
            t[2].median_ns,
            t[0].median_ns,
            t[1].median_ns,
            100.0 * layer,
            100.0 * over_bare
        );
    }
}

/// Whether a bench binary was started by `cargo bench` (which passes `--bench`), not by
/// `cargo test --benches` or `--list`: only then is a summary after divan's table wanted.
pub fn benchmarking() -> bool {
    let args: Vec<String> = std::env::args().collect();
    args.iter().any(|a| a == "--bench") && !args.iter().any(|a| a == "--test" || a == "--list")
}

/// The rows of a generated variable table with one base type and causality (e.g. the real
/// outputs a master reads every step), in table order.
pub fn variables_of(
    table: &'static [crate::VariableInfo],
    value_type: crate::ValueType,
    causality: crate::Causality,
) -> impl Iterator<Item = &'static crate::VariableInfo> {
    table
        .iter()
        .filter(move |v| v.value_type == value_type && v.causality == causality)
}

/// The value references of [`variables_of`].
pub fn references_of(
    table: &'static [crate::VariableInfo],
    value_type: crate::ValueType,
    causality: crate::Causality,
) -> Vec<u32> {
    variables_of(table, value_type, causality)
        .map(|v| v.value_reference)
        .collect()
}

/// The shared library `lib<modelIdentifier>.so` built next to the running test or benchmark
/// executable (`target/<profile>/deps/<exe>` → `target/<profile>/lib<id>.so`).
pub fn built_library_path(model_identifier: &str) -> Result<std::path::PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| format!("current_exe: {e}"))?;
    let file = format!("lib{model_identifier}.so");
    let mut candidates = Vec::new();
    for dir in exe.ancestors().skip(1).take(3) {
        let candidate = dir.join(&file);
        if candidate.is_file() {
            return Ok(candidate);
        }
        candidates.push(candidate.display().to_string());
    }
    Err(format!(
        "{file} not found; looked at {} (build it with `cargo build -p <crate>` for the same profile)",
        candidates.join(", ")
    ))
}

/// One message the FMU sent to the logger.
#[derive(Debug, Clone, PartialEq)]
pub struct LogLine {
    pub instance_name: String,
    pub status: Fmi2Status,
    pub category: String,
    /// The format argument (the plumbing always passes "%s").
    pub format: String,
    pub message: String,
}

/// Records logger calls; the `componentEnvironment` of the callbacks points at it.
#[derive(Debug, Default)]
pub struct LogCapture {
    pub lines: Mutex<Vec<LogLine>>,
}

impl LogCapture {
    pub fn lines(&self) -> Vec<LogLine> {
        self.lines.lock().map(|l| l.clone()).unwrap_or_default()
    }

    pub fn clear(&self) {
        if let Ok(mut lines) = self.lines.lock() {
            lines.clear();
        }
    }

    /// The last message, if any.
    pub fn last(&self) -> Option<LogLine> {
        self.lines().last().cloned()
    }
}

/// The logger: reads exactly one variadic argument, because the plumbing passes "%s" as the
/// format. On x86-64 System V and AArch64 Linux a variadic call passes these six pointer/integer
/// arguments like a plain call, so a fixed-arity function can receive it (Rust cannot define
/// variadic functions on stable; fmpy's ctypes logger works the same way).
unsafe extern "C" fn record(
    environment: Fmi2ComponentEnvironment,
    instance_name: Fmi2String,
    status: Fmi2Status,
    category: Fmi2String,
    format: Fmi2String,
    message: *const c_char,
) {
    let text = |p: *const c_char| {
        if p.is_null() {
            String::from("<NULL>")
        } else {
            // SAFETY: the FMU passes NUL-terminated strings.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    if environment.is_null() {
        return;
    }
    // SAFETY: the environment is the LogCapture given to `callbacks`.
    let capture = unsafe { &*(environment as *const LogCapture) };
    let line = LogLine {
        instance_name: text(instance_name),
        status,
        category: text(category),
        format: text(format),
        message: text(message),
    };
    if let Ok(mut lines) = capture.lines.lock() {
        lines.push(line);
    }
}

/// Callback functions whose logger records into `capture` (which must outlive the instance).
pub fn callbacks(capture: &LogCapture) -> Fmi2CallbackFunctions {
    type FixedLogger = unsafe extern "C" fn(
        Fmi2ComponentEnvironment,
        Fmi2String,
        Fmi2Status,
        Fmi2String,
        Fmi2String,
        *const c_char,
    );
    // SAFETY: see `record` on why the fixed-arity function can serve as the variadic logger.
    let logger = unsafe {
        std::mem::transmute::<
            FixedLogger,
            unsafe extern "C" fn(
                Fmi2ComponentEnvironment,
                Fmi2String,
                Fmi2Status,
                Fmi2String,
                Fmi2String,
                ...
            ),
        >(record)
    };
    Fmi2CallbackFunctions {
        logger: Some(logger),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: capture as *const LogCapture as Fmi2ComponentEnvironment,
    }
}

/// An instance driven through a function table; frees itself on drop.
pub struct Slave {
    pub api: Fmi2Api,
    pub component: Fmi2Component,
    /// Boxed so that its address (the component environment) stays fixed.
    pub log: Box<LogCapture>,
    callbacks: Box<Fmi2CallbackFunctions>,
}

// SAFETY: an FMI instance may be used from any thread as long as calls are not concurrent; the
// Slave is not Sync, so they cannot be.
unsafe impl Send for Slave {}

impl Slave {
    /// fmi2Instantiate as co-simulation with the given GUID; `Err` with the log if it fails.
    pub fn instantiate(api: Fmi2Api, name: &str, guid: &str) -> Result<Self, Vec<LogLine>> {
        let log = Box::new(LogCapture::default());
        let callbacks = Box::new(callbacks(&log));
        let name = CString::new(name).expect("name without NUL");
        let guid = CString::new(guid).expect("guid without NUL");
        // SAFETY: valid strings and callbacks that outlive the instance (owned by the Slave).
        let component = unsafe {
            (api.instantiate)(
                name.as_ptr(),
                FMI2_CO_SIMULATION,
                guid.as_ptr(),
                c"file:///tmp/resources".as_ptr(),
                &*callbacks,
                FMI2_FALSE,
                FMI2_FALSE,
            )
        };
        if component.is_null() {
            return Err(log.lines());
        }
        Ok(Self {
            api,
            component,
            log,
            callbacks,
        })
    }

    /// The callbacks this instance was created with (for further fmi2Instantiate calls).
    pub fn callbacks(&self) -> &Fmi2CallbackFunctions {
        &self.callbacks
    }

    /// setupExperiment(start, no stop time) + enter + exit initialisation.
    pub fn initialize(&mut self, start_time: f64) -> Fmi2Status {
        unsafe {
            let s = (self.api.setup_experiment)(
                self.component,
                FMI2_FALSE,
                0.0,
                start_time,
                FMI2_FALSE,
                0.0,
            );
            if s != Fmi2Status::Ok {
                return s;
            }
            let s = (self.api.enter_initialization_mode)(self.component);
            if s != Fmi2Status::Ok {
                return s;
            }
            (self.api.exit_initialization_mode)(self.component)
        }
    }

    pub fn set_real(&mut self, vr: u32, value: f64) -> Fmi2Status {
        unsafe { (self.api.set_real)(self.component, &vr, 1, &value) }
    }

    pub fn set_reals(&mut self, vrs: &[u32], values: &[f64]) -> Fmi2Status {
        assert_eq!(vrs.len(), values.len());
        unsafe { (self.api.set_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) }
    }

    pub fn set_integer(&mut self, vr: u32, value: i32) -> Fmi2Status {
        unsafe { (self.api.set_integer)(self.component, &vr, 1, &value) }
    }

    pub fn set_boolean(&mut self, vr: u32, value: bool) -> Fmi2Status {
        let value = if value { FMI2_TRUE } else { FMI2_FALSE };
        unsafe { (self.api.set_boolean)(self.component, &vr, 1, &value) }
    }

    pub fn get_real(&mut self, vr: u32) -> (Fmi2Status, f64) {
        let mut value = f64::NAN;
        let status = unsafe { (self.api.get_real)(self.component, &vr, 1, &mut value) };
        (status, value)
    }

    /// Several reals at once; panics unless the call returns fmi2OK.
    pub fn reals(&mut self, vrs: &[u32]) -> Vec<f64> {
        let mut values = vec![f64::NAN; vrs.len()];
        let status = unsafe {
            (self.api.get_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        assert_eq!(status, Fmi2Status::Ok, "fmi2GetReal: {:?}", self.log.last());
        values
    }

    /// Several reals into `values` (no allocation, for benchmarks); the status as returned.
    pub fn get_reals_into(&mut self, vrs: &[u32], values: &mut [f64]) -> Fmi2Status {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: both slices hold vrs.len() elements.
        unsafe { (self.api.get_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr()) }
    }

    pub fn get_integer(&mut self, vr: u32) -> (Fmi2Status, i32) {
        let mut value = i32::MIN;
        let status = unsafe { (self.api.get_integer)(self.component, &vr, 1, &mut value) };
        (status, value)
    }

    pub fn do_step(&mut self, t: f64, h: f64) -> Fmi2Status {
        unsafe { (self.api.do_step)(self.component, t, h, FMI2_TRUE) }
    }

    pub fn terminate(&mut self) -> Fmi2Status {
        unsafe { (self.api.terminate)(self.component) }
    }

    pub fn reset(&mut self) -> Fmi2Status {
        unsafe { (self.api.reset)(self.component) }
    }

    /// fmi2GetFMUstate into a new state.
    pub fn get_state(&mut self) -> (Fmi2Status, FmuState) {
        let mut state: Fmi2FmuState = std::ptr::null_mut();
        let status = unsafe { (self.api.get_fmu_state)(self.component, &mut state) };
        (status, FmuState { raw: state })
    }

    pub fn set_state(&mut self, state: &FmuState) -> Fmi2Status {
        unsafe { (self.api.set_fmu_state)(self.component, state.raw) }
    }

    /// fmi2FreeFMUstate; the state is null afterwards.
    pub fn free_state(&mut self, state: &mut FmuState) -> Fmi2Status {
        unsafe { (self.api.free_fmu_state)(self.component, &mut state.raw) }
    }

    /// SerializedFMUstateSize + SerializeFMUstate.
    pub fn serialize(&mut self, state: &FmuState) -> Result<Vec<u8>, Fmi2Status> {
        let mut size = 0usize;
        let status =
            unsafe { (self.api.serialized_fmu_state_size)(self.component, state.raw, &mut size) };
        if status != Fmi2Status::Ok {
            return Err(status);
        }
        let mut bytes = vec![0u8; size];
        let status = unsafe {
            (self.api.serialize_fmu_state)(
                self.component,
                state.raw,
                bytes.as_mut_ptr() as *mut Fmi2Byte,
                size,
            )
        };
        if status != Fmi2Status::Ok {
            return Err(status);
        }
        Ok(bytes)
    }

    pub fn deserialize(&mut self, bytes: &[u8]) -> (Fmi2Status, FmuState) {
        let mut state: Fmi2FmuState = std::ptr::null_mut();
        let status = unsafe {
            (self.api.deserialize_fmu_state)(
                self.component,
                bytes.as_ptr() as *const Fmi2Byte,
                bytes.len(),
                &mut state,
            )
        };
        (status, FmuState { raw: state })
    }
}

/// An FMU state obtained from a [`Slave`] (freed with [`Slave::free_state`]).
#[derive(Debug)]
pub struct FmuState {
    raw: Fmi2FmuState,
}

impl FmuState {
    pub fn is_null(&self) -> bool {
        self.raw.is_null()
    }

    /// The pointer as the master holds it (for tests of stale states).
    pub fn raw(&self) -> Fmi2FmuState {
        self.raw
    }
}

impl Drop for Slave {
    fn drop(&mut self) {
        // SAFETY: the component was created by this table's fmi2Instantiate and is freed once.
        unsafe { (self.api.free_instance)(self.component) };
    }
}
