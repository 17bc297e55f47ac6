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

use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::INPUT_DIM;
use vehicle_models::single_track::{MEASUREMENT_DIM, STATE_DIM};
use vehicle_models::{HsriTyre, SingleTrackModel, TyreModel};

/// Model A's vehicle as seed 000 gives it (the VehicleStateEstimator's defaults), re-exported so
/// that a caller of [`identify_scales_from_arrays`] needs no direct `vehicle-models` dependency.
pub use vehicle_models::SingleTrackHsri;

use vehicle_models::single_track::state_index;
use vehicle_models::Integrator;

use crate::identification::accelerated::{identify_accelerated, AccelerationConfig};
use crate::identification::{
    EmConfig, EmResult, EmSchedule, IdentificationError, LineSearchConfig, Parameterised,
};
use crate::kalman::SettingsError;
use crate::models::single_track::SingleTrackEstimationModel;
use crate::particle::{ParticleFilterConfig, RecordedRun};
use crate::StateSpaceModel;

/// Names of the entries of `p`, as the VehicleStateEstimator parameters are called.
pub const PARAMETER_NAMES: [&str; 2] = [
    "cornering_stiffness_scale_front",
    "cornering_stiffness_scale_rear",
];

/// Scale factors outside `[MIN_SCALE, MAX_SCALE]` are refused ([`Parameterised::with_parameters`]
/// answers `None`, the M-step treats them as impossible): a tyre with a twentieth or twenty
/// times the seed's stiffness is not a plausible explanation of any passenger-car data, and the
/// bounds keep the line search away from zero, where the lateral forces vanish.
pub const MIN_SCALE: f64 = 0.05;
pub const MAX_SCALE: f64 = 20.0;

/// Model A whose per-axle cornering-stiffness scales are the parameters; everything else (the
/// filter's sample time, integrator, `Q`, `R`) is that of the wrapped estimation model.
#[derive(Debug, Clone, PartialEq)]
pub struct CorneringStiffnessModel<T: TyreModel = HsriTyre> {
    model: SingleTrackEstimationModel<T>,
}

impl<T: TyreModel> CorneringStiffnessModel<T> {
    /// Wraps `model`; its vehicle's scales are the starting parameters.
    pub fn new(model: SingleTrackEstimationModel<T>) -> Self {
        Self { model }
    }

    /// The estimation model with the current scales (for building filters with them).
    pub fn model(&self) -> &SingleTrackEstimationModel<T> {
        &self.model
    }

    /// The same model with the scales `[k_F, k_R]`; an error names a scale outside
    /// `[MIN_SCALE, MAX_SCALE]` or a non-finite one.
    pub fn with_scales(&self, scales: &SVector<f64, 2>) -> Result<Self, SettingsError> {
        for (name, &scale) in PARAMETER_NAMES.iter().zip(scales.iter()) {
            if !(MIN_SCALE..=MAX_SCALE).contains(&scale) {
                return Err(SettingsError(format!(
                    "{name} = {scale}; expected a factor between {MIN_SCALE} and {MAX_SCALE}"
                )));
            }
        }
        let current = self.model.vehicle();
        let mut vehicle = current.vehicle.clone();
        vehicle.cornering_stiffness_scale_front = scales[0];
        vehicle.cornering_stiffness_scale_rear = scales[1];
        // The wrapped model was built from diagonal Q and R (its constructor's only form), so
        // their diagonals rebuild them exactly.
        let process = self.model.process_noise().diagonal();
        let measurement = self.model.measurement_noise().diagonal();
        let model = SingleTrackEstimationModel::new(
            SingleTrackModel::new(vehicle, current.tyre.clone()),
            self.model.sample_time(),
            self.model.integrator(),
            process.into(),
            measurement.into(),
        )?;
        Ok(Self { model })
    }
}

impl<T: TyreModel> StateSpaceModel<STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>
    for CorneringStiffnessModel<T>
{
    fn state_names(&self) -> [&'static str; STATE_DIM] {
        self.model.state_names()
    }

    fn measurement_names(&self) -> [&'static str; MEASUREMENT_DIM] {
        self.model.measurement_names()
    }

    fn transition(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SVector<f64, STATE_DIM> {
        self.model.transition(state, input)
    }

    fn transition_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        self.model.transition_jacobian(state, input)
    }

    fn transition_input_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, STATE_DIM, INPUT_DIM> {
        self.model.transition_input_jacobian(state, input)
    }

    fn measurement(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SVector<f64, MEASUREMENT_DIM> {
        self.model.measurement(state, input)
    }

    fn measurement_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, MEASUREMENT_DIM, STATE_DIM> {
        self.model.measurement_jacobian(state, input)
    }

    fn measurement_input_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, MEASUREMENT_DIM, INPUT_DIM> {
        self.model.measurement_input_jacobian(state, input)
    }

    fn process_noise(&self) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        self.model.process_noise()
    }

    fn measurement_noise(&self) -> SMatrix<f64, MEASUREMENT_DIM, MEASUREMENT_DIM> {
        self.model.measurement_noise()
    }
}

impl<T: TyreModel> Parameterised<2> for CorneringStiffnessModel<T> {
    fn parameter_names(&self) -> [&'static str; 2] {
        PARAMETER_NAMES
    }

    fn parameters(&self) -> SVector<f64, 2> {
        let vehicle = &self.model.vehicle().vehicle;
        SVector::<f64, 2>::new(
            vehicle.cornering_stiffness_scale_front,
            vehicle.cornering_stiffness_scale_rear,
        )
    }

    fn with_parameters(&self, parameters: &SVector<f64, 2>) -> Option<Self> {
        self.with_scales(parameters).ok()
    }

    /// `ay` is a tyre-force sum (000: 5.40): the measurement depends on the scales.
    fn measurement_depends_on_parameters(&self) -> bool {
        true
    }
}

/// Settings of [`identify_scales_from_arrays`]. The studies crate's model-mismatch study sets
/// them for its data (`harness::mismatch::identification_config`: a two-track Magic Formula car
/// seen through model A, sensors with the seed-001 scenarios' noise, 10 ms samples); the field
/// comments say what each choice trades.
#[derive(Debug, Clone, PartialEq)]
pub struct CorneringIdentificationConfig {
    /// Sample time of the data and of the model's step, s.
    pub sample_time: f64,
    pub integrator: Integrator,
    /// `Q = diag(std²)` per sample, `[vx, vy, r, ωF, ωR]`. It sets how much of the data the
    /// model must explain: the larger it is, the more a parameter error hides in the process
    /// noise (with 1e-2 m/s on vy the scales hardly move from 1), the smaller, the more the
    /// particle filter of the E-step degenerates (with 1e-3 m/s and 100 particles the EM drifts
    /// away from the likelihood optimum). The defaults (vy 2e-3 m/s, r 1e-3 rad/s per 10 ms)
    /// lead the EM to the optimum of the EKF's prediction-error likelihood on the same data
    /// (checked on a grid in the study) and are the `Q` the filters then run with.
    pub process_noise_std: [f64; STATE_DIM],
    /// `R = diag(std²)`, `[r, ay, ωF, ωR]`: the sensors' noise.
    pub measurement_noise_std: [f64; MEASUREMENT_DIM],
    /// Starting scales `[k_F, k_R]`.
    pub start: [f64; 2],
    /// Standard deviations of the prior around the initial state derived from the first
    /// complete measurement row (see [`initial_state_from_measurement`]).
    pub initial_std: [f64; STATE_DIM],
    /// The E-step's particle filter (count, resampling, seed: common random numbers; proposal).
    pub filter: ParticleFilterConfig,
    /// Stop when a SQUAREM cycle changes no scale by more than this fraction. The particle
    /// E-step makes the EM path jitter by about 0.3 % per cycle with 100 particles (common
    /// random numbers fix the map, not its roughness), so a tighter tolerance only waits for a
    /// lucky cycle.
    pub tolerance: f64,
    /// Most SQUAREM cycles (three E-steps each).
    pub max_cycles: usize,
    /// Powell sweeps of each M-step.
    pub max_sweeps: usize,
    pub acceleration: AccelerationConfig,
}

/// Why the scales cannot be identified from the given data.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CorneringIdentificationError {
    #[error("data: {0}")]
    Data(String),
    #[error("model: {}", .0.0)]
    Settings(SettingsError),
    #[error(transparent)]
    Identification(#[from] IdentificationError),
}

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
/// ([`identify_accelerated`], 003: §3.1) from rows of driver inputs
/// `[steering_angle, drive_torque, brake_torque]` and measurements `[r, ay, ωF, ωR]` sampled
/// every `config.sample_time` (row `k` of both at `t0 + k T`; a NaN measurement entry is a
/// missing value, the filter skips that row).
pub fn identify_scales_from_arrays<T: TyreModel>(
    vehicle: &SingleTrackModel<T>,
    inputs: &[[f64; INPUT_DIM]],
    measurements: &[[f64; MEASUREMENT_DIM]],
    config: &CorneringIdentificationConfig,
) -> Result<EmResult<2>, CorneringIdentificationError> {
    let (run, first_complete) = RecordedRun::from_checked_rows(
        inputs,
        measurements,
        "[steering_angle, drive_torque, brake_torque]",
    )
    .map_err(CorneringIdentificationError::Data)?;
    let Some(first) = first_complete.map(|k| &measurements[k]) else {
        return Err(CorneringIdentificationError::Data(String::from(
            "no measurement row is complete; the initial state is read off the first complete row",
        )));
    };
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
    let initial_std = SVector::from(config.initial_std);
    let em = EmConfig {
        filter: config.filter,
        initial_state: initial_state_from_measurement(vehicle, first),
        initial_covariance: SMatrix::from_diagonal(&initial_std.component_mul(&initial_std)),
        tolerance: config.tolerance,
        max_iterations: config.max_cycles,
        line_search: LineSearchConfig::default(),
        fresh_random_numbers: false,
        schedule: EmSchedule::FullMaximisation {
            max_sweeps: config.max_sweeps,
        },
    };
    Ok(identify_accelerated(
        &start,
        &run,
        &em,
        &config.acceleration,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

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
