//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file.
//! `cargo test -p estimation --test integration <module>::` runs one file's tests.

mod kalman_support;
mod seed000_support;
// EM identification is offline work (feature `offline`), which the FMU does not enable.
mod condition_on;
mod extra_measurement_noise;
mod gain_scheduling;
#[cfg(feature = "offline")]
mod identification_em;
mod kalman_linear;
mod luenberger_model_a;
mod luenberger_placement;
mod particle_filter;
mod seed000_findings;
mod seed001_step_steer;
