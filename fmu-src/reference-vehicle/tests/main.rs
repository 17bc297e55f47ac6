//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file (the test command's time is bounded).
//! `cargo test -p reference-vehicle --test integration <module>::` runs one file's tests.

mod c_api;
mod car_parameter_sets;
mod common;
mod feed_through;
mod load_unload;
mod parameter_limits;
mod sensor_faults;
