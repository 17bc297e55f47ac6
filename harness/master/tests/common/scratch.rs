//! A test's scratch folder, removed when the test ends. One definition for the test binaries of
//! fmi-master, harness and packaging: the other two include this file with `#[path]`.

use std::path::PathBuf;

/// A fresh folder `<package>-test-<name>-XXXXXX` under the system's temporary folder, removed
/// when dropped, at the end of a test that passes and of one that fails (panics).
/// KEEP_TEST_DIRS=1 keeps the folder of a failing test and prints its path, for inspection.
///
/// The random suffix (`tempfile`, created with `O_EXCL` semantics) keeps names unique across the
/// test threads of one binary and across processes, with no folder of an earlier run removed.
pub struct Scratch(pub PathBuf);

impl Scratch {
    pub fn new(name: &str) -> Scratch {
        let prefix = format!("{}-test-{name}-", env!("CARGO_PKG_NAME"));
        let dir = tempfile::Builder::new()
            .prefix(&prefix)
            .tempdir()
            .unwrap_or_else(|e| panic!("scratch folder {prefix}*: {e}"));
        // The folder is removed by this type's Drop, which can keep it (KEEP_TEST_DIRS).
        Scratch(dir.keep())
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() && keep_failed_test_dirs() {
            eprintln!("KEEP_TEST_DIRS=1: kept {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Whether KEEP_TEST_DIRS=1 asks to keep the folders of failing tests.
pub fn keep_failed_test_dirs() -> bool {
    std::env::var_os("KEEP_TEST_DIRS").is_some_and(|value| value == "1")
}
