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
use crate::particle::{
    ParticleFilterConfig, Proposal, RecordedRun, ResamplingPolicy, ResamplingScheme,
};
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

/// Settings of [`identify_scales_from_arrays`]. The defaults are those of the harness's
/// model-mismatch study (a two-track Magic Formula car seen through model A, sensors with the
/// seed-001 scenarios' noise, 10 ms samples).
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
    /// The E-step's particle filter (count, resampling, seed: common random numbers).
    pub filter: ParticleFilterConfig,
    pub proposal: Proposal,
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

impl Default for CorneringIdentificationConfig {
    fn default() -> Self {
        Self {
            sample_time: 0.01,
            integrator: Integrator::SemiImplicitEuler,
            process_noise_std: [1e-3, 2e-3, 1e-3, 1e-2, 1e-2],
            measurement_noise_std: [0.002, 0.05, 0.02, 0.02],
            start: [1.0, 1.0],
            initial_std: [0.1, 0.05, 0.01, 0.1, 0.1],
            // 100 particles: the E-step's smoothed weights keep an effective sample size of
            // about 10 on the study's manoeuvre; with 50 the EM path jitters by about 0.005.
            filter: ParticleFilterConfig {
                particle_count: 100,
                scheme: ResamplingScheme::Stratified,
                policy: ResamplingPolicy::EffectiveSampleSizeBelow(0.5),
                seed: 1,
            },
            // The bootstrap filter degenerates with R this much tighter than Q on ay (see
            // the seed-003 reproduction, `harness::seed003`, for the same choice).
            proposal: Proposal::LinearisedOptimal,
            tolerance: 3e-3,
            max_cycles: 20,
            max_sweeps: 3,
            acceleration: AccelerationConfig::default(),
        }
    }
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
    state[state_index::VX] = measurement[y::OMEGA_REAR] * vehicle.vehicle.chassis.wheel_radius;
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
        proposal: config.proposal,
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
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};
    use vehicle_models::reference::{ReferenceModelKind, ReferenceVehicle, ReferenceVehicleParams};
    use vehicle_models::{DriverInputVector, SingleTrackParams};

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

    /// Rows `[r, ay, ωF, ωR]` every 10 ms of a reference vehicle integrated with the
    /// estimation model's own 10 ms step (the model structure is exact), with the default
    /// configuration's sensor noise, under a two-sine steer.
    fn simulate(params: &ReferenceVehicleParams, seconds: f64) -> (Vec<[f64; 3]>, Vec<[f64; 4]>) {
        let dt = 0.01;
        let noise = CorneringIdentificationConfig::default().measurement_noise_std;
        let mut vehicle = ReferenceVehicle::new(params, 20.0);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (mut inputs, mut measurements) = (Vec::new(), Vec::new());
        for k in 0..(seconds / dt).round() as usize {
            let t = k as f64 * dt;
            // Two frequencies: the slow one for the stationary balance of the axles, the quick
            // one for the yaw and sideslip dynamics that set their level.
            let phase = std::f64::consts::TAU * (t - 0.5).max(0.0);
            let steer = 0.03 * (0.5 * phase).sin() + 0.015 * (1.7 * phase).sin();
            let input = DriverInputVector::new(steer, 0.0, 0.0);
            let truth = vehicle.truth(&input);
            let clean = [
                truth.yaw_rate,
                truth.lateral_acceleration,
                truth.omega_front,
                truth.omega_rear,
            ];
            measurements.push(core::array::from_fn(|i| {
                let draw: f64 = StandardNormal.sample(&mut rng);
                clean[i] + noise[i] * draw
            }));
            inputs.push([input[0], input[1], input[2]]);
            vehicle.step(&input, dt).unwrap();
        }
        (inputs, measurements)
    }

    /// Data of model A itself with softer front and stiffer rear tyres: the EM finds its scales
    /// back from 1/1.
    #[test]
    fn identifies_the_scales_of_a_model_a_car() {
        let truth = [0.85, 1.1];
        let params = ReferenceVehicleParams {
            model: ReferenceModelKind::SingleTrack,
            single_track: SingleTrackParams {
                cornering_stiffness_scale_front: truth[0],
                cornering_stiffness_scale_rear: truth[1],
                ..SingleTrackParams::default()
            },
            ..ReferenceVehicleParams::default()
        };
        let (inputs, measurements) = simulate(&params, 4.0);
        let config = CorneringIdentificationConfig {
            filter: ParticleFilterConfig {
                particle_count: 50,
                ..CorneringIdentificationConfig::default().filter
            },
            ..CorneringIdentificationConfig::default()
        };
        let result = identify_scales_from_arrays(
            &vehicle_models::SingleTrackHsri::default(),
            &inputs,
            &measurements,
            &config,
        )
        .unwrap();
        assert_eq!(result.parameter_names, PARAMETER_NAMES);
        assert_eq!(result.iterations[0], SVector::<f64, 2>::new(1.0, 1.0));
        // 4 s of data fix the balance of the axles (kF/kR, the stationary understeer) better
        // than their common level, which only the transient yaw dynamics show: within 2 % and
        // 5 % here (measured: 1.3 % and 1.8 % / 3.2 %).
        let (identified, path) = (result.parameters, &result.iterations);
        assert!(result.converged, "{path:?}");
        let balance = identified[0] / identified[1] / (truth[0] / truth[1]);
        assert!(
            (balance - 1.0).abs() < 0.02,
            "{identified:?}, path {path:?}"
        );
        for (value, truth) in identified.iter().zip(truth) {
            assert!(
                (value / truth - 1.0).abs() < 0.05,
                "{identified:?}, path {path:?}"
            );
        }
    }

    #[test]
    fn bad_data_is_named() {
        let vehicle = vehicle_models::SingleTrackHsri::default();
        let config = CorneringIdentificationConfig::default();
        let row = [0.0, 0.0, 60.0, 60.0];
        let error = |inputs: &[[f64; 3]], measurements: &[[f64; 4]]| {
            identify_scales_from_arrays(&vehicle, inputs, measurements, &config)
                .unwrap_err()
                .to_string()
        };
        assert!(error(&[[0.0; 3]], &[row, row]).contains("1 rows but measurements has 2"));
        assert!(error(&[[f64::NAN, 0.0, 0.0]], &[row]).contains("input row 0"));
        assert!(error(&[[0.0; 3]; 2], &[row, [f64::INFINITY; 4]]).contains("measurement row 1"));
        assert!(error(&[[0.0; 3]], &[[f64::NAN; 4]]).contains("no measurement row is complete"));
        let too_short = identify_scales_from_arrays(&vehicle, &[[0.0; 3]], &[row], &config);
        assert!(too_short
            .unwrap_err()
            .to_string()
            .contains("at least two samples"));
        let bad_start = CorneringIdentificationConfig {
            start: [0.0, 1.0],
            ..CorneringIdentificationConfig::default()
        };
        let error = identify_scales_from_arrays(&vehicle, &[[0.0; 3]; 2], &[row; 2], &bad_start)
            .unwrap_err();
        assert!(
            error
                .to_string()
                .contains("cornering_stiffness_scale_front = 0"),
            "{error}"
        );
    }

    #[test]
    fn initial_state_is_read_off_the_measurement() {
        let vehicle = vehicle_models::SingleTrackHsri::default();
        let state = initial_state_from_measurement(&vehicle, &[0.1, 2.0, 61.0, 60.0]);
        assert_eq!(state.as_slice(), &[18.0, 0.0, 0.1, 61.0, 60.0]);
    }
}
