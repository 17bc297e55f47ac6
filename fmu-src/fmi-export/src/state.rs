//! A small, explicit binary format for FMU states: little-endian, f64 stored by its bit pattern
//! so that a restored state continues bit-identically.
//!
//! A serialized state is framed so that a changed, truncated or foreign
//! buffer is refused before any of it is read:
//!
//! | bytes | what |
//! | --- | --- |
//! | 8 | magic `RSFMI2ST` |
//! | 4 | format version ([`STATE_FORMAT_VERSION`]) |
//! | 8 | total length in bytes, frame included |
//! | n | payload (what [`StateWriter`] wrote) |
//! | 8 | FNV-1a 64 checksum of every byte before it |
//!
//! FNV-1a (Fowler, Noll, Vo; IETF draft-eastlake-fnv) detects every change of a single byte:
//! each step `h = (h ^ byte) * prime` is a bijection of `h` for a fixed byte, and the xor
//! differs for different bytes.

use std::fmt;

/// The magic bytes that open a serialized FMU state of this implementation.
pub const STATE_MAGIC: &[u8; 8] = b"RSFMI2ST";
/// The version of the framed format; 1 had no length and no checksum.
pub const STATE_FORMAT_VERSION: u32 = 2;
const HEADER_LENGTH: usize = 8 + 4 + 8;
const CHECKSUM_LENGTH: usize = 8;

/// FNV-1a, 64 bit (offset basis 0xcbf29ce484222325, prime 0x100000001b3).
pub fn fnv1a_64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &byte| {
        (hash ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Appends values to a byte buffer.
#[derive(Debug, Default)]
pub struct StateWriter {
    bytes: Vec<u8>,
}

impl StateWriter {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }

    /// A writer whose buffer starts with the frame's header; finish with
    /// [`StateWriter::into_framed_bytes`].
    pub fn framed() -> Self {
        let mut writer = Self::new();
        writer.bytes.extend_from_slice(STATE_MAGIC);
        writer.u32(STATE_FORMAT_VERSION);
        writer.u64(0); // The length, filled in by into_framed_bytes.
        writer
    }

    /// The framed bytes: the total length written into the header, the checksum appended.
    pub fn into_framed_bytes(mut self) -> Vec<u8> {
        let total = (self.bytes.len() + CHECKSUM_LENGTH) as u64;
        self.bytes[HEADER_LENGTH - 8..HEADER_LENGTH].copy_from_slice(&total.to_le_bytes());
        let checksum = fnv1a_64(&self.bytes);
        self.bytes.extend_from_slice(&checksum.to_le_bytes());
        self.bytes
    }

    pub fn f64(&mut self, value: f64) {
        self.bytes.extend_from_slice(&value.to_bits().to_le_bytes());
    }

    pub fn f64s(&mut self, values: &[f64]) {
        self.u64(values.len() as u64);
        for &value in values {
            self.f64(value);
        }
    }

    pub fn u64(&mut self, value: u64) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub fn u32(&mut self, value: u32) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub fn i32(&mut self, value: i32) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub fn bool(&mut self, value: bool) {
        self.bytes.push(u8::from(value));
    }

    pub fn u8(&mut self, value: u8) {
        self.bytes.push(value);
    }

    pub fn bytes(&mut self, value: &[u8]) {
        self.u64(value.len() as u64);
        self.bytes.extend_from_slice(value);
    }
}

/// Why a serialized FMU state could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StateError {
    pub message: String,
}

impl StateError {
    pub fn new(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
        }
    }
}

impl fmt::Display for StateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for StateError {}

/// Reads values in the order they were written; every read names what it reads, so a truncated
/// or foreign buffer gives a message like "the serialized state ends at byte 812 while reading 'vx'".
#[derive(Debug)]
pub struct StateReader<'a> {
    bytes: &'a [u8],
    position: usize,
}

impl<'a> StateReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, position: 0 }
    }

    /// A reader of the payload of a frame written by [`StateWriter::framed`], after checking
    /// the magic, the version, the length and the checksum; anything else is refused with a
    /// message saying what did not match.
    pub fn framed(bytes: &'a [u8]) -> Result<Self, StateError> {
        if bytes.len() < HEADER_LENGTH + CHECKSUM_LENGTH || &bytes[..8] != STATE_MAGIC {
            return Err(StateError::new(
                "the bytes are not a serialized FMU state of this implementation (wrong header)",
            ));
        }
        let mut header = Self::new(&bytes[8..HEADER_LENGTH]);
        let version = header.u32("format version")?;
        if version != STATE_FORMAT_VERSION {
            return Err(StateError::new(format!(
                "serialized state format version {version}; expected {STATE_FORMAT_VERSION}"
            )));
        }
        let length = header.u64("length")?;
        if length != bytes.len() as u64 {
            return Err(StateError::new(format!(
                "the serialized state says it is {length} bytes long but {} bytes were given",
                bytes.len()
            )));
        }
        let (content, checksum) = bytes.split_at(bytes.len() - CHECKSUM_LENGTH);
        let stored = u64::from_le_bytes(checksum.try_into().unwrap_or_default());
        let computed = fnv1a_64(content);
        if stored != computed {
            return Err(StateError::new(format!(
                "the serialized state's checksum is {stored:#018x} but its bytes give {computed:#018x}: it was changed or damaged"
            )));
        }
        Ok(Self::new(&content[HEADER_LENGTH..]))
    }

    pub fn position(&self) -> usize {
        self.position
    }

    /// How many bytes are left to read.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.position
    }

    pub fn is_at_end(&self) -> bool {
        self.position == self.bytes.len()
    }

    fn take(&mut self, count: usize, what: &str) -> Result<&'a [u8], StateError> {
        let end = self
            .position
            .checked_add(count)
            .filter(|&end| end <= self.bytes.len());
        match end {
            Some(end) => {
                let slice = &self.bytes[self.position..end];
                self.position = end;
                Ok(slice)
            }
            None => Err(StateError::new(format!(
                "the serialized state ends at byte {} while reading '{what}' ({count} more bytes expected)",
                self.bytes.len()
            ))),
        }
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], StateError> {
        let slice = self.take(N, what)?;
        let mut array = [0u8; N];
        array.copy_from_slice(slice);
        Ok(array)
    }

    pub fn f64(&mut self, what: &str) -> Result<f64, StateError> {
        Ok(f64::from_bits(u64::from_le_bytes(self.array(what)?)))
    }

    /// Reads a length-prefixed list written by [`StateWriter::f64s`] into `target`, which must
    /// have the same length.
    pub fn f64s_into(&mut self, target: &mut [f64], what: &str) -> Result<(), StateError> {
        let length = self.u64(what)?;
        if length != target.len() as u64 {
            return Err(StateError::new(format!(
                "'{what}' has {length} values in the serialized state; expected {}",
                target.len()
            )));
        }
        for value in target.iter_mut() {
            *value = self.f64(what)?;
        }
        Ok(())
    }

    /// Reads a length-prefixed list written by [`StateWriter::f64s`].
    pub fn f64s(&mut self, what: &str, max_len: usize) -> Result<Vec<f64>, StateError> {
        let length = self.u64(what)?;
        if length > max_len as u64 {
            return Err(StateError::new(format!(
                "'{what}' claims {length} values; expected at most {max_len}"
            )));
        }
        (0..length).map(|_| self.f64(what)).collect()
    }

    pub fn u64(&mut self, what: &str) -> Result<u64, StateError> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    pub fn u32(&mut self, what: &str) -> Result<u32, StateError> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub fn i32(&mut self, what: &str) -> Result<i32, StateError> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    pub fn u8(&mut self, what: &str) -> Result<u8, StateError> {
        Ok(self.array::<1>(what)?[0])
    }

    pub fn bool(&mut self, what: &str) -> Result<bool, StateError> {
        match self.u8(what)? {
            0 => Ok(false),
            1 => Ok(true),
            other => Err(StateError::new(format!(
                "'{what}' is {other} in the serialized state; expected a boolean 0 or 1"
            ))),
        }
    }

    pub fn bytes(&mut self, what: &str) -> Result<&'a [u8], StateError> {
        let length = self.u64(what)?;
        let length = usize::try_from(length)
            .map_err(|_| StateError::new(format!("'{what}' claims {length} bytes")))?;
        self.take(length, what)
    }
}
