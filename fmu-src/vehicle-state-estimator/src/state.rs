//! The FMU state's byte format (fmi-export's `StateWriter` / `StateReader`) as the `estimation`
//! crate's snapshot sink and source, so that an estimator stores its running state in the FMU
//! state without depending on the FMI plumbing.

use estimation::snapshot::{SnapshotError, SnapshotSink, SnapshotSource};
use fmi_export::{StateError, StateReader, StateWriter};

/// Writes an estimator's snapshot into an FMU state.
pub struct Sink<'a>(pub &'a mut StateWriter);

/// Reads an estimator's snapshot from an FMU state.
pub struct Source<'a, 'b>(pub &'a mut StateReader<'b>);

fn snapshot_error(error: StateError) -> SnapshotError {
    SnapshotError(error.message)
}

impl SnapshotSink for Sink<'_> {
    fn u8(&mut self, value: u8) {
        self.0.u8(value);
    }
    fn u32(&mut self, value: u32) {
        self.0.u32(value);
    }
    fn u64(&mut self, value: u64) {
        self.0.u64(value);
    }
    fn f64(&mut self, value: f64) {
        self.0.f64(value);
    }
    fn bool(&mut self, value: bool) {
        self.0.bool(value);
    }
    fn bytes(&mut self, value: &[u8]) {
        self.0.bytes(value);
    }
    fn f64s(&mut self, values: &[f64]) {
        self.0.f64s(values);
    }
}

impl SnapshotSource for Source<'_, '_> {
    fn u8(&mut self, what: &str) -> Result<u8, SnapshotError> {
        self.0.u8(what).map_err(snapshot_error)
    }
    fn u32(&mut self, what: &str) -> Result<u32, SnapshotError> {
        self.0.u32(what).map_err(snapshot_error)
    }
    fn u64(&mut self, what: &str) -> Result<u64, SnapshotError> {
        self.0.u64(what).map_err(snapshot_error)
    }
    fn f64(&mut self, what: &str) -> Result<f64, SnapshotError> {
        self.0.f64(what).map_err(snapshot_error)
    }
    fn bool(&mut self, what: &str) -> Result<bool, SnapshotError> {
        self.0.bool(what).map_err(snapshot_error)
    }
    fn bytes(&mut self, what: &str) -> Result<Vec<u8>, SnapshotError> {
        self.0
            .bytes(what)
            .map(<[u8]>::to_vec)
            .map_err(snapshot_error)
    }
    fn f64s(&mut self, what: &str, max_len: usize) -> Result<Vec<f64>, SnapshotError> {
        self.0.f64s(what, max_len).map_err(snapshot_error)
    }
    fn f64s_into(&mut self, target: &mut [f64], what: &str) -> Result<(), SnapshotError> {
        self.0.f64s_into(target, what).map_err(snapshot_error)
    }
}
