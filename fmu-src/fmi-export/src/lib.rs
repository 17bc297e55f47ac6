//! FMI 2.0 Co-Simulation plumbing, written once for both FMUs
