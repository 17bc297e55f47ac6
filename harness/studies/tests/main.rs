//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file.
//! `cargo test -p harness --test integration <module>::` runs one file's tests.

mod fmi_versions;
mod identify_cli;
mod low_speed_campaign;
mod mismatch_identification;
mod population;
mod replay;
mod replay_mbds;
mod robustness;
// The scratch folder of fmi-master's tests (removed at the end of a test, KEEP_TEST_DIRS=1 keeps
// a failing test's): one definition for the workspace's test binaries.
#[path = "../../master/tests/common/scratch.rs"]
mod scratch;
mod seed003_identification;
mod seed003_smoother;
