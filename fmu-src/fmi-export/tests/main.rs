//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file (a build per file cost minutes).
//! `cargo test -p fmi-export --test integration <module>::` runs one file's tests.

mod call_sequences;
mod fmi3_front_end;
mod setters_and_logging;
mod stale_components;
mod state_frames;
mod toy;
mod work_per_call;
