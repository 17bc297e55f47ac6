//! Vehicle models for planar (lateral + longitudinal) vehicle dynamics; no FMI code.
//!
//! - **Model A** ([`single_track`]): 5-state nonlinear single-track model with HSRI tyres
//!   (seed 000, ch. 5-6), the core model of the estimators and of the reference vehicle.
//! - **Model B** ([`two_track`]): two-track model with lateral load transfer and Magic Formula
//!   tyres (seed 001), both as a full reference vehicle and in the 3-state `[β, r, ay]` form.
//! - **Model C** ([`rear_axle`]): rear-axle-referenced single-track model with longitudinal load
//!   transfer (seed 003, §2.1), the test bed of the particle filter and EM identification.
//! - Tyres ([`tyre`]): HSRI, Magic Formula and linear behind one [`tyre::TyreModel`] trait.
//! - [`reference::ReferenceVehicle`]: model A or B behind one interface (same input, same
//!   [`VehicleTruth`]) for the ReferenceVehicle FMU.
//! - [`manoeuvre`]: the seed-000 manoeuvre inputs.
//!
//! Conventions (everyone relies on them):
//! - states, inputs and measurements are `nalgebra::SVector<f64, N>`; index constants name the
//!   positions (e.g. [`single_track::state_index`], [`driver_input::index`]);
//! - axes ISO 8855 (x forward, y left, z up), yaw rate positive for a left turn, steering angle =
//!   road-wheel angle at the front axle, positive left; sideslip `β = atan2(vy, vx)`;
//! - `brake_torque ≥ 0` is the magnitude of the total brake torque (see [`driver_input`]);
//! - parameters are plain serde structs whose `Default` holds the seed's values;
//! - every equation is generic over [`Scalar`], so the exact Jacobians come from forward-mode
//!   automatic differentiation ([`scalar::Dual`]) of the very same code;
//! - no heap allocation in any step.

/// Gravitational acceleration of every model, m/s²: the seeds' value (003: §3.2), also the
/// full vehicle's and the one the static wheel loads are computed with, in the models and by the
/// harness for the estimators. Standard gravity, 9.80665 m/s², is a unit (the FMVSS 126 0.3 g
/// criterion, signals recorded in g): `manoeuvres::STANDARD_GRAVITY`.
pub const GRAVITY: f64 = 9.81;

pub mod brake;
pub mod checks;
pub mod driver_input;
pub mod full_vehicle;
pub mod integrator;
/// The seed-000 manoeuvres, defined once in the `manoeuvres` crate (also the operating point's
/// initial speeds, [`single_track::SingleTrackModel::seed_operating_point`]).
pub use manoeuvres::seed000 as manoeuvre;
pub mod parameters;
pub mod rear_axle;
pub mod reference;
pub mod scalar;
pub mod single_track;
pub mod truth;
pub mod two_track;
pub mod two_track_lateral;
pub mod tyre;

pub use driver_input::{DriverInput, DriverInputVector};
pub use integrator::Integrator;
pub use rear_axle::{RearAxleModel, RearAxleParams};
pub use reference::{
    ReferenceModelKind, ReferenceVehicle, ReferenceVehicleError, ReferenceVehicleParams,
};
pub use scalar::{Dual, Scalar};
pub use single_track::{
    AxleSlipKinematics, Chassis, LateralTyreStates, SingleTrackHsri, SingleTrackLinearisation,
    SingleTrackModel, SingleTrackParams, SingleTrackState,
};
pub use truth::VehicleTruth;
pub use two_track::{TwoTrackMagicFormula, TwoTrackModel, TwoTrackParams, TwoTrackState};
pub use two_track_lateral::{TwoTrackLateralMagicFormula, TwoTrackLateralModel};
pub use tyre::{HsriTyre, LinearTyre, MagicFormulaTyre, TyreModel};
