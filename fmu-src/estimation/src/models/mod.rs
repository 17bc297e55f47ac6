//! Adapters from the vehicle models to [`crate::StateSpaceModel`].

// Model C and model A's stiffness scales exist for the EM identification (offline only).
mod dual_passes;
#[cfg(feature = "offline")]
pub mod rear_axle;
pub mod single_track;
pub mod single_track_grip;
#[cfg(feature = "offline")]
pub mod single_track_identification;
pub mod two_track;
pub mod unknown_torques;
