//! FMU **VehicleStateEstimator**: a recursive state estimator for planar vehicle dynamics as an
//! FMI 2.0 Co-Simulation FMU (modelIdentifier `VehicleStateEstimator`).
//!
//! The interface is modelDescription/VehicleStateEstimator.xml; value references, GUID and start
//! values are generated from it at build time. The filters come from the `estimation` crate:
//! LKF, EKF, UKF (2n and scaled 2n+1 sigma points) and the Luenberger observer through
//! `KalmanEstimator`, the SIR particle filter through `ParticleFilter`, all on model A (the
//! 5-state single-track model with HSRI tyres of seed 000, `SingleTrackEstimationModel`).
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
//! non-finite driver input keeps its last finite value (bit 64); below `min_speed` the filter
//! holds (bit 32); filter repairs are reported in bits 2, 4, 8, 16; no output is ever NaN.
//!
//! Model B (`model = 2`, the 3-state seed-001 form) is part of the interface; this build reports
//! at initialisation that it is not available until the two-track adapter of the `estimation`
//! crate exists.
#![allow(non_snake_case)] // the crate is named after the modelIdentifier

use estimation::kalman::{
    EstimatorKind, InitialEstimate, KalmanEstimator, SettingsError, SigmaPoints,
};
use estimation::models::single_track::SingleTrackEstimationModel;
use estimation::particle::{
    ParticleFilter, ParticleFilterConfig, ResamplingPolicy, ResamplingScheme,
};
use estimation::{Estimator, FilterIssue, StateSpaceModel};
use fmi_export::{
    CoSimulationModel, InstantiationContext, StateError, StateReader, StateWriter, StepOutcome,
};
use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::INPUT_DIM;
use vehicle_models::single_track::{
    measurement_index, state_index, SingleTrackParams, MEASUREMENT_DIM, STATE_DIM,
};
use vehicle_models::tyre::HsriParams;
use vehicle_models::{HsriTyre, Integrator, SingleTrackModel};

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
        ..SingleTrackParams::default()
    };
    let tyre = HsriTyre::new(HsriParams {
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
    });
    let integrator = match v.integrator {
        integrator_items::SEMI_IMPLICIT_EULER => Integrator::SemiImplicitEuler,
        integrator_items::RUNGE_KUTTA4 => Integrator::RungeKutta4,
        other => return Err(format!("parameter integrator = {other}; expected 1 or 2")),
    };
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
            let config = ParticleFilterConfig {
                particle_count,
                scheme,
                policy: ResamplingPolicy::EveryStep,
                seed,
            };
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

/// The estimator between samples: filter, sample clock and the last finite driver input.
#[derive(Clone, Debug)]
pub struct Runner {
    filter: FilterA,
    model: ModelA,
    sample_time: f64,
    start_time: f64,
    /// Index of the next sample to process, at `start_time + next_sample * sample_time`.
    next_sample: u64,
    input: InputVector,
    min_speed: f64,
    nis: f64,
    rows_used: i32,
}

impl Runner {
    fn build(v: &Variables, start_time: f64) -> Result<Self, String> {
        match v.model {
            estimator_model::SINGLE_TRACK_5_STATE => {}
            estimator_model::TWO_TRACK_3_STATE => {
                return Err(String::from(
                    "parameter model = 2 (the 3-state two-track model of seed 001) is not available \
                     in this build: the estimation crate has no two-track adapter yet; expected model = 1",
                ))
            }
            other => return Err(format!("parameter model = {other}; expected 1 or 2")),
        }
        let model = model_a(v)?;
        let initial = initial_estimate_a(v)?;
        let filter = filter_a(v, model.clone(), &initial)?;
        Ok(Self {
            filter,
            model,
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
        })
    }

    /// The filter (for tests and benchmarks).
    pub fn filter(&self) -> &FilterA {
        &self.filter
    }

    /// One sample: measurement update with `measurement`, then time update to the next sample.
    /// Returns the status bits of the sample.
    pub fn process_sample(&mut self, measurement: &MeasurementA) -> i32 {
        let mut bits = 0;
        let input = self.input;
        let estimator = self.filter.estimator_mut();
        if estimator.state()[state_index::VX] < self.min_speed {
            // The slip quantities are singular at standstill: hold instead of guessing.
            self.nis = 0.0;
            self.rows_used = 0;
            return status::BELOW_MIN_SPEED;
        }
        if measurement.iter().any(|value| !value.is_finite()) {
            bits |= status::ROW_SKIPPED;
        }
        // Non-finite rows are skipped by the filters themselves (SPEC §6).
        match estimator.update(measurement, &input, &[true; MEASUREMENT_DIM]) {
            Ok(report) => {
                self.nis = report.nis;
                self.rows_used = report.rows_used as i32;
            }
            Err(issue) => {
                bits |= issue_bit(issue);
                let report = match &self.filter {
                    FilterA::Kalman(filter) => *filter.last_report(),
                    FilterA::Particle(_) => estimation::UpdateReport::skipped(),
                };
                self.nis = report.nis;
                self.rows_used = report.rows_used as i32;
            }
        }
        if let Err(issue) = self.filter.estimator_mut().predict(&input) {
            bits |= issue_bit(issue);
        }
        bits
    }

    /// Processes every sample in `[t, t + h)`; returns the status bits and whether any ran.
    pub fn advance(&mut self, t: f64, h: f64, measurement: &MeasurementA) -> (i32, bool) {
        let tolerance = 1e-6 * self.sample_time;
        let mut bits = 0;
        let mut processed = false;
        loop {
            let sample_time = self.start_time + self.next_sample as f64 * self.sample_time;
            if sample_time >= t + h - tolerance {
                break;
            }
            bits |= self.process_sample(measurement);
            self.next_sample += 1;
            processed = true;
        }
        (bits, processed)
    }

    fn write_state(&self, writer: &mut StateWriter) -> Result<(), String> {
        let estimator = match &self.filter {
            FilterA::Kalman(filter) => filter,
            FilterA::Particle(_) => return Err(String::from(
                "the particle filter's state (particles and random stream) cannot be serialized: \
                     estimation::particle::ParticleFilter offers no way to restore it; \
                     fmi2GetFMUstate/fmi2SetFMUstate work for it",
            )),
        };
        writer.f64s(estimator.state().as_slice());
        writer.f64s(estimator.covariance().as_slice());
        writer.f64(self.start_time);
        writer.u64(self.next_sample);
        writer.f64s(self.input.as_slice());
        writer.f64(self.nis);
        writer.i32(self.rows_used);
        Ok(())
    }

    fn read_state(v: &Variables, reader: &mut StateReader<'_>) -> Result<Self, StateError> {
        let mut state = StateA::zeros();
        reader.f64s_into(state.as_mut_slice(), "estimate")?;
        let mut covariance = CovarianceA::zeros();
        reader.f64s_into(covariance.as_mut_slice(), "covariance")?;
        let start_time = reader.f64("start time")?;
        let mut runner = Runner::build(v, start_time).map_err(StateError::new)?;
        // The Kalman-type filters are fully described by (x, P) and their parameters: rebuilding
        // them from the stored pair continues bit-identically.
        let initial = InitialEstimate { state, covariance };
        runner.filter = filter_a(v, runner.model.clone(), &initial).map_err(StateError::new)?;
        runner.next_sample = reader.u64("next sample")?;
        reader.f64s_into(runner.input.as_mut_slice(), "driver input")?;
        runner.nis = reader.f64("nis")?;
        runner.rows_used = reader.i32("rows used")?;
        Ok(runner)
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
}

impl VehicleStateEstimator {
    /// The running estimator (for tests and benchmarks).
    pub fn runner(&self) -> Option<&Runner> {
        self.runner.as_ref()
    }

    /// Writes the estimate into the outputs; keeps an output's previous value (and reports
    /// status bit 8) if it would not be finite.
    fn publish(&mut self) -> i32 {
        let Some(runner) = &self.runner else {
            return 0;
        };
        let estimator = runner.filter.estimator();
        let x = *estimator.state();
        let p = *estimator.covariance();
        let u = runner.input;
        let derived = runner.model.vehicle().outputs(&x, &u);
        let ay = runner.model.measurement(&x, &u)[measurement_index::LATERAL_ACCELERATION];
        let std = |i: usize| p[(i, i)].max(0.0).sqrt();
        // First-order propagation of P through atan2(vy, vx).
        let (vx, vy) = (x[state_index::VX], x[state_index::VY]);
        let speed_squared = vx * vx + vy * vy;
        let gradient = [-vy / speed_squared, vx / speed_squared];
        let sideslip_variance = gradient[0] * gradient[0] * p[(0, 0)]
            + 2.0 * gradient[0] * gradient[1] * p[(0, 1)]
            + gradient[1] * gradient[1] * p[(1, 1)];
        let values = [
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
            runner.nis,
        ];
        let v = &mut self.variables;
        let targets: [&mut f64; 18] = [
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
        let mut bits = 0;
        for (target, value) in targets.into_iter().zip(values) {
            if value.is_finite() {
                *target = value;
            } else {
                bits |= status::STATE_RESET;
            }
        }
        v.rows_used = runner.rows_used;
        bits
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
        let bits = self.publish();
        self.variables.status = bits;
        Ok(())
    }

    fn do_step(&mut self, current_time: f64, step_size: f64) -> StepOutcome {
        let v = &self.variables;
        let driver = [v.steering_angle, v.drive_torque, v.brake_torque];
        let measurement = MeasurementA::from([
            v.yaw_rate_meas,
            v.ay_meas,
            v.omega_front_meas,
            v.omega_rear_meas,
        ]);
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
        let (sample_bits, processed) = runner.advance(current_time, step_size, &measurement);
        bits |= sample_bits;
        if processed {
            bits |= self.publish();
        }
        self.variables.status = bits;
        StepOutcome::Ok
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
        self.runner = if reader.bool("estimator present")? {
            Some(Runner::read_state(&self.variables, reader)?)
        } else {
            None
        };
        Ok(())
    }
}

fmi_export::export_fmi2!(VehicleStateEstimator);
