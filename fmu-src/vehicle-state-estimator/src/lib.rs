//! FMU **VehicleStateEstimator**: a recursive state estimator for planar vehicle dynamics as an
//! FMI 2.0 Co-Simulation FMU (modelIdentifier `VehicleStateEstimator`).
//!
//! The interface is modelDescription/VehicleStateEstimator.xml; value references, GUID and start
//! values are generated from it at build time. The filters come from the `estimation` crate:
//! LKF, EKF, UKF (2n and scaled 2n+1 sigma points) and the Luenberger observer through
//! `KalmanEstimator`, the SIR particle filter through `ParticleFilter`, on model A (the 5-state
//! single-track model with HSRI tyres of seed 000, `SingleTrackEstimationModel`) or model B.
//!
//! **Timing** (see the `sample_time` description in the XML): sample `k` lies at `t0 + k T`.
//! A doStep from `t` to `t + h` processes every sample with `t <= t0 + k T < t + h`: the
//! measurement update with the sensor inputs as set for this doStep (they are the samples at
//! `t`), then the time update with the driver inputs (000: 4.64-4.75 order: predict with `u(k)`
//! to `k + 1`). The outputs hold the resulting one-step prediction, the estimate for the next
//! sample instant from the measurements up to now; this is the time-consistent choice in a
//! co-simulation, where the measurement at `t + h` is not known before the step ends. Outputs
//! are held through doSteps without a sample.
//!
//! **Robustness.** A non-finite sensor input skips that measurement row (status bit 1); a
//! non-finite driver input keeps its last finite value (bit 64); when the speed estimate is
//! below `min_speed` the filter is re-seeded from the wheel speeds if they show a higher speed
//! (bits 32 + 8), else it holds (bit 32); filter repairs are reported in bits 2, 4, 8, 16; no
//! output is ever NaN.
//!
//! **Model B** (`model = 2`): the 3-state seed-001 form `x = [sideslip, yaw_rate, ay]` with
//! `u = [steering_angle, vx]` and `y = [ay_meas, yaw_rate_meas]` (001: eqs 6-11,
//! `TwoTrackEstimationModel`), the same car with Magic Formula tyres matched to the HSRI
//! parameters. LKF (seed 001's linear single-track comparison filter about straight driving at
//! `lkf_vx`), EKF, both UKFs and the particle filter run on it; the Luenberger observer has no
//! design for it (seed 002 covers model A only) and is refused at initialisation. The speed input
//! is `vx_meas`, else `wheel_radius` times the mean wheel speed; without either above
//! `min_speed` the filter holds (bit 32). Outputs: vx_est = the speed input, vy_est =
//! vx·tan(sideslip), wheel speeds passed through, stds as the XML states.
#![allow(non_snake_case)] // the crate is named after the modelIdentifier

use estimation::kalman::{
    EstimatorKind, InitialEstimate, KalmanEstimator, SettingsError, SigmaPoints,
};
use estimation::models::single_track::SingleTrackEstimationModel;
use estimation::models::two_track::{two_track_kind, TwoTrackEstimationModel};
use estimation::particle::{
    ParticleFilter, ParticleFilterConfig, ParticleFilterSnapshot, ResamplingPolicy,
    ResamplingScheme,
};
use estimation::{Estimator, FilterIssue};
use fmi_export::{
    CoSimulationModel, InstantiationContext, StateError, StateReader, StateWriter, StepOutcome,
};
use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::INPUT_DIM;
use vehicle_models::single_track::{state_index, SingleTrackParams, MEASUREMENT_DIM, STATE_DIM};
use vehicle_models::two_track_lateral as model_b;
use vehicle_models::tyre::{HsriParams, MagicFormulaParams};
use vehicle_models::{
    HsriTyre, Integrator, MagicFormulaTyre, SingleTrackModel, TwoTrackLateralModel, TwoTrackParams,
};

/// Generated from modelDescription/VehicleStateEstimator.xml.
pub mod model_description {
    include!(concat!(env!("OUT_DIR"), "/model_description.rs"));
}

use model_description::{
    estimator_kind, estimator_model, integrator as integrator_items, particle_resampling, Variables,
};

/// Bits of the `status` output (see its description in the XML).
pub mod status {
    pub const ROW_SKIPPED: i32 = 1;
    pub const COVARIANCE_REPAIRED: i32 = 2;
    pub const UPDATE_SKIPPED: i32 = 4;
    pub const STATE_RESET: i32 = 8;
    pub const WEIGHTS_RESET: i32 = 16;
    pub const BELOW_MIN_SPEED: i32 = 32;
    pub const INPUT_HELD: i32 = 64;
}

fn issue_bit(issue: FilterIssue) -> i32 {
    match issue {
        FilterIssue::CovarianceRepaired => status::COVARIANCE_REPAIRED,
        FilterIssue::UpdateSkipped => status::UPDATE_SKIPPED,
        FilterIssue::StateReset => status::STATE_RESET,
        FilterIssue::WeightsReset => status::WEIGHTS_RESET,
    }
}

/// Model A as the filters see it.
pub type ModelA = SingleTrackEstimationModel<HsriTyre>;
type StateA = SVector<f64, STATE_DIM>;
type CovarianceA = SMatrix<f64, STATE_DIM, STATE_DIM>;
type InputVector = SVector<f64, INPUT_DIM>;
type MeasurementA = SVector<f64, MEASUREMENT_DIM>;

/// The running filter on model A.
#[derive(Clone, Debug)]
pub enum FilterA {
    Kalman(KalmanEstimator<ModelA, STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>),
    Particle(ParticleFilter<ModelA, STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>),
}

impl FilterA {
    pub fn estimator(&self) -> &dyn Estimator<STATE_DIM, MEASUREMENT_DIM, INPUT_DIM> {
        match self {
            FilterA::Kalman(filter) => filter,
            FilterA::Particle(filter) => filter,
        }
    }

    pub fn estimator_mut(&mut self) -> &mut dyn Estimator<STATE_DIM, MEASUREMENT_DIM, INPUT_DIM> {
        match self {
            FilterA::Kalman(filter) => filter,
            FilterA::Particle(filter) => filter,
        }
    }
}

fn positive(name: &str, value: f64) -> Result<f64, String> {
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(format!(
            "parameter {name} = {value}; expected a positive number"
        ))
    }
}

fn settings(error: SettingsError) -> String {
    format!("estimator set-up: {}", error.0)
}

/// Builds model A from the vehicle, tyre and noise parameters.
pub fn model_a(v: &Variables) -> Result<ModelA, String> {
    let vehicle = SingleTrackParams {
        mass: positive("mass", v.mass)?,
        cog_to_front_axle: positive("cog_to_front_axle", v.cog_to_front_axle)?,
        cog_to_rear_axle: positive("cog_to_rear_axle", v.cog_to_rear_axle)?,
        yaw_inertia: positive("yaw_inertia", v.yaw_inertia)?,
        front_wheel_inertia: positive("wheel_inertia_front", v.wheel_inertia_front)?,
        rear_wheel_inertia: positive("wheel_inertia_rear", v.wheel_inertia_rear)?,
        brake_split_front: v.brake_distribution_front,
        wheel_radius: positive("wheel_radius", v.wheel_radius)?,
        front_wheel_load: positive("wheel_load_front", v.wheel_load_front)?,
        rear_wheel_load: positive("wheel_load_rear", v.wheel_load_rear)?,
        // Beyond the seeds: per-axle factors on Cα (000: 5.70), 1 = the seed's model A.
        cornering_stiffness_scale_front: positive(
            "cornering_stiffness_scale_front",
            v.cornering_stiffness_scale_front,
        )?,
        cornering_stiffness_scale_rear: positive(
            "cornering_stiffness_scale_rear",
            v.cornering_stiffness_scale_rear,
        )?,
        ..SingleTrackParams::default()
    };
    let tyre = HsriTyre::new(hsri_params(v)?);
    let integrator = integrator(v)?;
    // Q = diag(std²) per sample, R = diag(std²) (000: ch. 7 uses Q = diag(w²), R = diag(v²)).
    let process = [
        positive("process_noise_std_vx", v.process_noise_std_vx)?,
        positive("process_noise_std_vy", v.process_noise_std_vy)?,
        positive("process_noise_std_yaw_rate", v.process_noise_std_yaw_rate)?,
        positive(
            "process_noise_std_omega_front",
            v.process_noise_std_omega_front,
        )?,
        positive(
            "process_noise_std_omega_rear",
            v.process_noise_std_omega_rear,
        )?,
    ];
    let measurement = [
        positive(
            "measurement_noise_std_yaw_rate",
            v.measurement_noise_std_yaw_rate,
        )?,
        positive("measurement_noise_std_ay", v.measurement_noise_std_ay)?,
        positive(
            "measurement_noise_std_omega_front",
            v.measurement_noise_std_omega_front,
        )?,
        positive(
            "measurement_noise_std_omega_rear",
            v.measurement_noise_std_omega_rear,
        )?,
    ];
    SingleTrackEstimationModel::new(
        SingleTrackModel::new(vehicle, tyre),
        positive("sample_time", v.sample_time)?,
        integrator,
        process.map(|std| std * std),
        measurement.map(|std| std * std),
    )
    .map_err(settings)
}

/// The initial estimate of model A from the parameters.
pub fn initial_estimate_a(v: &Variables) -> Result<InitialEstimate<STATE_DIM>, String> {
    let stds = [
        positive("initial_std_vx", v.initial_std_vx)?,
        positive("initial_std_vy", v.initial_std_vy)?,
        positive("initial_std_yaw_rate", v.initial_std_yaw_rate)?,
        positive("initial_std_omega_front", v.initial_std_omega_front)?,
        positive("initial_std_omega_rear", v.initial_std_omega_rear)?,
    ];
    Ok(InitialEstimate::diagonal(
        StateA::from([
            v.vx_initial,
            v.vy_initial,
            v.yaw_rate_initial,
            v.omega_front_initial,
            v.omega_rear_initial,
        ]),
        StateA::from(stds.map(|std| std * std)),
    ))
}

/// Layout of the particle-filter block of an FMU state; a state written with another layout is
/// refused by name instead of being misread.
const PARTICLE_STATE_LAYOUT: u8 = 1;

/// Appends a particle filter's running state (see [`ParticleFilterSnapshot`]) to an FMU state,
/// compactly: ancestors as u32 (particle_count is at most 100000, XML), the propagated means
/// only while the optimal proposal's noise draw is pending (otherwise the filter never reads
/// them before overwriting them).
fn write_particles<const N: usize>(writer: &mut StateWriter, snapshot: &ParticleFilterSnapshot<N>) {
    writer.u8(PARTICLE_STATE_LAYOUT);
    writer.bytes(&snapshot.rng_seed);
    writer.u64(snapshot.rng_stream);
    writer.u64(snapshot.rng_word_pos as u64);
    writer.u64((snapshot.rng_word_pos >> 64) as u64);
    let flat = |vectors: &[SVector<f64, N>]| -> Vec<f64> {
        vectors.iter().flat_map(|v| v.iter().copied()).collect()
    };
    writer.f64s(&flat(&snapshot.particles));
    writer.f64s(&snapshot.log_weights);
    writer.f64s(&snapshot.weights);
    writer.u64(snapshot.ancestors.len() as u64);
    for &ancestor in &snapshot.ancestors {
        writer.u32(ancestor as u32);
    }
    writer.bool(snapshot.noise_pending);
    if snapshot.noise_pending {
        writer.f64s(&flat(&snapshot.predicted_means));
    }
    writer.f64s(snapshot.estimate.as_slice());
    writer.f64s(snapshot.covariance.as_slice());
    writer.f64(snapshot.effective_sample_size);
    writer.bool(snapshot.resampled_in_last_update);
}

/// Reads what [`write_particles`] wrote into `filter` (built from the same parameters); sizes
/// are checked against the filter's particle count before anything is allocated for them.
fn restore_particles<Model, const N: usize, const M: usize, const U: usize>(
    reader: &mut StateReader<'_>,
    filter: &mut ParticleFilter<Model, N, M, U>,
) -> Result<(), StateError>
where
    Model: estimation::StateSpaceModel<N, M, U>,
{
    let layout = reader.u8("particle state layout")?;
    if layout != PARTICLE_STATE_LAYOUT {
        return Err(StateError::new(format!(
            "particle filter state layout {layout}; expected {PARTICLE_STATE_LAYOUT}"
        )));
    }
    let count = filter.config().particle_count;
    let seed: [u8; 32] = reader
        .bytes("particle filter random seed")?
        .try_into()
        .map_err(|_| StateError::new("'particle filter random seed' must be 32 bytes"))?;
    let stream = reader.u64("particle filter random stream")?;
    let word_low = reader.u64("particle filter random position")?;
    let word_high = reader.u64("particle filter random position")?;
    let vectors = |values: Vec<f64>| -> Vec<SVector<f64, N>> {
        values
            .chunks_exact(N)
            .map(SVector::from_column_slice)
            .collect()
    };
    let particles = vectors(reader.f64s("particles", count * N)?);
    let log_weights = reader.f64s("particle log weights", count)?;
    let weights = reader.f64s("particle weights", count)?;
    let ancestor_count = reader.u64("particle ancestors")?;
    if ancestor_count != count as u64 {
        return Err(StateError::new(format!(
            "'particle ancestors' has {ancestor_count} entries; expected {count} (particle_count)"
        )));
    }
    let ancestors = (0..count)
        .map(|_| reader.u32("particle ancestors").map(|a| a as usize))
        .collect::<Result<Vec<_>, _>>()?;
    let noise_pending = reader.bool("particle noise pending")?;
    let predicted_means = if noise_pending {
        vectors(reader.f64s("particle predictions", count * N)?)
    } else {
        // Not read before the next propagation overwrites them: keep the filter's own.
        filter.snapshot().predicted_means
    };
    let mut estimate = SVector::<f64, N>::zeros();
    reader.f64s_into(estimate.as_mut_slice(), "particle estimate")?;
    let mut covariance = SMatrix::<f64, N, N>::zeros();
    reader.f64s_into(covariance.as_mut_slice(), "particle covariance")?;
    let snapshot = ParticleFilterSnapshot {
        rng_seed: seed,
        rng_stream: stream,
        rng_word_pos: u128::from(word_low) | (u128::from(word_high) << 64),
        particles,
        log_weights,
        weights,
        ancestors,
        predicted_means,
        noise_pending,
        estimate,
        covariance,
        effective_sample_size: reader.f64("particle effective sample size")?,
        resampled_in_last_update: reader.bool("particle resampled flag")?,
    };
    filter
        .restore(&snapshot)
        .map_err(|e| StateError::new(format!("particle filter state: {e}")))
}

/// Builds the filter selected by `estimator` on model A, starting from `initial`.
pub fn filter_a(
    v: &Variables,
    model: ModelA,
    initial: &InitialEstimate<STATE_DIM>,
) -> Result<FilterA, String> {
    // The LKF/Luenberger operating point: straight driving, zero inputs (000: 5.58-5.62).
    let operating_state = StateA::from([
        v.lkf_vx,
        v.lkf_vy,
        v.lkf_yaw_rate,
        v.lkf_omega_front,
        v.lkf_omega_rear,
    ]);
    let operating_input = InputVector::zeros();
    let kind = match v.estimator {
        estimator_kind::LKF => EstimatorKind::Linear {
            operating_state,
            operating_input,
        },
        estimator_kind::EKF => EstimatorKind::Extended,
        estimator_kind::UKF => EstimatorKind::Unscented(SigmaPoints::Symmetric),
        estimator_kind::UKF_SCALED => {
            EstimatorKind::Unscented(SigmaPoints::scaled(v.ukf_alpha, v.ukf_beta, v.ukf_kappa))
        }
        estimator_kind::LUENBERGER => EstimatorKind::Luenberger {
            operating_state,
            operating_input,
            design: model.default_observer_design(),
        },
        estimator_kind::PARTICLE_FILTER => {
            let config = particle_config(v)?;
            return ParticleFilter::new(model, config, initial.state, initial.covariance)
                .map(FilterA::Particle)
                .map_err(|error| format!("particle filter set-up: {error}"));
        }
        other => return Err(format!("parameter estimator = {other}; expected 1 to 6")),
    };
    KalmanEstimator::build(model, &kind, initial)
        .map(FilterA::Kalman)
        .map_err(settings)
}

/// Model B (the 3-state form of seed 001, `x = [sideslip, yaw_rate, ay]`, `u = [steering_angle,
/// vx]`, `y = [ay, yaw_rate]`) as the filters see it.
pub type ModelB = TwoTrackEstimationModel<MagicFormulaTyre>;
type StateB = SVector<f64, { model_b::STATE_DIM }>;
type CovarianceB = SMatrix<f64, { model_b::STATE_DIM }, { model_b::STATE_DIM }>;
type InputB = SVector<f64, { model_b::INPUT_DIM }>;
type MeasurementB = SVector<f64, { model_b::MEASUREMENT_DIM }>;

/// The running filter on model B.
// One per instance, built at initialisation: the size difference costs nothing per step.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum FilterB {
    Kalman(
        KalmanEstimator<
            ModelB,
            { model_b::STATE_DIM },
            { model_b::MEASUREMENT_DIM },
            { model_b::INPUT_DIM },
        >,
    ),
    Particle(
        ParticleFilter<
            ModelB,
            { model_b::STATE_DIM },
            { model_b::MEASUREMENT_DIM },
            { model_b::INPUT_DIM },
        >,
    ),
}

impl FilterB {
    pub fn estimator(
        &self,
    ) -> &dyn Estimator<{ model_b::STATE_DIM }, { model_b::MEASUREMENT_DIM }, { model_b::INPUT_DIM }>
    {
        match self {
            FilterB::Kalman(filter) => filter,
            FilterB::Particle(filter) => filter,
        }
    }

    pub fn estimator_mut(
        &mut self,
    ) -> &mut dyn Estimator<
        { model_b::STATE_DIM },
        { model_b::MEASUREMENT_DIM },
        { model_b::INPUT_DIM },
    > {
        match self {
            FilterB::Kalman(filter) => filter,
            FilterB::Particle(filter) => filter,
        }
    }
}

/// The HSRI tyre parameters (model A's tyre; model B's Magic Formula tyre is matched to them).
fn hsri_params(v: &Variables) -> Result<HsriParams, String> {
    Ok(HsriParams {
        reference_load: positive("tyre_reference_load", v.tyre_reference_load)?,
        friction_base: v.tyre_f00,
        friction_load: v.tyre_f01,
        friction_decay_base: v.tyre_kr0,
        friction_decay_load: v.tyre_kr1,
        cornering_base: v.tyre_ca1,
        cornering_load: v.tyre_ca2,
        longitudinal_base: v.tyre_cs1,
        longitudinal_load: v.tyre_cs2,
        reference_sliding_speed: positive("tyre_v_mu", v.tyre_v_mu)?,
        ..HsriParams::default()
    })
}

fn integrator(v: &Variables) -> Result<Integrator, String> {
    match v.integrator {
        integrator_items::SEMI_IMPLICIT_EULER => Ok(Integrator::SemiImplicitEuler),
        integrator_items::RUNGE_KUTTA4 => Ok(Integrator::RungeKutta4),
        other => Err(format!("parameter integrator = {other}; expected 1 or 2")),
    }
}

/// Builds model B from the vehicle, tyre and noise parameters: the same car as model A (track
/// width, CoG height and roll-moment split are the vehicle-models defaults), Magic Formula tyres
/// matched to the HSRI parameters (seed 001 prints no tyre data; SPEC §4).
pub fn model_b(v: &Variables) -> Result<ModelB, String> {
    let vehicle = TwoTrackParams {
        mass: positive("mass", v.mass)?,
        cog_to_front_axle: positive("cog_to_front_axle", v.cog_to_front_axle)?,
        cog_to_rear_axle: positive("cog_to_rear_axle", v.cog_to_rear_axle)?,
        yaw_inertia: positive("yaw_inertia", v.yaw_inertia)?,
        front_wheel_inertia: positive("wheel_inertia_front", v.wheel_inertia_front)?,
        rear_wheel_inertia: positive("wheel_inertia_rear", v.wheel_inertia_rear)?,
        brake_split_front: v.brake_distribution_front,
        wheel_radius: positive("wheel_radius", v.wheel_radius)?,
        front_wheel_load: positive("wheel_load_front", v.wheel_load_front)?,
        rear_wheel_load: positive("wheel_load_rear", v.wheel_load_rear)?,
        ..TwoTrackParams::default()
    };
    let tyre = MagicFormulaTyre::new(MagicFormulaParams::matching_hsri(&hsri_params(v)?));
    // Q = diag(std²) per sample over [β, r, ay], R = diag(std²) over [ay, r] (001: eq 9 order).
    let process = [
        positive("process_noise_std_sideslip", v.process_noise_std_sideslip)?,
        positive("process_noise_std_yaw_rate", v.process_noise_std_yaw_rate)?,
        positive("process_noise_std_ay", v.process_noise_std_ay)?,
    ];
    let measurement = [
        positive("measurement_noise_std_ay", v.measurement_noise_std_ay)?,
        positive(
            "measurement_noise_std_yaw_rate",
            v.measurement_noise_std_yaw_rate,
        )?,
    ];
    TwoTrackEstimationModel::new(
        TwoTrackLateralModel::new(vehicle, tyre),
        positive("sample_time", v.sample_time)?,
        integrator(v)?,
        process.map(|std| std * std),
        measurement.map(|std| std * std),
    )
    .map_err(settings)
}

/// The initial estimate of model B from the parameters.
pub fn initial_estimate_b(
    v: &Variables,
) -> Result<InitialEstimate<{ model_b::STATE_DIM }>, String> {
    let stds = [
        positive("initial_std_sideslip", v.initial_std_sideslip)?,
        positive("initial_std_yaw_rate", v.initial_std_yaw_rate)?,
        positive("initial_std_ay", v.initial_std_ay)?,
    ];
    Ok(InitialEstimate::diagonal(
        StateB::from([v.sideslip_initial, v.yaw_rate_initial, v.ay_initial]),
        StateB::from(stds.map(|std| std * std)),
    ))
}

/// Builds the filter selected by `estimator` on model B, starting from `initial`. The LKF is
/// the linear single-track comparison filter of seed 001 about straight driving at `lkf_vx`
/// (see `estimation::models::two_track`); no Luenberger design exists for model B.
pub fn filter_b(
    v: &Variables,
    model: ModelB,
    initial: &InitialEstimate<{ model_b::STATE_DIM }>,
) -> Result<FilterB, String> {
    let name =
        match v.estimator {
            estimator_kind::LKF => "lkf",
            estimator_kind::EKF => "ekf",
            estimator_kind::UKF => "ukf",
            estimator_kind::UKF_SCALED => "ukf_scaled",
            estimator_kind::PARTICLE_FILTER => {
                let config = particle_config(v)?;
                return ParticleFilter::new(model, config, initial.state, initial.covariance)
                    .map(FilterB::Particle)
                    .map_err(|error| format!("particle filter set-up: {error}"));
            }
            estimator_kind::LUENBERGER => return Err(String::from(
                "parameter estimator = 6 (Luenberger observer) with model = 2 (3-state two-track \
                 model of seed 001) is not supported: seed 002 designs the observer for the \
                 single-track model only; expected estimator 1 to 5 with model = 2, or model = 1",
            )),
            other => return Err(format!("parameter estimator = {other}; expected 1 to 6")),
        };
    let kind =
        two_track_kind(name, (v.ukf_alpha, v.ukf_beta, v.ukf_kappa), v.lkf_vx).map_err(settings)?;
    KalmanEstimator::build(model, &kind, initial)
        .map(FilterB::Kalman)
        .map_err(settings)
}

fn particle_config(v: &Variables) -> Result<ParticleFilterConfig, String> {
    let scheme = match v.particle_resampling {
        particle_resampling::MULTINOMIAL => ResamplingScheme::Multinomial,
        particle_resampling::SYSTEMATIC => ResamplingScheme::Systematic,
        particle_resampling::STRATIFIED => ResamplingScheme::Stratified,
        other => {
            return Err(format!(
                "parameter particle_resampling = {other}; expected 1, 2 or 3"
            ))
        }
    };
    let particle_count = usize::try_from(v.particle_count)
        .ok()
        .filter(|&n| n >= 2)
        .ok_or_else(|| {
            format!(
                "parameter particle_count = {}; expected at least 2",
                v.particle_count
            )
        })?;
    let seed = u64::try_from(v.seed)
        .map_err(|_| format!("parameter seed = {}; expected a value >= 0", v.seed))?;
    Ok(ParticleFilterConfig {
        particle_count,
        scheme,
        policy: ResamplingPolicy::EveryStep,
        seed,
    })
}

/// The sensor inputs of one doStep: `[yaw_rate, ay, omega_front, omega_rear, ax, vx]`.
#[derive(Clone, Copy, Debug)]
pub struct Sensors {
    pub yaw_rate: f64,
    pub ay: f64,
    pub omega_front: f64,
    pub omega_rear: f64,
    pub vx: f64,
}

impl Sensors {
    fn of(v: &Variables) -> Self {
        Self {
            yaw_rate: v.yaw_rate_meas,
            ay: v.ay_meas,
            omega_front: v.omega_front_meas,
            omega_rear: v.omega_rear_meas,
            vx: v.vx_meas,
        }
    }

    fn model_a(&self) -> MeasurementA {
        MeasurementA::from([self.yaw_rate, self.ay, self.omega_front, self.omega_rear])
    }

    /// `r_w` times the mean of the finite wheel speeds, if any.
    fn wheel_speed(&self, wheel_radius: f64) -> Option<f64> {
        let (sum, count) = [self.omega_front, self.omega_rear]
            .into_iter()
            .filter(|w| w.is_finite())
            .fold((0.0, 0u32), |(sum, count), w| (sum + w, count + 1));
        (count > 0).then(|| wheel_radius * sum / f64::from(count))
    }

    /// Model B's speed input: `vx_meas` (seed 001: the speed is measured), else the wheel-speed
    /// fallback, each only when finite and at least `min_speed` (XML: vx_meas).
    fn speed(&self, wheel_radius: f64, min_speed: f64) -> Option<f64> {
        let usable = |speed: f64| speed.is_finite() && speed >= min_speed;
        if usable(self.vx) {
            Some(self.vx)
        } else {
            self.wheel_speed(wheel_radius).filter(|&s| usable(s))
        }
    }
}

/// Model B's filter with what it does not estimate: the speed it runs at and the wheel speeds it
/// passes through (XML: vx_est, omega_front_est, omega_rear_est).
#[derive(Clone, Debug)]
pub struct RunnerB {
    filter: FilterB,
    model: ModelB,
    speed: f64,
    omega_front: f64,
    omega_rear: f64,
}

/// The filter and model of the selected estimator model.
// One per instance, built at initialisation: the size difference costs nothing per step.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Core {
    A { filter: FilterA, model: ModelA },
    B(RunnerB),
}

/// The estimator between samples: filter, sample clock and the last finite driver input.
#[derive(Clone, Debug)]
pub struct Runner {
    core: Core,
    sample_time: f64,
    start_time: f64,
    /// Index of the next sample to process, at `start_time + next_sample * sample_time`.
    next_sample: u64,
    input: InputVector,
    min_speed: f64,
    nis: f64,
    rows_used: i32,
    /// The parameters, to rebuild the filter when it has to be re-seeded (see `reseed`).
    parameters: Box<Variables>,
}

impl Runner {
    fn build(v: &Variables, start_time: f64) -> Result<Self, String> {
        let core = match v.model {
            estimator_model::SINGLE_TRACK_5_STATE => {
                let model = model_a(v)?;
                let initial = initial_estimate_a(v)?;
                let filter = filter_a(v, model.clone(), &initial)?;
                Core::A { filter, model }
            }
            estimator_model::TWO_TRACK_3_STATE => {
                let model = model_b(v)?;
                let initial = initial_estimate_b(v)?;
                let filter = filter_b(v, model.clone(), &initial)?;
                // Before the first sample: the speed the sensors show now, else vx_initial; the
                // wheels free rolling at that speed until they are measured.
                let sensors = Sensors::of(v);
                let min_speed = positive("min_speed", v.min_speed)?;
                let speed = sensors
                    .speed(v.wheel_radius, min_speed)
                    .unwrap_or(v.vx_initial);
                let free_rolling = speed / v.wheel_radius;
                Core::B(RunnerB {
                    filter,
                    model,
                    speed,
                    omega_front: finite_or(sensors.omega_front, free_rolling),
                    omega_rear: finite_or(sensors.omega_rear, free_rolling),
                })
            }
            other => return Err(format!("parameter model = {other}; expected 1 or 2")),
        };
        Ok(Self {
            core,
            sample_time: positive("sample_time", v.sample_time)?,
            start_time,
            next_sample: 0,
            input: InputVector::new(
                finite_or(v.steering_angle, 0.0),
                finite_or(v.drive_torque, 0.0),
                finite_or(v.brake_torque, 0.0),
            ),
            min_speed: positive("min_speed", v.min_speed)?,
            nis: 0.0,
            rows_used: 0,
            parameters: Box::new(v.clone()),
        })
    }

    /// Re-seeds the model-A filter from the measurements when its speed estimate fell below
    /// `min_speed` but the wheel-speed sensors report a speed above it: the estimate is lost
    /// (e.g. after zero sensor signals before the bus delivered data) and waiting for the filter
    /// to find back is hopeless, because the model is singular near standstill. The new start is
    /// `vx = r_w · mean(ωF, ωR)`, `vy = 0`, `r` = measured yaw rate, wheel speeds as measured,
    /// with the initial covariance of the parameters. Returns whether it re-seeded.
    fn reseed(&mut self, sensors: &Sensors) -> bool {
        let v = &*self.parameters;
        let Core::A { filter, model } = &mut self.core else {
            return false;
        };
        let Some(speed) = sensors.wheel_speed(v.wheel_radius) else {
            return false;
        };
        if !(speed >= self.min_speed && speed.is_finite()) {
            return false;
        }
        let free_rolling = speed / v.wheel_radius;
        let Ok(mut initial) = initial_estimate_a(v) else {
            return false;
        };
        initial.state = StateA::from([
            speed,
            0.0,
            finite_or(sensors.yaw_rate, 0.0),
            finite_or(sensors.omega_front, free_rolling),
            finite_or(sensors.omega_rear, free_rolling),
        ]);
        match filter_a(v, model.clone(), &initial) {
            Ok(rebuilt) => {
                *filter = rebuilt;
                true
            }
            Err(_) => false,
        }
    }

    /// The model-A filter, if model A runs (for tests and benchmarks).
    pub fn filter_a(&self) -> Option<&FilterA> {
        match &self.core {
            Core::A { filter, .. } => Some(filter),
            Core::B(_) => None,
        }
    }

    /// The model-B filter, if model B runs (for tests and benchmarks).
    pub fn filter_b(&self) -> Option<&FilterB> {
        match &self.core {
            Core::A { .. } => None,
            Core::B(runner) => Some(&runner.filter),
        }
    }

    /// One sample: measurement update with the sensors, then time update to the next sample.
    /// Returns the status bits of the sample.
    pub fn process_sample(&mut self, sensors: &Sensors) -> i32 {
        match self.core {
            Core::A { .. } => self.process_sample_a(sensors),
            Core::B(_) => self.process_sample_b(sensors),
        }
    }

    fn process_sample_a(&mut self, sensors: &Sensors) -> i32 {
        let measurement = sensors.model_a();
        let mut bits = 0;
        let input = self.input;
        let below_min_speed = match &self.core {
            Core::A { filter, .. } => filter.estimator().state()[state_index::VX] < self.min_speed,
            Core::B(_) => return 0,
        };
        if below_min_speed {
            if !self.reseed(sensors) {
                // The slip quantities are singular at standstill and the wheels confirm it:
                // hold instead of guessing.
                self.nis = 0.0;
                self.rows_used = 0;
                return status::BELOW_MIN_SPEED;
            }
            bits |= status::BELOW_MIN_SPEED | status::STATE_RESET;
        }
        let Core::A { filter, .. } = &mut self.core else {
            return bits;
        };
        if measurement.iter().any(|value| !value.is_finite()) {
            bits |= status::ROW_SKIPPED;
        }
        // Non-finite rows are skipped by the filters themselves (SPEC §6).
        match filter
            .estimator_mut()
            .update(&measurement, &input, &[true; MEASUREMENT_DIM])
        {
            Ok(report) => {
                self.nis = report.nis;
                self.rows_used = report.rows_used as i32;
            }
            Err(issue) => {
                bits |= issue_bit(issue);
                let report = match &*filter {
                    FilterA::Kalman(filter) => *filter.last_report(),
                    FilterA::Particle(_) => estimation::UpdateReport::skipped(),
                };
                self.nis = report.nis;
                self.rows_used = report.rows_used as i32;
            }
        }
        if let Err(issue) = filter.estimator_mut().predict(&input) {
            bits |= issue_bit(issue);
        }
        bits
    }

    /// Model B: the speed is an input (vx_meas or the wheel-speed fallback), `y = [ay, r]`
    /// (001: eq 9); the wheel speeds are passed through.
    fn process_sample_b(&mut self, sensors: &Sensors) -> i32 {
        let wheel_radius = self.parameters.wheel_radius;
        let Core::B(runner) = &mut self.core else {
            return 0;
        };
        let mut bits = 0;
        if sensors.omega_front.is_finite() {
            runner.omega_front = sensors.omega_front;
        }
        if sensors.omega_rear.is_finite() {
            runner.omega_rear = sensors.omega_rear;
        }
        let Some(speed) = sensors.speed(wheel_radius, self.min_speed) else {
            // Model B divides by the speed: hold the estimate until a speed is measured again.
            self.nis = 0.0;
            self.rows_used = 0;
            return status::BELOW_MIN_SPEED;
        };
        if !sensors.vx.is_finite() {
            // vx_meas is missing and the wheel-speed fallback stands in for it.
            bits |= status::ROW_SKIPPED;
        }
        runner.speed = speed;
        let input = InputB::from([self.input[0], speed]);
        let measurement = MeasurementB::from([sensors.ay, sensors.yaw_rate]);
        if measurement.iter().any(|value| !value.is_finite()) {
            bits |= status::ROW_SKIPPED;
        }
        match runner.filter.estimator_mut().update(
            &measurement,
            &input,
            &[true; model_b::MEASUREMENT_DIM],
        ) {
            Ok(report) => {
                self.nis = report.nis;
                self.rows_used = report.rows_used as i32;
            }
            Err(issue) => {
                bits |= issue_bit(issue);
                let report = match &runner.filter {
                    FilterB::Kalman(filter) => *filter.last_report(),
                    FilterB::Particle(_) => estimation::UpdateReport::skipped(),
                };
                self.nis = report.nis;
                self.rows_used = report.rows_used as i32;
            }
        }
        if let Err(issue) = runner.filter.estimator_mut().predict(&input) {
            bits |= issue_bit(issue);
        }
        bits
    }

    /// Processes every sample in `[t, t + h)`; returns the status bits and whether any ran.
    pub fn advance(&mut self, t: f64, h: f64, sensors: &Sensors) -> (i32, bool) {
        let tolerance = 1e-6 * self.sample_time;
        let mut bits = 0;
        let mut processed = false;
        loop {
            let sample_time = self.start_time + self.next_sample as f64 * self.sample_time;
            if sample_time >= t + h - tolerance {
                break;
            }
            bits |= self.process_sample(sensors);
            self.next_sample += 1;
            processed = true;
        }
        (bits, processed)
    }

    fn write_state(&self, writer: &mut StateWriter) -> Result<(), String> {
        // Kalman-type filters: (x, P). The particle filter: its whole running state, random
        // generator position included (the estimator kind is a parameter, restored first).
        match &self.core {
            Core::A { filter, .. } => match filter {
                FilterA::Kalman(estimator) => {
                    writer.f64s(estimator.state().as_slice());
                    writer.f64s(estimator.covariance().as_slice());
                }
                FilterA::Particle(particles) => write_particles(writer, &particles.snapshot()),
            },
            Core::B(runner) => {
                match &runner.filter {
                    FilterB::Kalman(estimator) => {
                        writer.f64s(estimator.state().as_slice());
                        writer.f64s(estimator.covariance().as_slice());
                    }
                    FilterB::Particle(particles) => write_particles(writer, &particles.snapshot()),
                }
                writer.f64(runner.speed);
                writer.f64(runner.omega_front);
                writer.f64(runner.omega_rear);
            }
        }
        writer.f64(self.start_time);
        writer.u64(self.next_sample);
        writer.f64s(self.input.as_slice());
        writer.f64(self.nis);
        writer.i32(self.rows_used);
        Ok(())
    }

    fn read_state(v: &Variables, reader: &mut StateReader<'_>) -> Result<Self, StateError> {
        // The Kalman-type filters are fully described by (x, P) and their parameters: rebuilding
        // them from the stored pair continues bit-identically.
        // The particle filter is built from its parameters as at instantiation and then
        // continues from the stored snapshot.
        let mut runner = Runner::build(v, 0.0).map_err(StateError::new)?;
        match &mut runner.core {
            Core::A { filter, model } => match filter {
                FilterA::Particle(particles) => restore_particles(reader, particles)?,
                FilterA::Kalman(_) => {
                    let mut state = StateA::zeros();
                    reader.f64s_into(state.as_mut_slice(), "estimate")?;
                    let mut covariance = CovarianceA::zeros();
                    reader.f64s_into(covariance.as_mut_slice(), "covariance")?;
                    let initial = InitialEstimate { state, covariance };
                    *filter = filter_a(v, model.clone(), &initial).map_err(StateError::new)?;
                }
            },
            Core::B(core) => {
                match &mut core.filter {
                    FilterB::Particle(particles) => restore_particles(reader, particles)?,
                    FilterB::Kalman(_) => {
                        let mut state = StateB::zeros();
                        reader.f64s_into(state.as_mut_slice(), "estimate")?;
                        let mut covariance = CovarianceB::zeros();
                        reader.f64s_into(covariance.as_mut_slice(), "covariance")?;
                        let initial = InitialEstimate { state, covariance };
                        core.filter =
                            filter_b(v, core.model.clone(), &initial).map_err(StateError::new)?;
                    }
                }
                core.speed = reader.f64("speed")?;
                core.omega_front = reader.f64("front wheel speed")?;
                core.omega_rear = reader.f64("rear wheel speed")?;
            }
        }
        runner.start_time = reader.f64("start time")?;
        runner.next_sample = reader.u64("next sample")?;
        reader.f64s_into(runner.input.as_mut_slice(), "driver input")?;
        runner.nis = reader.f64("nis")?;
        runner.rows_used = reader.i32("rows used")?;
        Ok(runner)
    }

    /// What the outputs after the latest sample are computed from (see `PendingOutputs`).
    fn output_sample(&self) -> OutputSample {
        let mut sample = OutputSample {
            state: StateA::zeros(),
            variances: StateA::zeros(),
            covariance_vx_vy: 0.0,
            input: self.input,
            speed: 0.0,
            omega_front: 0.0,
            omega_rear: 0.0,
            nis: self.nis,
            rows_used: self.rows_used,
        };
        match &self.core {
            Core::A { filter, .. } => {
                let estimator = filter.estimator();
                sample.state = *estimator.state();
                let covariance = estimator.covariance();
                sample.variances = covariance.diagonal();
                sample.covariance_vx_vy = covariance[(state_index::VX, state_index::VY)];
            }
            Core::B(runner) => {
                // Model B's 3 states sit in the leading entries (copies, so bit-exact).
                let estimator = runner.filter.estimator();
                sample
                    .state
                    .fixed_rows_mut::<{ model_b::STATE_DIM }>(0)
                    .copy_from(estimator.state());
                sample
                    .variances
                    .fixed_rows_mut::<{ model_b::STATE_DIM }>(0)
                    .copy_from(&estimator.covariance().diagonal());
                sample.speed = runner.speed;
                sample.omega_front = runner.omega_front;
                sample.omega_rear = runner.omega_rear;
            }
        }
        sample
    }

    /// The output values in the order of `OUTPUTS` (see `publish`) for one sample's result.
    fn outputs(&self, sample: &OutputSample) -> [f64; OUTPUT_COUNT] {
        match &self.core {
            Core::A { model, .. } => Self::outputs_a(model, sample),
            Core::B(runner) => self.outputs_b(&runner.model, sample),
        }
    }

    fn outputs_a(model: &ModelA, sample: &OutputSample) -> [f64; OUTPUT_COUNT] {
        let x = sample.state;
        let variances = sample.variances;
        let u = sample.input;
        // One model evaluation for every derived output: its ay is v̇y + vx r (000: 5.40), the
        // measurement function h(x, u) of the ay row in exact arithmetic, so evaluating h again
        // would only repeat the tyre forces.
        let derived = model.vehicle().outputs(&x, &u);
        let ay = derived.lateral_acceleration;
        let std = |i: usize| variances[i].max(0.0).sqrt();
        // First-order propagation of P through atan2(vy, vx).
        let (vx, vy) = (x[state_index::VX], x[state_index::VY]);
        let speed_squared = vx * vx + vy * vy;
        let gradient = [-vy / speed_squared, vx / speed_squared];
        let sideslip_variance = gradient[0] * gradient[0] * variances[state_index::VX]
            + 2.0 * gradient[0] * gradient[1] * sample.covariance_vx_vy
            + gradient[1] * gradient[1] * variances[state_index::VY];
        [
            x[state_index::VX],
            x[state_index::VY],
            x[state_index::YAW_RATE],
            x[state_index::OMEGA_FRONT],
            x[state_index::OMEGA_REAR],
            derived.sideslip,
            ay,
            derived.slip_angle_front,
            derived.slip_angle_rear,
            derived.slip_front,
            derived.slip_rear,
            std(state_index::VX),
            std(state_index::VY),
            std(state_index::YAW_RATE),
            std(state_index::OMEGA_FRONT),
            std(state_index::OMEGA_REAR),
            sideslip_variance.max(0.0).sqrt(),
            sample.nis,
        ]
    }

    /// Model B's outputs as the XML descriptions state them.
    fn outputs_b(&self, model: &ModelB, sample: &OutputSample) -> [f64; OUTPUT_COUNT] {
        use model_b::state_index as b;
        let v = &*self.parameters;
        let x: StateB = sample
            .state
            .fixed_rows::<{ model_b::STATE_DIM }>(0)
            .into_owned();
        let variances = sample.variances;
        let steering = sample.input[0];
        let u = InputB::from([steering, sample.speed]);
        // vy = vx tan β and the axle slip angles (001: eqs 4-5).
        let derived = model.vehicle().outputs(&x, &u);
        let vx = sample.speed;
        let (sideslip, yaw_rate) = (x[b::SIDESLIP], x[b::YAW_RATE]);
        let vy = derived.lateral_velocity;
        // Longitudinal slip (ω r_w − vxW) / vxW with the wheel-centre speed along the wheel
        // (000: 5.65; front wheel turned by δ, as in model A).
        let front_along_wheel =
            vx * steering.cos() + (vy + v.cog_to_front_axle * yaw_rate) * steering.sin();
        let slip = |omega: f64, along: f64| (omega * v.wheel_radius - along) / along;
        let std = |i: usize| variances[i].max(0.0).sqrt();
        let cos_sideslip = sideslip.cos();
        [
            vx,
            vy,
            yaw_rate,
            sample.omega_front,
            sample.omega_rear,
            sideslip,
            x[b::LATERAL_ACCELERATION],
            derived.slip_angle_front,
            derived.slip_angle_rear,
            slip(sample.omega_front, front_along_wheel),
            slip(sample.omega_rear, vx),
            v.measurement_noise_std_vx,
            // d(vx tan β)/dβ = vx / cos²β (first-order propagation).
            vx * std(b::SIDESLIP) / (cos_sideslip * cos_sideslip),
            std(b::YAW_RATE),
            v.measurement_noise_std_omega_front,
            v.measurement_noise_std_omega_rear,
            std(b::SIDESLIP),
            sample.nis,
        ]
    }
}

/// Number of real outputs written by `publish`.
const OUTPUT_COUNT: usize = 18;

/// What the outputs after a sample are computed from: the filter's estimate, the covariance
/// entries the outputs use and the values beside it, copied when the sample is processed.
#[derive(Clone, Copy, Debug)]
struct OutputSample {
    /// Model A's state; model B's 3 states in the leading entries.
    state: StateA,
    /// The diagonal of the covariance (model B's in the leading entries).
    variances: StateA,
    /// Model A only: cov(vx, vy), for the sideslip standard deviation.
    covariance_vx_vy: f64,
    input: InputVector,
    /// Model B only: the speed input and the wheel speeds passed through.
    speed: f64,
    omega_front: f64,
    omega_rear: f64,
    nis: f64,
    rows_used: i32,
}

impl OutputSample {
    fn empty() -> Self {
        Self {
            state: StateA::zeros(),
            variances: StateA::zeros(),
            covariance_vx_vy: 0.0,
            input: InputVector::zeros(),
            speed: 0.0,
            omega_front: 0.0,
            omega_rear: 0.0,
            nis: 0.0,
            rows_used: 0,
        }
    }
}

/// How many doSteps with a sample may pass without an output read before the outputs are
/// computed anyway (bounds the memory; one evaluation per this many doSteps).
const PENDING_CAPACITY: usize = 8;

/// The derived outputs (slip quantities, ay, standard deviations, sideslip) cost about as much
/// as a filter step, so they are computed lazily: each doStep that processed a sample stores
/// what its outputs are computed from, and the first output read (`refresh_outputs`) computes
/// them. The values are exactly those of publishing after every doStep: an output that is not
/// finite keeps its previous value, so the samples since the last publish are kept and a
/// non-finite output is looked up in the older ones, newest first.
#[derive(Clone, Debug)]
struct PendingOutputs {
    samples: [OutputSample; PENDING_CAPACITY],
    len: usize,
    /// The latest doStep processed a sample, so its `status` includes the publish bits.
    status_awaits_publish: bool,
}

impl PendingOutputs {
    fn new() -> Self {
        Self {
            samples: [OutputSample::empty(); PENDING_CAPACITY],
            len: 0,
            status_awaits_publish: false,
        }
    }
}

fn finite_or(value: f64, fallback: f64) -> f64 {
    if value.is_finite() {
        value
    } else {
        fallback
    }
}

/// The VehicleStateEstimator FMU.
#[derive(Clone, Debug)]
pub struct VehicleStateEstimator {
    variables: Variables,
    runner: Option<Runner>,
    pending: PendingOutputs,
}

impl VehicleStateEstimator {
    /// The running estimator (for tests and benchmarks).
    pub fn runner(&self) -> Option<&Runner> {
        self.runner.as_ref()
    }

    /// Stores the outputs of the sample just processed, to be computed at the next read.
    fn defer_publish(&mut self) {
        if self.pending.len == PENDING_CAPACITY {
            self.publish();
        }
        if let Some(runner) = &self.runner {
            self.pending.samples[self.pending.len] = runner.output_sample();
            self.pending.len += 1;
        }
    }

    /// Writes the pending estimate into the outputs; keeps an output's previous value (and
    /// reports status bit 8 for the latest doStep) if it would not be finite.
    fn publish(&mut self) {
        let pending = &mut self.pending;
        let Some(runner) = &self.runner else {
            pending.len = 0;
            return;
        };
        if pending.len == 0 {
            return;
        }
        let newest = &pending.samples[pending.len - 1];
        let rows_used = newest.rows_used;
        let mut values = runner.outputs(newest);
        let mut finite = values.map(f64::is_finite);
        let reset = finite.contains(&false);
        // Eager publishing would have kept the value of the newest older sample where it was
        // finite; walk back only while some output is still missing.
        for older in pending.samples[..pending.len - 1].iter().rev() {
            if !finite.contains(&false) {
                break;
            }
            let older_values = runner.outputs(older);
            for ((value, is_finite), older_value) in
                values.iter_mut().zip(finite.iter_mut()).zip(older_values)
            {
                if !*is_finite && older_value.is_finite() {
                    *value = older_value;
                    *is_finite = true;
                }
            }
        }
        let v = &mut self.variables;
        let targets: [&mut f64; OUTPUT_COUNT] = [
            &mut v.vx_est,
            &mut v.vy_est,
            &mut v.yaw_rate_est,
            &mut v.omega_front_est,
            &mut v.omega_rear_est,
            &mut v.sideslip_est,
            &mut v.ay_est,
            &mut v.slip_angle_front_est,
            &mut v.slip_angle_rear_est,
            &mut v.slip_front_est,
            &mut v.slip_rear_est,
            &mut v.vx_std,
            &mut v.vy_std,
            &mut v.yaw_rate_std,
            &mut v.omega_front_std,
            &mut v.omega_rear_std,
            &mut v.sideslip_std,
            &mut v.nis,
        ];
        for ((target, value), is_finite) in targets.into_iter().zip(values).zip(finite) {
            if is_finite {
                *target = value;
            }
        }
        v.rows_used = rows_used;
        if reset && pending.status_awaits_publish {
            v.status |= status::STATE_RESET;
        }
        pending.len = 0;
        pending.status_awaits_publish = false;
    }
}

impl CoSimulationModel for VehicleStateEstimator {
    type Variables = Variables;
    const MODEL_IDENTIFIER: &'static str = model_description::MODEL_IDENTIFIER;
    const GUID: &'static str = model_description::GUID;
    const VARIABLES: &'static [fmi_export::VariableInfo] = model_description::VARIABLES;
    const LOG_CATEGORIES: &'static [&'static str] = model_description::LOG_CATEGORIES;

    fn instantiate(_context: &InstantiationContext) -> Self {
        Self {
            variables: Variables::default(),
            runner: None,
            pending: PendingOutputs::new(),
        }
    }

    fn variables(&self) -> &Variables {
        &self.variables
    }

    fn variables_mut(&mut self) -> &mut Variables {
        &mut self.variables
    }

    fn initialize(&mut self, start_time: f64) -> Result<(), String> {
        self.runner = Some(Runner::build(&self.variables, start_time)?);
        self.pending.len = 0;
        self.variables.status = 0;
        self.defer_publish();
        self.pending.status_awaits_publish = true;
        // Initialisation is not the hot path: publish at once.
        self.publish();
        Ok(())
    }

    fn do_step(&mut self, current_time: f64, step_size: f64) -> StepOutcome {
        let v = &self.variables;
        let driver = [v.steering_angle, v.drive_torque, v.brake_torque];
        let sensors = Sensors::of(v);
        let Some(runner) = self.runner.as_mut() else {
            return StepOutcome::Error(String::from("the estimator was not initialised"));
        };
        let mut bits = 0;
        for (i, value) in driver.into_iter().enumerate() {
            if value.is_finite() {
                runner.input[i] = value;
            } else {
                bits |= status::INPUT_HELD;
            }
        }
        let (sample_bits, processed) = runner.advance(current_time, step_size, &sensors);
        bits |= sample_bits;
        if processed {
            self.defer_publish();
        }
        self.variables.status = bits;
        self.pending.status_awaits_publish = processed;
        StepOutcome::Ok
    }

    fn refresh_outputs(&mut self) {
        self.publish();
    }

    fn write_state(&self, writer: &mut StateWriter) -> Result<(), String> {
        match &self.runner {
            None => writer.bool(false),
            Some(runner) => {
                writer.bool(true);
                runner.write_state(writer)?;
            }
        }
        Ok(())
    }

    fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        // The outputs were published before the state was taken (see `refresh_outputs`).
        self.pending = PendingOutputs::new();
        self.runner = if reader.bool("estimator present")? {
            Some(Runner::read_state(&self.variables, reader)?)
        } else {
            None
        };
        Ok(())
    }
}

fmi_export::export_fmi2!(VehicleStateEstimator);
