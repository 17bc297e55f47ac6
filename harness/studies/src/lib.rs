//! The project's studies on top of the general FMI master [`fmi_master`]: the demo with the
//! seed findings and its report, the offline seed-003 identification (`harness identify`) and
//! the model-mismatch study. Co-simulation goes through FMI alone (the master); only the offline
//! parts (EM identification, no FMU involved) link the `estimation` library with its `offline`
//! feature (and through it `vehicle-models`).

pub mod campaigns;
pub mod consistency;
pub mod demo;
pub mod expression;
pub mod findings;
pub mod fmi_versions;
pub mod identify;
pub mod mismatch;
pub mod population;
pub mod replay;
pub mod robustness;
pub mod seed003;
pub mod summary;
