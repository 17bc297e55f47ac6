//! Adapters from the vehicle models to [`crate::StateSpaceModel`].

pub mod rear_axle;
pub mod single_track;
pub mod single_track_identification;
pub mod two_track;
