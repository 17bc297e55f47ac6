//! Where an estimator writes its running state and reads it back (an FMU's
//! fmi2SerializeFMUstate, see [`crate::registry::RunningEstimator::save`]).
//!
//! The byte format belongs to the host: the FMU crates implement these traits over fmi-export's
//! `StateWriter` / `StateReader`, so this crate does not depend on the FMI plumbing and the
//! format stays written once. Every read names what it reads, for the host's error message.

use nalgebra::{SMatrix, SVector};

/// Why a stored state could not be read back (the host's message, or the estimator's).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SnapshotError(pub String);

/// Appends values to a stored state.
pub trait SnapshotSink {
    fn u8(&mut self, value: u8);
    fn u32(&mut self, value: u32);
    fn u64(&mut self, value: u64);
    fn f64(&mut self, value: f64);
    fn bool(&mut self, value: bool);
    /// A length-prefixed byte string.
    fn bytes(&mut self, value: &[u8]);
    /// A length-prefixed list of values.
    fn f64s(&mut self, values: &[f64]);
}

/// Reads values in the order a [`SnapshotSink`] wrote them; `what` names the value in errors.
pub trait SnapshotSource {
    fn u8(&mut self, what: &str) -> Result<u8, SnapshotError>;
    fn u32(&mut self, what: &str) -> Result<u32, SnapshotError>;
    fn u64(&mut self, what: &str) -> Result<u64, SnapshotError>;
    fn f64(&mut self, what: &str) -> Result<f64, SnapshotError>;
    fn bool(&mut self, what: &str) -> Result<bool, SnapshotError>;
    /// A byte string written by [`SnapshotSink::bytes`].
    fn bytes(&mut self, what: &str) -> Result<Vec<u8>, SnapshotError>;
    /// A list written by [`SnapshotSink::f64s`] of at most `max_len` values.
    fn f64s(&mut self, what: &str, max_len: usize) -> Result<Vec<f64>, SnapshotError>;
    /// A list written by [`SnapshotSink::f64s`] into `target`, which must have its length.
    fn f64s_into(&mut self, target: &mut [f64], what: &str) -> Result<(), SnapshotError>;
}

/// The Gaussian `(x̂, P)` of a Kalman-type estimator as stored: the state, then the covariance
/// (column-major), each a length-prefixed list.
pub(crate) fn save_gaussian<const N: usize>(
    sink: &mut dyn SnapshotSink,
    state: &SVector<f64, N>,
    covariance: &SMatrix<f64, N, N>,
) {
    sink.f64s(state.as_slice());
    sink.f64s(covariance.as_slice());
}

/// Reads what [`save_gaussian`] wrote.
pub(crate) fn read_gaussian<const N: usize>(
    source: &mut dyn SnapshotSource,
) -> Result<(SVector<f64, N>, SMatrix<f64, N, N>), SnapshotError> {
    let mut state = SVector::<f64, N>::zeros();
    source.f64s_into(state.as_mut_slice(), "estimate")?;
    let mut covariance = SMatrix::<f64, N, N>::zeros();
    source.f64s_into(covariance.as_mut_slice(), "covariance")?;
    Ok((state, covariance))
}

/// A stored state in memory, for the tests of `save`/`restore`: the numbers, the flags and a
/// read position in each.
#[cfg(test)]
#[derive(Default)]
pub(crate) struct Tape(Vec<f64>, Vec<bool>, usize, usize);

#[cfg(test)]
impl SnapshotSink for Tape {
    fn u8(&mut self, v: u8) {
        self.0.push(f64::from(v));
    }
    fn u32(&mut self, v: u32) {
        self.0.push(f64::from(v));
    }
    fn u64(&mut self, v: u64) {
        self.0.push(v as f64);
    }
    fn f64(&mut self, v: f64) {
        self.0.push(v);
    }
    fn bool(&mut self, v: bool) {
        self.1.push(v);
    }
    fn bytes(&mut self, _: &[u8]) {
        unreachable!()
    }
    fn f64s(&mut self, v: &[f64]) {
        self.0.extend_from_slice(v);
    }
}
#[cfg(test)]
impl SnapshotSource for Tape {
    fn u8(&mut self, w: &str) -> Result<u8, SnapshotError> {
        Ok(SnapshotSource::f64(self, w)? as u8)
    }
    fn u32(&mut self, w: &str) -> Result<u32, SnapshotError> {
        Ok(SnapshotSource::f64(self, w)? as u32)
    }
    fn u64(&mut self, w: &str) -> Result<u64, SnapshotError> {
        Ok(SnapshotSource::f64(self, w)? as u64)
    }
    fn f64(&mut self, _: &str) -> Result<f64, SnapshotError> {
        self.2 += 1;
        Ok(self.0[self.2 - 1])
    }
    fn bool(&mut self, _: &str) -> Result<bool, SnapshotError> {
        self.3 += 1;
        Ok(self.1[self.3 - 1])
    }
    fn bytes(&mut self, _: &str) -> Result<Vec<u8>, SnapshotError> {
        unreachable!()
    }
    fn f64s(&mut self, _: &str, _: usize) -> Result<Vec<f64>, SnapshotError> {
        unreachable!()
    }
    fn f64s_into(&mut self, target: &mut [f64], w: &str) -> Result<(), SnapshotError> {
        for value in target.iter_mut() {
            *value = SnapshotSource::f64(self, w)?;
        }
        Ok(())
    }
}
