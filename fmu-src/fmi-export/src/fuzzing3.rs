//! Sequences of FMI 3.0 calls with arbitrary arguments, decoded from bytes (feature `testing`):
//! the FMI 3 counterpart of [`crate::fuzzing`], run on a model through the same generic
//! functions the exported `fmi3*` symbols forward to ([`crate::api3`]).
//!
//! What must hold, whatever the sequence: no crash, no hang, every call answers a status, and
//! `fmi3Reset` brings the instance back to a state that initialises and steps. The arguments
//! include wrong value-reference types, wrong `nValues`, null output pointers, foreign FMU
//! states, mutated serialized states, and the functions of capabilities the FMU does not declare.

use std::ffi::{c_char, CStr};
use std::sync::Mutex;

use crate::api::free_instance_as;
use crate::api3::{self, Fmi3Type};
use crate::ffi3::*;
use crate::CoSimulationModel;

/// The longest communication step the driver takes [s] (see [`crate::fuzzing::MAX_STEP_SIZE`]).
pub const MAX_STEP_SIZE: f64 = 1.0;

/// At most this many calls per input.
pub const MAX_CALLS: usize = 200;

/// The largest value buffer a getter or setter is given; `nValues` never exceeds it.
const BUFFER: usize = 256;

/// Messages an FMI 3 instance logged: (status, category, message).
#[derive(Debug, Default)]
pub struct Fmi3Log {
    pub lines: Mutex<Vec<(Fmi3Status, String, String)>>,
}

impl Fmi3Log {
    /// The last message, if any.
    pub fn last(&self) -> Option<(Fmi3Status, String, String)> {
        self.lines.lock().ok().and_then(|l| l.last().cloned())
    }

    /// Every message so far.
    pub fn all(&self) -> Vec<(Fmi3Status, String, String)> {
        self.lines.lock().map(|l| l.clone()).unwrap_or_default()
    }
}

/// `fmi3LogMessageCallback` recording into the [`Fmi3Log`] the environment points to.
///
/// # Safety
/// `environment` is null or an `Fmi3Log`; the strings are null or NUL-terminated.
pub unsafe extern "C" fn record(
    environment: Fmi3InstanceEnvironment,
    status: Fmi3Status,
    category: Fmi3String,
    message: Fmi3String,
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
    // SAFETY: the environment is the Fmi3Log given at instantiation.
    let log = unsafe { &*(environment as *const Fmi3Log) };
    if let Ok(mut lines) = log.lines.lock() {
        lines.push((status, text(category), text(message)));
    }
}

/// `fmi3InstantiateCoSimulation` of model `M` logging into `log`; null on refusal.
///
/// # Safety
/// `log` outlives the instance.
pub unsafe fn instantiate<M: CoSimulationModel>(
    log: &Fmi3Log,
    name: &CStr,
    token: &CStr,
    event_mode_used: bool,
) -> Fmi3Instance {
    unsafe {
        api3::instantiate_co_simulation::<M>(
            name.as_ptr(),
            token.as_ptr(),
            std::ptr::null(),
            FMI3_FALSE,
            u8::from(event_mode_used),
            log as *const Fmi3Log as Fmi3InstanceEnvironment,
            Some(record),
        )
    }
}

/// Reads arguments from the bytes; past the end every read is zero.
struct Bytes<'a> {
    data: &'a [u8],
    position: usize,
}

impl Bytes<'_> {
    fn is_empty(&self) -> bool {
        self.position >= self.data.len()
    }

    fn byte(&mut self) -> u8 {
        let value = self.data.get(self.position).copied().unwrap_or(0);
        self.position += 1;
        value
    }

    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.byte(), self.byte(), self.byte(), self.byte()])
    }

    fn f64(&mut self) -> f64 {
        const SPECIAL: [f64; 10] = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            5e-324,
            1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.01,
        ];
        match self.byte() % 3 {
            0 => SPECIAL[usize::from(self.byte()) % SPECIAL.len()],
            _ => f64::from_bits(u64::from(self.u32()) << 32 | u64::from(self.u32())),
        }
    }

    /// A value reference of the model (FMI 2 table or FMI 3-only), sometimes any number.
    fn reference<M: CoSimulationModel>(&mut self) -> u32 {
        let known: Vec<u32> = M::VARIABLES
            .iter()
            .map(|v| v.value_reference)
            .chain(M::FMI3_VARIABLES.iter().map(|v| v.value_reference))
            .collect();
        if self.byte() < 24 || known.is_empty() {
            self.u32()
        } else {
            known[usize::from(self.byte()) % known.len()]
        }
    }

    /// Up to four value references and a `nValues` that is mostly right for `fmi3_type`.
    fn references<M: CoSimulationModel>(&mut self) -> (Vec<u32>, usize) {
        let count = usize::from(self.byte() % 5);
        let references: Vec<u32> = (0..count).map(|_| self.reference::<M>()).collect();
        let elements: usize = references
            .iter()
            .map(|&r| {
                M::FMI3_VARIABLES
                    .iter()
                    .find(|v| v.value_reference == r)
                    .map_or(1, |v| v.elements())
            })
            .sum();
        let n_values = match self.byte() % 8 {
            0 => usize::from(self.byte()),
            _ => elements,
        };
        (references, n_values.min(BUFFER))
    }
}

/// An instance under test with its log; freed on drop.
struct Driven<'l, M: CoSimulationModel> {
    instance: Fmi3Instance,
    log: &'l Fmi3Log,
    states: Vec<Fmi3FmuState>,
    time: f64,
    _model: std::marker::PhantomData<M>,
}

impl<M: CoSimulationModel> Drop for Driven<'_, M> {
    fn drop(&mut self) {
        for mut state in std::mem::take(&mut self.states) {
            // SAFETY: states of this instance; a stale one is refused, not read.
            unsafe { api3::free_fmu_state::<M>(self.instance, &mut state) };
        }
        // SAFETY: the instance of this driver, not used afterwards.
        unsafe { free_instance_as::<M>("fmi3FreeInstance", self.instance) };
    }
}

/// Runs the FMI 3 call sequence `data` encodes on a fresh instance of `M`.
pub fn drive_calls<M: CoSimulationModel>(data: &[u8]) {
    let log = Fmi3Log::default();
    let token = std::ffi::CString::new(M::GUID).expect("a GUID has no NUL byte");
    // SAFETY: `log` outlives the instance (dropped with `driven` below).
    let instance = unsafe { instantiate::<M>(&log, c"fuzz3", &token, false) };
    assert!(
        !instance.is_null(),
        "fmi3InstantiateCoSimulation refused: {:?}",
        log.last()
    );
    let mut driven = Driven::<M> {
        instance,
        log: &log,
        states: Vec::new(),
        time: 0.0,
        _model: std::marker::PhantomData,
    };
    let mut bytes = Bytes { data, position: 0 };
    for _ in 0..MAX_CALLS {
        if bytes.is_empty() {
            break;
        }
        // SAFETY: every pointer passed is valid for the count passed with it, or null.
        unsafe { one_call(&mut driven, &mut bytes) };
    }
    // SAFETY: the driver's instance.
    unsafe {
        let i = driven.instance;
        assert_eq!(
            api3::reset::<M>(i),
            Fmi3Status::Ok,
            "{:?}",
            driven.log.last()
        );
        assert_eq!(
            api3::enter_initialization_mode::<M>(i, 0.0, FMI3_FALSE, 0.0),
            Fmi3Status::Ok,
            "{:?}",
            driven.log.last()
        );
        assert_eq!(
            api3::exit_initialization_mode::<M>(i),
            Fmi3Status::Ok,
            "{:?}",
            driven.log.last()
        );
        let (mut event, mut terminate, mut early, mut last) = (9, 9, 9, f64::NAN);
        let status = api3::do_step::<M>(
            i,
            0.0,
            0.01,
            &mut event,
            &mut terminate,
            &mut early,
            &mut last,
        );
        assert!(
            matches!(status, Fmi3Status::Ok | Fmi3Status::Warning),
            "a step after fmi3Reset: {status:?} {:?}",
            driven.log.last()
        );
        assert_eq!((event, terminate, early, last), (0, 0, 0, 0.01));
    }
}

/// One call chosen by the next byte.
///
/// # Safety
/// `driven` holds a live instance of `M`.
unsafe fn one_call<M: CoSimulationModel>(driven: &mut Driven<'_, M>, bytes: &mut Bytes<'_>) {
    let i = driven.instance;
    let mut floats = [0.0f64; BUFFER];
    let mut ints = [0i32; BUFFER];
    let mut longs = [0i64; BUFFER];
    let mut flags = [0u8; BUFFER];
    let null_values = bytes.byte() % 16 == 0;
    unsafe {
        let _status = match bytes.byte() % 20 {
            0 => {
                let (r, n) = bytes.references::<M>();
                let out = if null_values {
                    std::ptr::null_mut()
                } else {
                    floats.as_mut_ptr()
                };
                api3::get_float64::<M>(i, r.as_ptr(), r.len(), out, n)
            }
            1 => {
                let (r, n) = bytes.references::<M>();
                for value in floats.iter_mut().take(n) {
                    *value = bytes.f64();
                }
                api3::set_float64::<M>(i, r.as_ptr(), r.len(), floats.as_ptr(), n)
            }
            2 => {
                let (r, n) = bytes.references::<M>();
                match bytes.byte() % 4 {
                    0 => api3::get_int32::<M>(i, r.as_ptr(), r.len(), ints.as_mut_ptr(), n),
                    1 => api3::get_int64::<M>(i, r.as_ptr(), r.len(), longs.as_mut_ptr(), n),
                    2 => api3::get_boolean::<M>(i, r.as_ptr(), r.len(), flags.as_mut_ptr(), n),
                    _ => api3::no_variables_of_type::<M>(
                        i,
                        "fmi3GetFloat32",
                        Fmi3Type::Float32,
                        false,
                        r.as_ptr(),
                        r.len(),
                        null_values,
                    ),
                }
            }
            3 => {
                let (r, n) = bytes.references::<M>();
                for k in 0..n {
                    ints[k] = bytes.u32() as i32;
                    longs[k] = i64::from(bytes.u32()) << (bytes.byte() % 40);
                    flags[k] = bytes.byte();
                }
                match bytes.byte() % 3 {
                    0 => api3::set_int32::<M>(i, r.as_ptr(), r.len(), ints.as_ptr(), n),
                    1 => api3::set_int64::<M>(i, r.as_ptr(), r.len(), longs.as_ptr(), n),
                    _ => api3::set_boolean::<M>(i, r.as_ptr(), r.len(), flags.as_ptr(), n),
                }
            }
            4 => {
                let start = bytes.f64();
                let stop = bytes.f64();
                driven.time = start;
                api3::enter_initialization_mode::<M>(i, start, bytes.byte() % 2, stop)
            }
            5 => api3::exit_initialization_mode::<M>(i),
            6 | 7 => {
                let step = bytes.f64().abs().min(MAX_STEP_SIZE);
                let at = if bytes.byte() % 8 == 0 {
                    bytes.f64()
                } else {
                    driven.time
                };
                let (mut event, mut terminate, mut early, mut last) = (0, 0, 0, 0.0);
                let status = if bytes.byte() % 16 == 0 {
                    api3::do_step::<M>(
                        i,
                        at,
                        step,
                        std::ptr::null_mut(),
                        &mut terminate,
                        &mut early,
                        &mut last,
                    )
                } else {
                    api3::do_step::<M>(
                        i,
                        at,
                        step,
                        &mut event,
                        &mut terminate,
                        &mut early,
                        &mut last,
                    )
                };
                if matches!(status, Fmi3Status::Ok | Fmi3Status::Warning) {
                    driven.time = at + step;
                }
                status
            }
            8 => {
                let mut state = if bytes.byte() % 4 == 0 {
                    driven
                        .states
                        .first()
                        .copied()
                        .unwrap_or(std::ptr::null_mut())
                } else {
                    std::ptr::null_mut()
                };
                let status = api3::get_fmu_state::<M>(i, &mut state);
                if status == Fmi3Status::Ok && !driven.states.contains(&state) {
                    if driven.states.len() < 4 {
                        driven.states.push(state);
                    } else {
                        api3::free_fmu_state::<M>(i, &mut state);
                    }
                }
                status
            }
            9 => {
                let state = match driven.states.get(usize::from(bytes.byte()) % 5) {
                    Some(&state) => state,
                    // A pointer that is no FMU state of this library.
                    None => floats.as_mut_ptr() as Fmi3FmuState,
                };
                api3::set_fmu_state::<M>(i, state)
            }
            10 => round_trip_mutated_state::<M>(driven, bytes),
            11 => {
                if driven.states.is_empty() {
                    Fmi3Status::Ok
                } else {
                    let mut state = driven.states.remove(0);
                    api3::free_fmu_state::<M>(i, &mut state)
                }
            }
            12 => api3::reset::<M>(i),
            13 => api3::terminate::<M>(i),
            14 => {
                let categories = [
                    c"logEvents".as_ptr(),
                    c"logStatusError".as_ptr(),
                    c"nonsense".as_ptr(),
                ];
                let count = usize::from(bytes.byte() % 4);
                let pointer = if null_values {
                    std::ptr::null()
                } else {
                    categories.as_ptr()
                };
                crate::api::set_debug_logging_as::<M>(
                    "fmi3SetDebugLogging",
                    i,
                    bytes.byte() % 2 == 0,
                    count.min(categories.len()),
                    pointer,
                )
            }
            15 => {
                let mut count = 0usize;
                let out = if null_values {
                    std::ptr::null_mut()
                } else {
                    &mut count
                };
                api3::get_number_of_variable_dependencies::<M>(i, bytes.reference::<M>(), out)
            }
            16 => {
                let n = usize::from(bytes.byte() % 8);
                let (mut a, mut b, mut c, mut d) = ([0usize; 8], [0u32; 8], [0usize; 8], [0i32; 8]);
                let a_ptr = if null_values {
                    std::ptr::null_mut()
                } else {
                    a.as_mut_ptr()
                };
                api3::get_variable_dependencies::<M>(
                    i,
                    bytes.reference::<M>(),
                    a_ptr,
                    b.as_mut_ptr(),
                    c.as_mut_ptr(),
                    d.as_mut_ptr(),
                    n,
                )
            }
            17 => {
                let functions = [
                    ("fmi3EnterEventMode", "hasEventMode"),
                    ("fmi3EnterConfigurationMode", "structural parameters"),
                    (
                        "fmi3GetDirectionalDerivative",
                        "providesDirectionalDerivatives",
                    ),
                    ("fmi3SetTime", "Model Exchange"),
                ];
                let (function, capability) = functions[usize::from(bytes.byte()) % functions.len()];
                api3::not_declared::<M>(i, function, capability)
            }
            18 => {
                // A stale or foreign handle: answered without touching anything.
                let foreign = floats.as_mut_ptr() as Fmi3Instance;
                api3::terminate::<M>(foreign)
            }
            _ => {
                let (r, _) = bytes.references::<M>();
                api3::no_variables_of_type::<M>(
                    i,
                    "fmi3SetString",
                    Fmi3Type::String,
                    true,
                    r.as_ptr(),
                    r.len(),
                    null_values,
                )
            }
        };
    }
}

/// Serializes a stored state, changes one byte (or none), deserializes and applies it.
///
/// # Safety
/// `driven` holds a live instance of `M`.
unsafe fn round_trip_mutated_state<M: CoSimulationModel>(
    driven: &mut Driven<'_, M>,
    bytes: &mut Bytes<'_>,
) -> Fmi3Status {
    let Some(&state) = driven.states.first() else {
        return Fmi3Status::Ok;
    };
    let i = driven.instance;
    unsafe {
        let mut size = 0usize;
        let status = api3::serialized_fmu_state_size::<M>(i, state, &mut size);
        if status != Fmi3Status::Ok {
            return status;
        }
        let mut serialized = vec![0u8; size];
        let status = api3::serialize_fmu_state::<M>(i, state, serialized.as_mut_ptr(), size);
        if status != Fmi3Status::Ok {
            return status;
        }
        if bytes.byte() % 2 == 0 && !serialized.is_empty() {
            let position = bytes.u32() as usize % serialized.len();
            serialized[position] ^= bytes.byte() | 1;
        }
        let mut restored: Fmi3FmuState = std::ptr::null_mut();
        let status = api3::deserialize_fmu_state::<M>(
            i,
            serialized.as_ptr(),
            serialized.len(),
            &mut restored,
        );
        if status != Fmi3Status::Ok {
            return status;
        }
        let status = api3::set_fmu_state::<M>(i, restored);
        api3::free_fmu_state::<M>(i, &mut restored);
        status
    }
}
