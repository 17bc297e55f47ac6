//! FMI 2.0 Co-Simulation master of the vehicle state estimator project: scenario files,
//! the manoeuvre library, scoring against the truth, CSV and PNG output, the demo report and
//! Monte Carlo runs. FMUs are loaded only through the `fmi` crate; nothing here links the
//! model or estimator code (except `identify`, which calls the offline identification of the
//! `estimation` library — no co-simulation).

pub mod cosim;
pub mod demo;
pub mod fmu;
pub mod fmu_log;
pub mod manoeuvre;
pub mod montecarlo;
pub mod plot;
pub mod recording;
pub mod report;
pub mod runner;
pub mod scenario;
pub mod scoring;
