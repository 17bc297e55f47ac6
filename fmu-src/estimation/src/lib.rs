//! State estimators for vehicle dynamics, all generic over one model interface
//! ([`StateSpaceModel`]), so that each runs on models A, B (3-state form) and C without copies.
//!
//! # Adding an estimator
//!
//! Say a square-root UKF. Exactly these places change:
//!
//! 1. **One new file** with the algorithm, e.g. `src/kalman/srukf.rs` (and its `mod` line in
//!    `kalman/mod.rs`): the filter type, its [`Estimator`] implementation and its
//!    [`running::RunningEstimator`] implementation (`last_report`; a Kalman-type filter keeps
//!    the default `save`/`restore` of `(x̂, P)`).
//! 2. **One registry line** in the `registry!` invocation of [`registry`]: variant, name and how
//!    it is built from the model, the [`registry::EstimatorSettings`] and the start (name the new
//!    type by its path, e.g. `crate::kalman::srukf::SquareRootUkf::new(..)`). The FMU,
//!    the tests, the benchmarks and the studies build through [`registry::build`], and the FMU
//!    maps its parameter to [`registry::EstimatorChoice`] by item name, so none of them lists
//!    the estimators.
//! 3. **One XML item** in the `EstimatorKind` enumeration of
//!    `modelDescription/VehicleStateEstimator.xml`, with the registry line's name and at the
//!    same position (a test of the FMU crate checks that the two lists agree, in order). Its
//!    value is the `estimator` parameter's new value. The generated Rust enum, the FMU's error
//!    messages, the fmpy tests (they read the enumeration from the XML) and the documentation
//!    follow from it.
//!
//! A new setting the estimator needs (a parameter of the FMU) is a field of
//! [`registry::EstimatorSettings`] and a variable of the XML, beyond these three places.

pub mod estimator;
pub mod model;

/// Small dense-matrix helpers: symmetrising, Cholesky with repair.
pub mod linalg;

pub mod kalman;

/// Discrete Luenberger observer with pole placement (Ackermann formula, 002: §4).
pub mod luenberger;

/// The vehicle models of the `vehicle-models` crate seen through [`StateSpaceModel`].
pub mod models;

/// SIR particle filter and resampling schemes (003: §2.2.4, A.4).
pub mod particle;

/// Innovation-based adaptive process noise (covariance matching on the NIS).
pub mod adaptive;

/// A fixed-gain observer's reported covariance scaled to its windowed NIS.
pub mod innovation_scaling;

/// Whether a filter's innovations exceed the covariance it reports.
pub mod innovation_monitor;

/// Each measurement row's noise variance learned from its innovations (covariance matching).
pub mod measurement_noise;

pub mod registry;
pub mod running;
pub mod snapshot;

/// Reweighting (marginal) particle smoother (003: 2.63-2.75, 3.1-3.2).
#[cfg(feature = "offline")]
pub mod smoother;

/// EM parameter identification with the particle smoother (003: 2.76-2.78, 3.3-3.12).
#[cfg(feature = "offline")]
pub mod identification;

/// The posterior Cramér-Rao lower bound (Tichavský, Muravchik and Nehorai 1998).
#[cfg(feature = "offline")]
pub mod pcrlb;

#[cfg(test)]
mod test_oracle;

pub use estimator::{Estimator, FilterIssue, MeasurementMask, UpdateReport};
pub use model::StateSpaceModel;
