//! Model A with its two cornering-stiffness scale factors as identifiable parameters
//! (`p = [k_F, k_R]`, [`Parameterised<2>`]) for the EM identification of
//! [`crate::identification`] — beyond the seeds: seed 003 identifies model C's stiffnesses on
//! data of the same model (003: §3.1-3.2); here model A (single track, HSRI, seed 000) learns
//! how stiff the axles of *another* vehicle look through its own structure, e.g. the two-track
//! Magic Formula car of seed 001 with its lateral load transfer (model mismatch).
//!
//! `k_F` and `k_R` multiply the cornering stiffness `Cα = (Cα1 + Cα2 Fz/FZref) Fz` (000: 5.70)
//! of the front and rear tyres wherever it enters the HSRI force law (lateral demand and
//! resultant slip, 000: 5.72-5.73), see
//! [`vehicle_models::single_track::SingleTrackParams::cornering_stiffness_scale_front`].
//! The tyre forces feed both the transition (000: 5.42, 5.44) and the measured lateral
//! acceleration `ay = (FyR + FyF cos δ + FxF sin δ)/m` (000: 5.40, 5.63), so the measurement
//! term `I_3` (003: 2.78) enters the M-step.

use nalgebra::SVector;
use vehicle_models::driver_input::INPUT_DIM;
use vehicle_models::single_track::{MEASUREMENT_DIM, STATE_DIM};
use vehicle_models::{HsriTyre, SingleTrackModel, TyreModel};

/// Model A's vehicle as seed 000 gives it (the VehicleStateEstimator's defaults), re-exported so
/// that a caller of [`identify_scales_from_arrays`] needs no direct `vehicle-models` dependency.
pub use vehicle_models::SingleTrackHsri;

use vehicle_models::single_track::state_index;

use super::stiffness_identification::{checked_run, identify_scales, StiffnessScaled};
pub use super::stiffness_identification::{
    CorneringIdentificationError, StiffnessIdentificationConfig, StiffnessScales, MAX_SCALE,
    MIN_SCALE, PARAMETER_NAMES,
};
use crate::identification::EmResult;
use crate::kalman::SettingsError;
use crate::models::single_track::SingleTrackEstimationModel;
use crate::StateSpaceModel;

/// Model A whose per-axle cornering-stiffness scales are the parameters; everything else (the
/// filter's sample time, integrator, `Q`, `R`) is that of the wrapped estimation model.
pub type CorneringStiffnessModel<T = HsriTyre> = StiffnessScales<SingleTrackEstimationModel<T>>;

impl<T: TyreModel> StiffnessScaled for SingleTrackEstimationModel<T> {
    fn stiffness_scales(&self) -> [f64; 2] {
        let vehicle = &self.vehicle().vehicle;
        [
            vehicle.cornering_stiffness_scale_front,
            vehicle.cornering_stiffness_scale_rear,
        ]
    }

    fn with_stiffness_scales(&self, scales: [f64; 2]) -> Result<Self, SettingsError> {
        let current = self.vehicle();
        let mut vehicle = current.vehicle.clone();
        vehicle.cornering_stiffness_scale_front = scales[0];
        vehicle.cornering_stiffness_scale_rear = scales[1];
        // The model was built from diagonal Q and R (its constructor's only form), so their
        // diagonals rebuild them exactly.
        SingleTrackEstimationModel::new(
            SingleTrackModel::new(vehicle, current.tyre.clone()),
            self.sample_time(),
            self.integrator(),
            self.process_noise().diagonal().into(),
            self.measurement_noise().diagonal().into(),
        )
    }

    /// `ay` is a tyre-force sum (000: 5.40): the measurement depends on the scales.
    fn measurement_depends_on_scales(&self) -> bool {
        true
    }
}

/// Model A's settings of [`identify_scales_from_arrays`] (see [`StiffnessIdentificationConfig`]):
/// `Q` and the initial prior over `[vx, vy, r, ωF, ωR]`, `R` over `[r, ay, ωF, ωR]`.
pub type CorneringIdentificationConfig = StiffnessIdentificationConfig<STATE_DIM, MEASUREMENT_DIM>;

/// The state model A starts from, read off a measurement row `[r, ay, ωF, ωR]`: the speed of
/// the freely rolling rear wheels `ωR r_w` (no drive torque at the rear, 000: 5.46), no
/// lateral velocity (the data must start in straight driving; the prior's vy spread covers a
/// small error), the measured yaw rate and wheel speeds.
pub fn initial_state_from_measurement<T: TyreModel>(
    vehicle: &SingleTrackModel<T>,
    measurement: &[f64; MEASUREMENT_DIM],
) -> SVector<f64, STATE_DIM> {
    use vehicle_models::single_track::measurement_index as y;
    let mut state = SVector::<f64, STATE_DIM>::zeros();
    state[state_index::VX] = measurement[y::OMEGA_REAR] * vehicle.vehicle.chassis.rear_wheel_radius;
    state[state_index::YAW_RATE] = measurement[y::YAW_RATE];
    state[state_index::OMEGA_FRONT] = measurement[y::OMEGA_FRONT];
    state[state_index::OMEGA_REAR] = measurement[y::OMEGA_REAR];
    state
}

/// Identifies `[k_F, k_R]` of `vehicle` (model A's vehicle and tyre data; its own scales are
/// ignored, `config.start` is the start) by the accelerated EM
/// ([`identify_scales`], 003: §3.1) from rows of driver inputs
/// `[steering_angle, drive_torque, brake_torque]` and measurements `[r, ay, ωF, ωR]` sampled
/// every `config.sample_time` (row `k` of both at `t0 + k T`; a NaN measurement entry is a
/// missing value, the filter skips that row).
pub fn identify_scales_from_arrays<T: TyreModel>(
    vehicle: &SingleTrackModel<T>,
    inputs: &[[f64; INPUT_DIM]],
    measurements: &[[f64; MEASUREMENT_DIM]],
    config: &CorneringIdentificationConfig,
) -> Result<EmResult<2>, CorneringIdentificationError> {
    let (run, first) = checked_run(
        inputs,
        measurements,
        "[steering_angle, drive_torque, brake_torque]",
    )?;
    let model = SingleTrackEstimationModel::new(
        vehicle.clone(),
        config.sample_time,
        config.integrator,
        config.process_noise_std.map(|std| std * std),
        config.measurement_noise_std.map(|std| std * std),
    )
    .map_err(CorneringIdentificationError::Settings)?;
    let start = CorneringStiffnessModel::new(model)
        .with_scales(&SVector::from(config.start))
        .map_err(CorneringIdentificationError::Settings)?;
    identify_scales(
        &start,
        &run,
        initial_state_from_measurement(vehicle, &first),
        config,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identification::Parameterised;

    fn seed_model() -> SingleTrackEstimationModel {
        SingleTrackEstimationModel::seed_000(0.01).unwrap()
    }

    #[test]
    fn scales_are_the_parameters_within_their_range() {
        let model = CorneringStiffnessModel::new(seed_model());
        assert_eq!(model.parameters(), SVector::<f64, 2>::new(1.0, 1.0));
        let scaled = model
            .with_parameters(&SVector::<f64, 2>::new(0.8, 1.2))
            .unwrap();
        assert_eq!(scaled.parameters(), SVector::<f64, 2>::new(0.8, 1.2));
        assert_eq!(scaled.process_noise(), model.process_noise());
        assert_eq!(scaled.measurement_noise(), model.measurement_noise());
        assert_eq!(scaled.model().sample_time(), 0.01);
        // Scale 1 is the seed's model A, bit for bit.
        let unit = model
            .with_parameters(&SVector::<f64, 2>::new(1.0, 1.0))
            .unwrap();
        let state = SVector::<f64, STATE_DIM>::from([18.0, 0.3, 0.2, 60.2, 60.0]);
        let input = SVector::<f64, INPUT_DIM>::from([0.03, 0.0, 0.0]);
        assert_eq!(
            unit.transition(&state, &input),
            seed_model().transition(&state, &input)
        );
        // Other scales, other tyre forces, so another ay for the same state.
        assert_ne!(
            scaled.measurement(&state, &input)[1],
            model.measurement(&state, &input)[1]
        );
        for bad in [0.0, -1.0, 0.01, 25.0, f64::NAN, f64::INFINITY] {
            assert!(model
                .with_parameters(&SVector::<f64, 2>::new(bad, 1.0))
                .is_none());
            let error = model
                .with_scales(&SVector::<f64, 2>::new(1.0, bad))
                .unwrap_err();
            assert!(
                error.0.contains("cornering_stiffness_scale_rear"),
                "{}",
                error.0
            );
        }
    }

    #[test]
    fn initial_state_is_read_off_the_measurement() {
        let vehicle = vehicle_models::SingleTrackHsri::default();
        let state = initial_state_from_measurement(&vehicle, &[0.1, 2.0, 61.0, 60.0]);
        assert_eq!(state.as_slice(), &[18.0, 0.0, 0.1, 61.0, 60.0]);
    }
}
