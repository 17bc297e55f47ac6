//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file (the test command's time is bounded).
//! `cargo test -p vehicle-models --test integration <module>::` runs one file's tests.

mod combined_slip_tyre;
mod common;
mod full_vehicle_cars;
mod full_vehicle_handling;
mod full_vehicle_standstill;
mod full_vehicle_support;
mod handling_diagram;
mod model_a;
mod model_b;
mod model_c;
mod parameters;
mod planar_standstill;
mod reference;
mod robustness;
