//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file, which was a tenth of the
//! test command's build. `cargo test -p fmi-master --test integration
//! <module>::` runs one file's tests.

mod common;
mod fmu_instance;
mod fmu_refusal;
mod hardening;
mod independence;
mod parameter_files;
mod plan_errors;
mod recycled_recording;
mod scenario_errors;
mod scoring_maths;
