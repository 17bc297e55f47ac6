//! Serialized FMU states carry a format version, their length and a checksum; a changed,
//! truncated or resealed-but-inconsistent buffer is refused with fmi2Error and a message, and
//! never hangs or crashes the instance. Deterministic and bounded: a few
//! thousand cases in well under a second.

use crate::toy;

use fmi_export::ffi::Fmi2Status;
use fmi_export::testing::Slave;
use fmi_export::{fnv1a_64, STATE_FORMAT_VERSION};
use toy::vr;

/// The serialized state of a toy that has run a few steps with a non-zero input.
fn serialized_state() -> (Slave, Vec<u8>) {
    let mut s = toy::slave();
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::U, 2.0), Fmi2Status::Ok);
    for k in 0..3 {
        assert_eq!(s.do_step(f64::from(k) * 0.01, 0.01), Fmi2Status::Ok);
    }
    let (status, mut state) = s.get_state();
    assert_eq!(status, Fmi2Status::Ok);
    let bytes = s.serialize(&state).expect("serialize");
    s.free_state(&mut state);
    (s, bytes)
}

/// Deserializes `bytes` into `s`; the status and the last log line. The instance is reset
/// afterwards, so that a refusal (Error state) does not carry over to the next case.
fn deserialize(s: &mut Slave, bytes: &[u8]) -> (Fmi2Status, String) {
    s.log.clear();
    let (status, mut state) = s.deserialize(bytes);
    if status == Fmi2Status::Ok {
        s.free_state(&mut state);
    }
    let message = s.log.last().map(|line| line.message).unwrap_or_default();
    assert_eq!(s.reset(), Fmi2Status::Ok);
    (status, message)
}

/// The frame around a changed payload, with a correct length and checksum.
fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
    let length = bytes.len() as u64;
    bytes[12..20].copy_from_slice(&length.to_le_bytes());
    let end = bytes.len() - 8;
    let checksum = fnv1a_64(&bytes[..end]);
    bytes[end..].copy_from_slice(&checksum.to_le_bytes());
    bytes
}

/// xorshift64*: a fixed sequence of pseudo-random numbers, so that every run tests the same cases.
struct Cases(u64);

impl Cases {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, bound: usize) -> usize {
        (self.next() % bound as u64) as usize
    }
}

#[test]
fn a_valid_state_round_trips_and_carries_version_length_and_checksum() {
    let (mut s, bytes) = serialized_state();
    assert_eq!(&bytes[..8], b"RSFMI2ST");
    assert_eq!(bytes[8..12], STATE_FORMAT_VERSION.to_le_bytes());
    assert_eq!(bytes[12..20], (bytes.len() as u64).to_le_bytes());
    let end = bytes.len() - 8;
    assert_eq!(bytes[end..], fnv1a_64(&bytes[..end]).to_le_bytes());
    assert_eq!(deserialize(&mut s, &bytes).0, Fmi2Status::Ok);
}

#[test]
fn every_changed_byte_is_refused_with_a_message() {
    let (mut s, bytes) = serialized_state();
    let mut cases = 0;
    for position in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xff, 0x5a] {
            let mut changed = bytes.clone();
            changed[position] ^= flip;
            let (status, message) = deserialize(&mut s, &changed);
            assert_eq!(status, Fmi2Status::Error, "byte {position} ^ {flip:#x}");
            assert!(
                ["header", "version", "long", "checksum"]
                    .iter()
                    .any(|word| message.contains(word)),
                "byte {position}: {message}"
            );
            cases += 1;
        }
    }
    assert!(cases > 400, "{cases} cases");
}

#[test]
fn every_truncation_and_extension_is_refused() {
    let (mut s, bytes) = serialized_state();
    for length in 0..bytes.len() {
        let (status, message) = deserialize(&mut s, &bytes[..length]);
        assert_eq!(status, Fmi2Status::Error, "{length} bytes");
        assert!(!message.is_empty(), "{length} bytes: no message");
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert_eq!(deserialize(&mut s, &longer).0, Fmi2Status::Error);
    // A state of the old format (version 1, no length and no checksum) is refused by version.
    let mut old = bytes.clone();
    old[8..12].copy_from_slice(&1u32.to_le_bytes());
    let (status, message) = deserialize(&mut s, &resealed(old));
    assert_eq!(status, Fmi2Status::Error);
    assert!(message.contains("version 1"), "{message}");
}

/// Mutations that keep a valid frame reach the parser behind it: it must refuse or accept
/// without crashing, and an accepted state must step or refuse the step, never hang.
#[test]
fn resealed_mutations_are_parsed_without_crash_or_hang() {
    let (mut s, bytes) = serialized_state();
    let mut cases = Cases(0x9e37_79b9_7f4a_7c15);
    let (mut accepted, mut refused) = (0, 0);
    for _ in 0..3000 {
        let mut changed = bytes.clone();
        for _ in 0..=cases.below(4) {
            let position = 20 + cases.below(bytes.len() - 28);
            changed[position] = cases.next() as u8;
        }
        if cases.below(4) == 0 {
            changed.truncate(20 + cases.below(bytes.len() - 20));
            changed.extend_from_slice(&[0; 8]);
        }
        let changed = resealed(changed);
        s.log.clear();
        let (status, mut state) = s.deserialize(&changed);
        if status == Fmi2Status::Ok {
            accepted += 1;
            let restored = s.set_state(&state);
            s.free_state(&mut state);
            if restored == Fmi2Status::Ok {
                // Whatever the state says (an internal step of 1e-300 s, a negative one, NaN),
                // the call returns: Ok, Warning, Discard or Error.
                let _ = s.do_step(0.03, 0.01);
            }
        } else {
            refused += 1;
            assert!(s.log.last().is_some(), "a refusal without a message");
        }
        assert_eq!(s.reset(), Fmi2Status::Ok);
    }
    eprintln!("resealed mutations: {accepted} accepted, {refused} refused");
    assert!(refused > 0);
}
