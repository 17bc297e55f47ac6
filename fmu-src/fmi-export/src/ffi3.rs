//! The C types of the FMI 3.0 API (fmi3PlatformTypes.h, fmi3FunctionTypes.h) that the
//! Co-Simulation front end uses.

use std::ffi::{c_char, c_void};

use crate::ffi::Fmi2Status;

pub type Fmi3Instance = *mut c_void;
pub type Fmi3InstanceEnvironment = *mut c_void;
pub type Fmi3FmuState = *mut c_void;
pub type Fmi3ValueReference = u32;
pub type Fmi3Float32 = f32;
pub type Fmi3Float64 = f64;
pub type Fmi3Int8 = i8;
pub type Fmi3UInt8 = u8;
pub type Fmi3Int16 = i16;
pub type Fmi3UInt16 = u16;
pub type Fmi3Int32 = i32;
pub type Fmi3UInt32 = u32;
pub type Fmi3Int64 = i64;
pub type Fmi3UInt64 = u64;
/// `fmi3Boolean` is C `bool`, one byte. Read as a byte: a master's value other than 0 or 1
/// (true for C) must not be undefined behaviour in Rust; written as 0 or 1.
pub type Fmi3Boolean = u8;
pub const FMI3_TRUE: Fmi3Boolean = 1;
pub const FMI3_FALSE: Fmi3Boolean = 0;
pub type Fmi3Char = c_char;
pub type Fmi3String = *const c_char;
pub type Fmi3Byte = u8;
pub type Fmi3Binary = *const Fmi3Byte;
pub type Fmi3Clock = u8;

/// `fmi3Status`: fmi3OK .. fmi3Fatal have the values of fmi2OK .. fmi2Fatal (FMI 3.0, 2.2.3),
/// so the plumbing's status serves both; FMI 3 has no Pending, which the plumbing never answers.
pub type Fmi3Status = Fmi2Status;

/// `fmi3DependencyKind` (FMI 3.0, 2.2.10): how an unknown depends on a known.
pub type Fmi3DependencyKind = i32;
pub const FMI3_DEPENDENCY_DEPENDENT: Fmi3DependencyKind = 5;

/// `fmi3IntervalQualifier`.
pub type Fmi3IntervalQualifier = i32;

/// `fmi3LogMessageCallback`: not variadic in FMI 3.0, the message is one string.
pub type Fmi3LogMessageCallback =
    Option<unsafe extern "C" fn(Fmi3InstanceEnvironment, Fmi3Status, Fmi3String, Fmi3String)>;

/// `fmi3IntermediateUpdateCallback` (early return and intermediate variables; not used).
pub type Fmi3IntermediateUpdateCallback = Option<
    unsafe extern "C" fn(
        Fmi3InstanceEnvironment,
        Fmi3Float64,
        Fmi3Boolean,
        Fmi3Boolean,
        Fmi3Boolean,
        Fmi3Boolean,
        *mut Fmi3Boolean,
        *mut Fmi3Float64,
    ),
>;

/// `fmi3ClockUpdateCallback` (Scheduled Execution; not used).
pub type Fmi3ClockUpdateCallback = Option<unsafe extern "C" fn(Fmi3InstanceEnvironment)>;

/// `fmi3LockPreemptionCallback` / `fmi3UnlockPreemptionCallback` (Scheduled Execution).
pub type Fmi3PreemptionCallback = Option<unsafe extern "C" fn()>;
