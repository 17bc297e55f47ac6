//! What the EM identification of the per-axle cornering-stiffness scales `[k_F, k_R]` shares
//! between the estimator models (model A: [`super::single_track_identification`], model B:
//! [`super::two_track_identification`]): the parameters' names and range, the settings, the
//! errors and the run of the accelerated EM (003: §3.1) from a start model and an initial state.

use nalgebra::{SMatrix, SVector};
use vehicle_models::Integrator;

use crate::identification::accelerated::{identify_accelerated, AccelerationConfig};
use crate::identification::{
    EmConfig, EmResult, EmSchedule, IdentificationError, LineSearchConfig, Parameterised,
};
use crate::kalman::SettingsError;
use crate::particle::{ParticleFilterConfig, Proposal, RecordedRun};
use crate::StateSpaceModel;

/// Names of the entries of `p`, as the VehicleStateEstimator parameters are called (both models
/// read them as factors on the HSRI cornering stiffness at the axle's load, 000: 5.70).
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

/// `scales` if every one is within `[MIN_SCALE, MAX_SCALE]`; else an error naming the first
/// that is not.
pub fn check_scales(scales: &SVector<f64, 2>) -> Result<(), SettingsError> {
    for (name, &scale) in PARAMETER_NAMES.iter().zip(scales.iter()) {
        if !(MIN_SCALE..=MAX_SCALE).contains(&scale) {
            return Err(SettingsError(format!(
                "{name} = {scale}; expected a factor between {MIN_SCALE} and {MAX_SCALE}"
            )));
        }
    }
    Ok(())
}

/// An estimation model whose per-axle cornering-stiffness scales can be read and replaced:
/// what [`StiffnessScales`] needs to make them the EM's parameters.
pub trait StiffnessScaled: Sized {
    /// `[k_F, k_R]` of the model's vehicle.
    fn stiffness_scales(&self) -> [f64; 2];
    /// The same model (sample time, integrator, `Q`, `R`) with other scales, already checked
    /// to lie within `[MIN_SCALE, MAX_SCALE]`.
    fn with_stiffness_scales(&self, scales: [f64; 2]) -> Result<Self, SettingsError>;
    /// Whether the measurement function depends on the scales (then `I_3`, 003: 2.78, enters
    /// the M-step).
    fn measurement_depends_on_scales(&self) -> bool;
}

/// An estimation model with its per-axle cornering-stiffness scales as the EM's parameters
/// (`p = [k_F, k_R]`, [`Parameterised<2>`]); everything else is the wrapped model's.
#[derive(Debug, Clone, PartialEq)]
pub struct StiffnessScales<Inner> {
    model: Inner,
}

impl<Inner: StiffnessScaled> StiffnessScales<Inner> {
    /// Wraps `model`; its vehicle's scales are the starting parameters.
    pub fn new(model: Inner) -> Self {
        Self { model }
    }

    /// The estimation model with the current scales (for building filters with them).
    pub fn model(&self) -> &Inner {
        &self.model
    }

    /// The same model with the scales `[k_F, k_R]`; an error names a scale outside
    /// `[MIN_SCALE, MAX_SCALE]` or a non-finite one.
    pub fn with_scales(&self, scales: &SVector<f64, 2>) -> Result<Self, SettingsError> {
        check_scales(scales)?;
        Ok(Self {
            model: self.model.with_stiffness_scales([scales[0], scales[1]])?,
        })
    }
}

impl<Inner: StiffnessScaled> Parameterised<2> for StiffnessScales<Inner> {
    fn parameter_names(&self) -> [&'static str; 2] {
        PARAMETER_NAMES
    }

    fn parameters(&self) -> SVector<f64, 2> {
        SVector::from(self.model.stiffness_scales())
    }

    fn with_parameters(&self, parameters: &SVector<f64, 2>) -> Option<Self> {
        self.with_scales(parameters).ok()
    }

    fn measurement_depends_on_parameters(&self) -> bool {
        self.model.measurement_depends_on_scales()
    }
}

impl<Inner, const N: usize, const M: usize, const U: usize> StateSpaceModel<N, M, U>
    for StiffnessScales<Inner>
where
    Inner: StateSpaceModel<N, M, U>,
{
    fn state_names(&self) -> [&'static str; N] {
        self.model.state_names()
    }

    fn measurement_names(&self) -> [&'static str; M] {
        self.model.measurement_names()
    }

    fn transition(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, N> {
        self.model.transition(state, input)
    }

    fn transition_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, N, N> {
        self.model.transition_jacobian(state, input)
    }

    fn transition_and_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        self.model.transition_and_jacobian(state, input)
    }

    fn transition_input_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, N, U> {
        self.model.transition_input_jacobian(state, input)
    }

    fn measurement(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, M> {
        self.model.measurement(state, input)
    }

    fn measurement_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, M, N> {
        self.model.measurement_jacobian(state, input)
    }

    fn measurement_and_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> (SVector<f64, M>, SMatrix<f64, M, N>) {
        self.model.measurement_and_jacobian(state, input)
    }

    fn measurement_input_jacobian(
        &self,
        state: &SVector<f64, N>,
        input: &SVector<f64, U>,
    ) -> SMatrix<f64, M, U> {
        self.model.measurement_input_jacobian(state, input)
    }

    fn process_noise(&self) -> SMatrix<f64, N, N> {
        self.model.process_noise()
    }

    fn measurement_noise(&self) -> SMatrix<f64, M, M> {
        self.model.measurement_noise()
    }
}

/// Settings of the identification on a model with `N` states and `M` measurements. The studies
/// crate's model-mismatch study sets them for model A on its data
/// (`harness::mismatch::identification_config`: a two-track Magic Formula car seen through
/// model A, sensors with the seed-001 scenarios' noise, 10 ms samples), `harness fit` for both
/// models on a log; the field comments say what each choice trades.
#[derive(Debug, Clone, PartialEq)]
pub struct StiffnessIdentificationConfig<const N: usize, const M: usize> {
    /// Sample time of the data and of the model's step, s.
    pub sample_time: f64,
    pub integrator: Integrator,
    /// `Q = diag(std²)` per sample, in the model's state order. It sets how much of the data
    /// the model must explain: the larger it is, the more a parameter error hides in the
    /// process noise (model A: with 1e-2 m/s on vy the scales hardly move from 1), the
    /// smaller, the more the particle filter of the E-step degenerates (model A: with 1e-3 m/s
    /// and 100 particles the EM drifts away from the likelihood optimum). Model A's (vy 2e-3
    /// m/s, r 1e-3 rad/s per 10 ms) lead the EM to the optimum of the EKF's prediction-error
    /// likelihood on the same data (checked on a grid in the study) and are the `Q` the
    /// filters then run with.
    pub process_noise_std: [f64; N],
    /// `R = diag(std²)`, in the model's measurement order: the sensors' noise.
    pub measurement_noise_std: [f64; M],
    /// Starting scales `[k_F, k_R]`.
    pub start: [f64; 2],
    /// Standard deviations of the prior around the initial state the model reads off the first
    /// complete measurement row.
    pub initial_std: [f64; N],
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

/// Checks the rows and finds the first complete measurement row, from which the model reads its
/// initial state (`input_meaning` names the input columns in a message).
pub fn checked_run<const M: usize, const U: usize>(
    inputs: &[[f64; U]],
    measurements: &[[f64; M]],
    input_meaning: &str,
) -> Result<(RecordedRun<M, U>, [f64; M]), CorneringIdentificationError> {
    let (run, first_complete) = RecordedRun::from_checked_rows(inputs, measurements, input_meaning)
        .map_err(CorneringIdentificationError::Data)?;
    match first_complete {
        Some(k) => Ok((run, measurements[k])),
        None => Err(CorneringIdentificationError::Data(String::from(
            "no measurement row is complete; the initial state is read off the first complete row",
        ))),
    }
}

/// `[k_F, k_R]` by the accelerated EM ([`identify_accelerated`], 003: §3.1) from `start` (the
/// model with the starting scales) on `run`, the state starting at `initial_state` with the
/// prior `config.initial_std`.
pub fn identify_scales<Model, const N: usize, const M: usize, const U: usize>(
    start: &Model,
    run: &RecordedRun<M, U>,
    initial_state: SVector<f64, N>,
    config: &StiffnessIdentificationConfig<N, M>,
) -> Result<EmResult<2>, CorneringIdentificationError>
where
    Model: StateSpaceModel<N, M, U> + Parameterised<2> + Clone + Sync,
{
    let initial_std = SVector::from(config.initial_std);
    let em = EmConfig {
        filter: config.filter,
        proposal: config.proposal,
        initial_state,
        initial_covariance: SMatrix::from_diagonal(&initial_std.component_mul(&initial_std)),
        tolerance: config.tolerance,
        max_iterations: config.max_cycles,
        line_search: LineSearchConfig::default(),
        fresh_random_numbers: false,
        schedule: EmSchedule::FullMaximisation {
            max_sweeps: config.max_sweeps,
        },
    };
    Ok(identify_accelerated(start, run, &em, &config.acceleration)?)
}
