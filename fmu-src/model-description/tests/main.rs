//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file (a build per file cost minutes).
//! `cargo test -p model-description --test integration <module>::` runs one file's tests.

mod codegen_rows;
mod model_descriptions;
