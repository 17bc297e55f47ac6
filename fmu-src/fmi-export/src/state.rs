//! A small, explicit binary format for FMU states: little-endian, f64 stored by its bit pattern
//! so that a restored state continues bit-identically.

use std::fmt;

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

    pub fn position(&self) -> usize {
        self.position
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
