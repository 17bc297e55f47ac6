//! Sequences of FMI calls with arbitrary arguments, decoded from fuzzer bytes (feature
//! `testing`). One driver for every FMU: the cargo-fuzz targets in `fmi-export/fuzz`
//! hand it the bytes libFuzzer generates, and the crate's tests run it on pseudo-random bytes.
//!
//! Each call is chosen by one byte; its arguments come from the following bytes, with numbers
//! drawn often from values that break code (0, -0, subnormal, NaN, infinities, huge, the bounds
//! of the variables). What must hold, whatever the sequence: no crash, no hang, and an
//! instance that fmi2Reset brings back to a working state. Communication steps are at most [`MAX_STEP_SIZE`] long, because a
//! model's bound on the work of one call ([`crate::CoSimulationModel::internal_step_size`])
//! is what limits longer steps, and a model without one would make every long step a
//! (known) timeout.

use crate::ffi::*;
use crate::testing::{Fmi2Api, FmuState, Slave};
use crate::VariableInfo;

/// The longest communication step the driver takes [s].
pub const MAX_STEP_SIZE: f64 = 1.0;

/// At most this many calls per input, so one input runs in milliseconds.
pub const MAX_CALLS: usize = 200;

const SPECIAL_VALUES: [f64; 14] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    f64::MIN_POSITIVE,
    5e-324,
    1e-300,
    1e300,
    f64::MAX,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    0.01,
    1e-3,
];

const CATEGORIES: [&std::ffi::CStr; 5] = [
    c"logEvents",
    c"logAll",
    c"logStatusWarning",
    c"logSingularLinearSystems",
    c"",
];

/// Reads arguments from the fuzzer's bytes; past the end every read is zero.
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

    fn f64(&mut self, variable: Option<&VariableInfo>) -> f64 {
        match self.byte() % 4 {
            0 => SPECIAL_VALUES[usize::from(self.byte()) % SPECIAL_VALUES.len()],
            1 => variable.map_or(0.5, |v| if self.byte() % 2 == 0 { v.min } else { v.max }),
            _ => f64::from_bits(u64::from(self.u32()) << 32 | u64::from(self.u32())),
        }
    }

    /// A value reference: mostly one of the table's (of any type), sometimes any number.
    fn variable<'v>(&mut self, variables: &'v [VariableInfo]) -> (u32, Option<&'v VariableInfo>) {
        let choice = self.byte();
        if choice < 16 || variables.is_empty() {
            return (self.u32(), None);
        }
        let variable = &variables[usize::from(self.byte()) % variables.len()];
        (variable.value_reference, Some(variable))
    }
}

/// Runs the call sequence `data` encodes on a fresh instance of the FMU behind `api`.
pub fn drive_calls(api: Fmi2Api, guid: &str, variables: &[VariableInfo], data: &[u8]) {
    let Ok(mut slave) = Slave::instantiate(api, "fuzz", guid) else {
        panic!("fmi2Instantiate with the FMU's own GUID failed");
    };
    let mut bytes = Bytes { data, position: 0 };
    let mut states: Vec<FmuState> = Vec::new();
    let mut time = 0.0;
    for _ in 0..MAX_CALLS {
        if bytes.is_empty() {
            break;
        }
        slave.log.clear();
        one_call(&mut slave, &mut bytes, variables, &mut states, &mut time);
    }
    for mut state in states {
        slave.free_state(&mut state);
    }
    // Whatever happened, fmi2Reset brings the instance back to its start values, from which it
    // initialises and steps.
    assert_eq!(
        slave.reset(),
        Fmi2Status::Ok,
        "fmi2Reset: {:?}",
        slave.log.last()
    );
    assert_eq!(
        slave.initialize(0.0),
        Fmi2Status::Ok,
        "{:?}",
        slave.log.last()
    );
    let status = slave.do_step(0.0, 0.01);
    assert!(
        matches!(status, Fmi2Status::Ok | Fmi2Status::Warning),
        "a step after fmi2Reset: {status:?} {:?}",
        slave.log.last()
    );
}

fn one_call(
    slave: &mut Slave,
    bytes: &mut Bytes<'_>,
    variables: &[VariableInfo],
    states: &mut Vec<FmuState>,
    time: &mut f64,
) {
    let status = match bytes.byte() % 16 {
        0 => {
            let (vr, variable) = bytes.variable(variables);
            let value = bytes.f64(variable);
            slave.set_real(vr, value)
        }
        1 => {
            let (vr, variable) = bytes.variable(variables);
            let value = match bytes.byte() % 3 {
                0 => variable.map_or(0, |v| v.min.clamp(-1e9, 1e9) as i32),
                1 => variable.map_or(0, |v| v.max.clamp(-1e9, 1e9) as i32),
                _ => bytes.u32() as i32,
            };
            slave.set_integer(vr, value)
        }
        2 => {
            let (vr, _) = bytes.variable(variables);
            let value = bytes.byte() % 2 == 0;
            slave.set_boolean(vr, value)
        }
        3 => {
            let start = bytes.f64(None);
            let stop = bytes.f64(None);
            let stop_defined = if bytes.byte() % 2 == 0 {
                FMI2_TRUE
            } else {
                FMI2_FALSE
            };
            *time = start;
            unsafe {
                (slave.api.setup_experiment)(
                    slave.component,
                    FMI2_FALSE,
                    0.0,
                    start,
                    stop_defined,
                    stop,
                )
            }
        }
        4 => unsafe { (slave.api.enter_initialization_mode)(slave.component) },
        5 => unsafe { (slave.api.exit_initialization_mode)(slave.component) },
        6 | 7 => {
            let step = bytes.f64(None).abs().min(MAX_STEP_SIZE);
            let at = if bytes.byte() % 8 == 0 {
                bytes.f64(None)
            } else {
                *time
            };
            let status = slave.do_step(at, step);
            if matches!(status, Fmi2Status::Ok | Fmi2Status::Warning) {
                *time = at + step;
            }
            status
        }
        8 => {
            let (vr, _) = bytes.variable(variables);
            slave.get_real(vr).0
        }
        9 => {
            let (status, state) = slave.get_state();
            if status == Fmi2Status::Ok && states.len() < 4 {
                states.push(state);
            } else if !state.is_null() {
                let mut state = state;
                slave.free_state(&mut state);
            }
            status
        }
        10 => match states.get(usize::from(bytes.byte()) % states.len().max(1)) {
            Some(state) => slave.set_state(state),
            None => Fmi2Status::Ok,
        },
        11 => round_trip_mutated_state(slave, bytes, states),
        12 => slave.reset(),
        13 => slave.terminate(),
        14 => {
            let chosen = [CATEGORIES[usize::from(bytes.byte()) % CATEGORIES.len()].as_ptr()];
            let count = usize::from(bytes.byte() % 2);
            let on = if bytes.byte() % 2 == 0 {
                FMI2_TRUE
            } else {
                FMI2_FALSE
            };
            unsafe { (slave.api.set_debug_logging)(slave.component, on, count, chosen.as_ptr()) }
        }
        _ => {
            let (vr, _) = bytes.variable(variables);
            slave.get_integer(vr).0
        }
    };
    let _ = status;
}

/// Serializes a stored state, changes one byte (or none) and deserializes it into the instance.
fn round_trip_mutated_state(
    slave: &mut Slave,
    bytes: &mut Bytes<'_>,
    states: &[FmuState],
) -> Fmi2Status {
    let Some(state) = states.first() else {
        return Fmi2Status::Ok;
    };
    let Ok(mut serialized) = slave.serialize(state) else {
        return Fmi2Status::Error;
    };
    if bytes.byte() % 2 == 0 && !serialized.is_empty() {
        let position = bytes.u32() as usize % serialized.len();
        serialized[position] ^= bytes.byte() | 1;
    }
    let (status, mut restored) = slave.deserialize(&serialized);
    if status == Fmi2Status::Ok {
        let status = slave.set_state(&restored);
        slave.free_state(&mut restored);
        return status;
    }
    status
}
