//! State estimators for vehicle dynamics, all generic over one model interface
//! ([`StateSpaceModel`]), so that each runs on models A, B (3-state form) and C without copies.

pub mod estimator;
pub mod model;

/// Small dense-matrix helpers: symmetrising, Cholesky with repair.
pub mod linalg;

/// Kalman-type filters: LKF, EKF, UKF (2n and scaled 2n+1 sigma points).
pub mod kalman;

/// Discrete Luenberger observer with pole placement (Ackermann formula, 002: §4).
pub mod luenberger;

/// The vehicle models of the `vehicle-models` crate seen through [`StateSpaceModel`].
pub mod models;

/// SIR particle filter and resampling schemes (003: §2.2.4, A.4).
pub mod particle;

/// Reweighting (marginal) particle smoother (003: 2.63-2.75, 3.1-3.2).
#[cfg(feature = "offline")]
pub mod smoother;

/// EM parameter identification with the particle smoother (003: 2.76-2.78, 3.3-3.12).
#[cfg(feature = "offline")]
pub mod identification;

#[cfg(test)]
mod test_oracle;

pub use estimator::{Estimator, FilterIssue, MeasurementMask, UpdateReport};
pub use model::StateSpaceModel;
