//! FMI 2.0 Co-Simulation master of the vehicle state estimator project: scenario files,
//! the manoeuvre library, scoring against the truth, CSV and PNG output, the demo report and
//! Monte Carlo runs. FMUs are loaded only through the `fmi` crate; nothing here links the FMU
//! crates. The one exception to "FMI only" is `identify` (and the demo's seed-003 section that
//! uses it): the offline EM identification of seed 003 links the `estimation` library (and
//! through it `vehicle-models`) — no FMU and no co-simulation is involved there.

pub mod cosim;
pub mod demo;
pub mod fmu;
pub mod fmu_log;
pub mod identify;
pub mod manoeuvre;
pub mod mismatch;
pub mod montecarlo;
pub mod plot;
pub mod recording;
pub mod report;
pub mod runner;
pub mod scenario;
pub mod scoring;
