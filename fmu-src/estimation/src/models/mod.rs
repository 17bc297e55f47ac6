//! Adapters from the vehicle models to [`crate::StateSpaceModel`].

// Model C and models A's and B's stiffness scales exist for the EM identification (offline only).
#[cfg(feature = "offline")]
pub mod rear_axle;
pub mod single_track;
pub mod single_track_grip;
#[cfg(feature = "offline")]
pub mod single_track_identification;
#[cfg(feature = "offline")]
pub mod stiffness_identification;
pub mod two_track;
#[cfg(feature = "offline")]
pub mod two_track_identification;
