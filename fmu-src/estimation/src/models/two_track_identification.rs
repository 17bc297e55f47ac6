//! Model B (the 3-state two-track form of seed 001, [`TwoTrackEstimationModel`]) with its
//! per-axle cornering-stiffness scales as the EM's parameters (`p = [k_F, k_R]`,
//! [`StiffnessScales`]) — beyond the seeds, as model A's ([`super::single_track_identification`]):
//! `harness fit --model b` identifies how stiff a car's axles look through model B, whose
//! lateral load transfer the car has too, so the scales do not carry it (model A's do, and
//! written for model B they counted it twice: harness/logs/README.md).
//!
//! `k_F` and `k_R` multiply the Magic Formula tyres' `B·C·D`, matched to the HSRI cornering
//! stiffness `Cα = (Cα1 + Cα2 Fz/FZref) Fz` (000: 5.70) at each wheel's load
//! ([`vehicle_models::TwoTrackParams::cornering_stiffness_scale_front`]). They act in the
//! transition only: model B measures its states `ay` and `r` directly (001: eq 9), so the
//! measurement term `I_3` (003: 2.78) is left out of the M-step.

use nalgebra::SVector;
use vehicle_models::two_track_lateral::{
    input_index, measurement_index, state_index, INPUT_DIM, MEASUREMENT_DIM, STATE_DIM,
};
use vehicle_models::{TwoTrackLateralModel, TyreModel};

use super::stiffness_identification::{checked_run, identify_scales, StiffnessScaled};
pub use super::stiffness_identification::{
    CorneringIdentificationError, StiffnessIdentificationConfig, StiffnessScales, PARAMETER_NAMES,
};
use crate::identification::EmResult;
use crate::kalman::SettingsError;
use crate::models::two_track::TwoTrackEstimationModel;
use crate::StateSpaceModel;

/// Model B with its stiffness scales as the parameters.
pub type TwoTrackStiffnessModel<T> = StiffnessScales<TwoTrackEstimationModel<T>>;

/// Model B's settings (see [`StiffnessIdentificationConfig`]): `Q` and the initial prior over
/// `[β, r, ay]`, `R` over `[ay, r]`.
pub type TwoTrackIdentificationConfig = StiffnessIdentificationConfig<STATE_DIM, MEASUREMENT_DIM>;

impl<T: TyreModel> StiffnessScaled for TwoTrackEstimationModel<T> {
    fn stiffness_scales(&self) -> [f64; 2] {
        let vehicle = &self.vehicle().vehicle;
        [
            vehicle.cornering_stiffness_scale_front,
            vehicle.cornering_stiffness_scale_rear,
        ]
    }

    fn with_stiffness_scales(&self, scales: [f64; 2]) -> Result<Self, SettingsError> {
        let mut vehicle: TwoTrackLateralModel<T> = self.vehicle().clone();
        vehicle.vehicle.cornering_stiffness_scale_front = scales[0];
        vehicle.vehicle.cornering_stiffness_scale_rear = scales[1];
        // Built from diagonal Q and R (the constructor's only form): their diagonals rebuild
        // them exactly.
        TwoTrackEstimationModel::new(
            vehicle,
            self.sample_time(),
            self.integrator(),
            self.process_noise().diagonal().into(),
            self.measurement_noise().diagonal().into(),
        )
    }

    /// `y = [ay, r]` are states (001: eq 9).
    fn measurement_depends_on_scales(&self) -> bool {
        false
    }
}

/// The state model B starts from, read off a measurement row `[ay, r]`: no sideslip (the data
/// must start near straight driving; the prior's spread covers a small one), the measured yaw
/// rate and lateral acceleration.
pub fn initial_state_from_measurement(
    measurement: &[f64; MEASUREMENT_DIM],
) -> SVector<f64, STATE_DIM> {
    let mut state = SVector::<f64, STATE_DIM>::zeros();
    state[state_index::YAW_RATE] = measurement[measurement_index::YAW_RATE];
    state[state_index::LATERAL_ACCELERATION] = measurement[measurement_index::LATERAL_ACCELERATION];
    state
}

/// Identifies `[k_F, k_R]` of `vehicle` (model B's car and tyres; its own scales are ignored,
/// `config.start` is the start) by the accelerated EM ([`identify_scales`], 003: §3.1) from
/// rows of inputs `[steering_angle, vx, ax]` (`ax` 0 where not measured: the axle loads then
/// stay static) and measurements `[ay, r]` sampled every `config.sample_time` (a NaN
/// measurement entry is a missing value).
pub fn identify_two_track_scales_from_arrays<T: TyreModel + Sync>(
    vehicle: &TwoTrackLateralModel<T>,
    inputs: &[[f64; INPUT_DIM]],
    measurements: &[[f64; MEASUREMENT_DIM]],
    config: &TwoTrackIdentificationConfig,
) -> Result<EmResult<2>, CorneringIdentificationError> {
    debug_assert_eq!(input_index::LONGITUDINAL_ACCELERATION, 2);
    let (run, first) = checked_run(inputs, measurements, "[steering_angle, vx, ax]")?;
    let model = TwoTrackEstimationModel::new(
        vehicle.clone(),
        config.sample_time,
        config.integrator,
        config.process_noise_std.map(|std| std * std),
        config.measurement_noise_std.map(|std| std * std),
    )
    .map_err(CorneringIdentificationError::Settings)?;
    let start = TwoTrackStiffnessModel::new(model)
        .with_scales(&SVector::from(config.start))
        .map_err(CorneringIdentificationError::Settings)?;
    identify_scales(&start, &run, initial_state_from_measurement(&first), config)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identification::Parameterised;

    fn seed_model() -> TwoTrackEstimationModel {
        TwoTrackEstimationModel::seed_001(0.01).unwrap()
    }

    #[test]
    fn scales_are_the_parameters_and_act_on_the_transition_only() {
        let model = TwoTrackStiffnessModel::new(seed_model());
        assert_eq!(model.parameters(), SVector::<f64, 2>::new(1.0, 1.0));
        let scaled = model
            .with_parameters(&SVector::<f64, 2>::new(0.8, 1.2))
            .unwrap();
        assert_eq!(scaled.parameters(), SVector::<f64, 2>::new(0.8, 1.2));
        assert_eq!(scaled.process_noise(), model.process_noise());
        assert_eq!(scaled.measurement_noise(), model.measurement_noise());
        assert!(!scaled.measurement_depends_on_parameters());
        let state = SVector::<f64, STATE_DIM>::from([-0.01, 0.2, 3.5]);
        let input = SVector::<f64, INPUT_DIM>::from([0.03, 18.0, 0.0]);
        let unit = model
            .with_parameters(&SVector::<f64, 2>::new(1.0, 1.0))
            .unwrap();
        assert_eq!(
            unit.transition(&state, &input),
            seed_model().transition(&state, &input)
        );
        assert_ne!(
            scaled.transition(&state, &input),
            model.transition(&state, &input)
        );
        assert_eq!(
            scaled.measurement(&state, &input),
            model.measurement(&state, &input)
        );
        let error = model
            .with_scales(&SVector::<f64, 2>::new(1.0, 30.0))
            .unwrap_err();
        assert!(
            error.0.contains("cornering_stiffness_scale_rear"),
            "{}",
            error.0
        );
    }

    #[test]
    fn initial_state_is_read_off_the_measurement() {
        let state = initial_state_from_measurement(&[2.0, 0.1]);
        assert_eq!(state.as_slice(), &[0.0, 0.1, 2.0]);
    }
}
