//! Mismatch campaigns (issue 13's last line, issue 17 point 5): every estimator on both of its
//! models against the ReferenceVehicle's full vehicle (model 3) with real cars' parameter files,
//! on the manoeuvres where a filter's model stops being right.

pub mod car;
pub mod metrics;
