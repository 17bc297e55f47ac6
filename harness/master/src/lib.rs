//! A general FMI 2.0 Co-Simulation master: scenario files driving the manoeuvre signals of the
//! `manoeuvres` crate, the co-simulation loop ([`cosim::Plan`]), FMU loading, instances
//! ([`instance::FmuInstance`]) and logging, recording to CSV, scoring against a truth, Monte
//! Carlo campaigns, plots and report primitives.
//!
//! FMUs are reached only through the `fmi` crate. This crate depends on no estimator, vehicle
//! model or FMU crate of the workspace (its Cargo.toml says so and `tests/independence.rs`
//! checks it); the project's studies (demo, findings, identification, model mismatch) live in
//! the `harness` crate on top of this one.

pub mod cosim;
pub mod fmu;
pub mod fmu_log;
pub mod instance;

pub mod montecarlo;
pub mod plot;
pub mod recording;
pub mod report;
pub mod runner;
pub mod scenario;
pub mod scoring;
pub mod ssv;
pub mod yardstick;
