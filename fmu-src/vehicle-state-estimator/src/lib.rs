//! FMU **VehicleStateEstimator**: a recursive state estimator for planar vehicle dynamics as an
//! FMI 2.0 Co-Simulation FMU (modelIdentifier `VehicleStateEstimator`).
//!
//! The interface is modelDescription/VehicleStateEstimator.xml; value references, GUID and start
//! values are generated from it at build time. The filters come from the `estimation` crate's
//! registry (`estimation::registry`: LKF, EKF, UKF with 2n and scaled 2n+1 sigma points,
//! Luenberger observer, SIR particle filter), selected by the `estimator` item's name, on model
//! A (the 5-state single-track model with HSRI tyres of seed 000, [`model_a`]) or model B
//! ([`model_b`]); one generic [`runner::Runner`] drives either.
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
//! below `min_speed` the filter is re-seeded from the measured speed if it is higher
//! (bits 32 + 8), else it holds (bit 32, low-speed mode); filter repairs are reported in bits 2,
//! 4, 8, 16; no output is ever NaN.
//!
//! **Robustness switches** (each a Boolean parameter, on by default; the seed scenarios and the tests of
//! the seeds' behaviour switch them off):
//! - `use_speed_measurements` (model A): `vx_meas` is a fifth row and a finite `ax_meas` drives
//!   `vx` by the kinematics `dvx/dt = ax + r vy` (`SpeedAnchoredModel` of the estimation crate),
//!   so the speed needs no torques.
//! - `start_from_measurements`: the filter holds (bit 512) until a sample shows a speed of at
//!   least `min_speed` and starts from it ([`runner::EstimationModel::measured_start`]); the LKF
//!   is linearised about straight driving at that speed.
//! - `gate_measurements`: the **runner** gates each row before the update, the same for every
//!   estimator: physical plausibility and the chi-square test `nu² <= gate_threshold · S`
//!   (bit 128), for the model's model-error rows (the yaw rate; model B also ay,
//!   [`runner::EstimationModel::model_error_rows`]) about the median of their recent innovations
//!   and clipped to the gate's edge when they fail; a plausible row gated for `readmit_time`
//!   re-seeds the filter from the measurements (bit 256), so it cannot lock itself out. Bit
//!   1024: an input outside its declared range was clamped by the FMI layer (fmi2Warning) since
//!   the previous doStep.
//! - `yaw_rate_offset_std` (a Real, 0 switches it off as the seed scenarios do): the runner
//!   learns the gyro's offset standing still and driving straight and takes it off
//!   `yaw_rate_meas` for every estimator ([`yaw_rate_offset`]; output `yaw_rate_offset_est`).
//! - `ay_offset_std` and `ay_gain_std` (Reals, both 0 switches it off): the runner learns the
//!   lateral accelerometer's offset driving straight and, where `ay_gain_std` is not 0, its gain
//!   in steady corners, and takes them off `ay_meas` ([`lateral_accelerometer`]; outputs
//!   `ay_offset_est`, `ay_gain_est`).
//! - `wheel_radius_std` (a Real, 0 switches it off): the runner learns each axle's effective
//!   rolling radius from `vx_meas` where the car rolls straight without traction and corrects
//!   the wheel speeds with it ([`rolling_radius`]).
//!
//! **Model B** (`model = 2`): the 3-state seed-001 form `x = [sideslip, yaw_rate, ay]` with
//! `u = [steering_angle, vx, ax_meas]` (`ax_meas` with `use_speed_measurements`, for the
//! longitudinal load transfer; else 0) and `y = [ay_meas, yaw_rate_meas]` (001: eqs 6-11,
//! `TwoTrackEstimationModel`), the same car with Magic Formula tyres matched to the HSRI
//! parameters. LKF (seed 001's linear single-track comparison filter about straight driving at
//! `lkf_vx`), EKF, both UKFs, the particle filter and the Luenberger observer run on it (the
//! observer's design, `β` through `ay` and `r` through the gyro, is ours: seed 002 covers model A
//! only). The speed input
//! is `vx_meas`, else the mean of the wheels' rolling speeds `r ω` (per-axle radii); without either above
//! `min_speed` the filter holds (bit 32). Outputs: vx_est = the speed input, vy_est =
//! vx·tan(sideslip), wheel speeds passed through, stds as the XML states.
#![allow(non_snake_case)] // the crate is named after the modelIdentifier

use fmi_export::{
    CoSimulationModel, InstantiationContext, StateError, StateReader, StateWriter, StepOutcome,
};

/// Generated from modelDescription/VehicleStateEstimator.xml.
pub mod model_description {
    include!(concat!(env!("OUT_DIR"), "/model_description.rs"));
}

pub mod estimation_model;
pub mod gauss_markov;
pub mod lateral_accelerometer;
pub mod model_a;
pub mod model_b;
pub mod model_grip;
pub mod parameters;
pub mod rolling_radius;
pub mod runner;
pub mod sensors;
pub mod speed_filter;
mod state;
pub mod yaw_rate_offset;

use model_a::RunnerA;
use model_b::RunnerB;
use model_description::{EstimatorModel, Variables};
use model_grip::RunnerGrip;
use sensors::{Sensors, SENSOR_COUNT};

/// Bits of the `status` output (see its description in the XML).
pub mod status {
    pub const ROW_SKIPPED: i32 = 1;
    pub const COVARIANCE_REPAIRED: i32 = 2;
    pub const UPDATE_SKIPPED: i32 = 4;
    pub const STATE_RESET: i32 = 8;
    pub const WEIGHTS_RESET: i32 = 16;
    pub const BELOW_MIN_SPEED: i32 = 32;
    pub const INPUT_HELD: i32 = 64;
    /// A row failed the gate.
    pub const ROW_GATED: i32 = 128;
    /// A row was locked out for `readmit_time` and the filter re-seeded from the sensors.
    pub const SENSOR_READMITTED: i32 = 256;
    /// `start_from_measurements` waits for (or started from) the first measured speed.
    pub const INITIALISING: i32 = 512;
    /// An input outside its declared range was clamped by fmi2SetReal/fmi2SetInteger (which
    /// answered fmi2Warning) since the previous doStep (`CoSimulationModel::value_adjusted`).
    pub const INPUT_CLAMPED: i32 = 1024;
    /// Model B: the load transfer at the estimated ay lifts an inner wheel, whose load is
    /// clamped at 0 (`TwoTrackParams::wheel_loads`).
    pub const WHEEL_LIFTED: i32 = 2048;
    /// `adaptive_process_noise` has scaled `Q` up.
    pub const ADAPTING: i32 = 4096;
    /// The innovations are larger than the reported covariance allows
    /// (`estimation::innovation_monitor`; with `adaptive_process_noise` or the Luenberger
    /// observer, their windowed NIS outside its 95 % band).
    pub const INCONSISTENT: i32 = 8192;
    /// The integrity guard re-seeded the sideslip where the car's own data put it
    /// (`runner::guard`).
    pub const GUARDED: i32 = 16384;
    /// The sideslip estimate's change is off what the kinematics integrate to
    /// (`runner::kinematic_check`).
    pub const OFF_THE_KINEMATICS: i32 = 32768;
}

/// The runner of the selected estimation model.
// One per instance, built at initialisation: the size difference costs nothing per step.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum ModelRunner {
    A(RunnerA),
    B(RunnerB),
    /// Model 3: model A with per-axle lateral grip states.
    Grip(RunnerGrip),
}

/// Calls the same method of whichever runner runs.
macro_rules! on_runner {
    ($runner:expr, $r:ident => $call:expr) => {
        match $runner {
            ModelRunner::A($r) => $call,
            ModelRunner::B($r) => $call,
            ModelRunner::Grip($r) => $call,
        }
    };
}

impl ModelRunner {
    fn build(v: &Variables, start_time: f64) -> Result<Self, String> {
        Ok(match parameters::estimator_model(v)? {
            EstimatorModel::SingleTrack5State => Self::A(RunnerA::build(v, start_time)?),
            EstimatorModel::TwoTrack3State => Self::B(RunnerB::build(v, start_time)?),
            EstimatorModel::SingleTrackGrip => Self::Grip(RunnerGrip::build(v, start_time)?),
        })
    }

    /// The FMI 3 arrays (`state_estimate`, `state_covariance`, row-major) at the largest
    /// model's size, zero past the running model's states.
    fn fill_estimate(&self, value_reference: u32, values: &mut [f64]) {
        on_runner!(self, r => fill_estimate(r, value_reference, values))
    }

    fn read_state(v: &Variables, reader: &mut StateReader<'_>) -> Result<Self, StateError> {
        Ok(
            match parameters::estimator_model(v).map_err(StateError::new)? {
                EstimatorModel::SingleTrack5State => Self::A(RunnerA::read_state(v, reader)?),
                EstimatorModel::TwoTrack3State => Self::B(RunnerB::read_state(v, reader)?),
                EstimatorModel::SingleTrackGrip => Self::Grip(RunnerGrip::read_state(v, reader)?),
            },
        )
    }
}

/// Writes runner `r`'s state (`vr3::STATE_ESTIMATE`) or covariance (`vr3::STATE_COVARIANCE`,
/// scaled like the reported standard deviations) into `values`, an array of the largest
/// model's size.
fn fill_estimate<Model, const N: usize, const M: usize, const U: usize>(
    r: &runner::Runner<Model, N, M, U>,
    value_reference: u32,
    values: &mut [f64],
) where
    Model: runner::EstimationModel<N, M, U>,
{
    values.fill(0.0);
    let largest = if value_reference == model_description::vr3::STATE_COVARIANCE {
        (values.len() as f64).sqrt() as usize
    } else {
        values.len()
    };
    if value_reference == model_description::vr3::STATE_ESTIMATE {
        for (value, x) in values.iter_mut().zip(r.filter().state().iter()) {
            *value = *x;
        }
    } else if value_reference == model_description::vr3::STATE_COVARIANCE && N <= largest {
        let scale = r.covariance_scale();
        let p = r.filter().covariance();
        for i in 0..N {
            for j in 0..N {
                values[i * largest + j] = p[(i, j)] * scale;
            }
        }
    }
}

/// The VehicleStateEstimator FMU.
#[derive(Clone, Debug)]
pub struct VehicleStateEstimator {
    variables: Variables,
    runner: Option<ModelRunner>,
    /// The latest doStep processed a sample, so its `status` includes the publish bits.
    status_awaits_publish: bool,
    /// An input was clamped into its range since the last doStep (status bit 1024).
    input_clamped: bool,
    /// The parameters as set when the filter was built or last retuned (the tunable ones are
    /// compared with the current values before each doStep).
    applied: Option<Box<Variables>>,
    /// Which sensor inputs have had a finite value, and whether the first doStep has told the
    /// importer about those that never had ([`UnconnectedSensors`]).
    sensors_seen: UnconnectedSensors,
}

/// The sensor inputs an importer never set. Every sensor input starts at NaN (XML), the value
/// the filter reads as "sample missing", so an input a master leaves unconnected is treated as
/// missing rather than as a measurement of its start value; the first doStep logs a notice
/// (the step answers fmi2OK: importers such as FMI++ stop their clock after an fmi2Warning)
/// naming each measurement-row sensor (gyro, lateral accelerometer, wheel speeds) that has not
/// had a finite value yet, once, so that a user sees a mapping left out instead of a silently
/// worse estimate. `vx_meas` and `ax_meas` are optional by design (the filter falls back to the
/// wheels and to unknown torques), so leaving them out is no notice.
#[derive(Clone, Copy, Debug, Default)]
struct UnconnectedSensors {
    /// `[yaw_rate, ay, omega_front, omega_rear, vx, ax]`, in [`Sensors::values`] order.
    finite: [bool; SENSOR_COUNT],
    reported: bool,
}

/// The sensors of the measurement rows, the first of [`SENSOR_NAMES`].
const REQUIRED_SENSORS: usize = 4;

/// The sensor inputs' names, in [`Sensors::values`] order.
const SENSOR_NAMES: [&str; SENSOR_COUNT] = [
    "yaw_rate_meas",
    "ay_meas",
    "omega_front_meas",
    "omega_rear_meas",
    "vx_meas",
    "ax_meas",
];

impl UnconnectedSensors {
    fn see(&mut self, sensors: &Sensors) {
        for (seen, value) in self.finite.iter_mut().zip(sensors.values()) {
            *seen |= value.is_finite();
        }
    }

    /// The notice of the first doStep, if some sensor input never had a finite value.
    fn first_report(&mut self) -> Option<String> {
        if std::mem::replace(&mut self.reported, true) {
            return None;
        }
        let missing: Vec<String> = SENSOR_NAMES
            .iter()
            .zip(self.finite)
            .take(REQUIRED_SENSORS)
            .filter(|(_, seen)| !seen)
            .map(|(name, _)| format!("{name} not connected: treated as missing"))
            .collect();
        (!missing.is_empty()).then(|| missing.join("; "))
    }
}

impl VehicleStateEstimator {
    /// The running estimator (for tests and benchmarks).
    pub fn runner(&self) -> Option<&ModelRunner> {
        self.runner.as_ref()
    }

    /// Stores the outputs of the sample just processed, to be computed at the next read.
    fn defer_publish(&mut self) {
        let awaits = self.status_awaits_publish;
        if let Some(runner) = &mut self.runner {
            on_runner!(runner, r => r.defer_publish(&mut self.variables, awaits));
        }
    }

    /// Writes the pending outputs (see `Runner::publish`).
    fn publish(&mut self) {
        let awaits = self.status_awaits_publish;
        if let Some(runner) = &mut self.runner {
            on_runner!(runner, r => r.publish(&mut self.variables, awaits));
        }
        self.status_awaits_publish = false;
    }
}

/// The value references of the Real parameters the XML declares `tunable`.
fn tunable_parameters() -> &'static [u32] {
    static TUNABLE: std::sync::OnceLock<Vec<u32>> = std::sync::OnceLock::new();
    TUNABLE.get_or_init(|| {
        model_description::VARIABLES
            .iter()
            .filter(|v| {
                v.variability == fmi_export::Variability::Tunable
                    && v.value_type == fmi_export::ValueType::Real
            })
            .map(|v| v.value_reference)
            .collect()
    })
}

impl VehicleStateEstimator {
    /// Tunable parameters set since the filter was built take effect from the next filter
    /// sample (FMI 2.0 §2.2.7: a tunable parameter may change after initialisation; the XML
    /// documents the moment): the runner is retuned when any differs from what it runs with.
    fn apply_tuned_parameters(&mut self) -> Result<(), String> {
        use fmi_export::VariableStore;
        let (Some(runner), Some(applied)) = (self.runner.as_mut(), self.applied.as_mut()) else {
            return Ok(());
        };
        let v = &self.variables;
        let changed = tunable_parameters()
            .iter()
            .any(|&vr| v.real(vr).map(f64::to_bits) != applied.real(vr).map(f64::to_bits));
        if !changed {
            return Ok(());
        }
        on_runner!(runner, r => r.retune(v))
            .map_err(|error| format!("tunable parameter set during the run: {error}"))?;
        (**applied).clone_from(v);
        Ok(())
    }
}

impl CoSimulationModel for VehicleStateEstimator {
    type Variables = Variables;
    const MODEL_IDENTIFIER: &'static str = model_description::MODEL_IDENTIFIER;
    const GUID: &'static str = model_description::GUID;
    const VARIABLES: &'static [fmi_export::VariableInfo] = model_description::VARIABLES;
    const LOG_CATEGORIES: &'static [&'static str] = model_description::LOG_CATEGORIES;
    const FMI3_VARIABLES: &'static [fmi_export::Fmi3Variable] = model_description::FMI3_VARIABLES;
    const OUTPUT_DEPENDENCIES: &'static [(u32, &'static [u32])] =
        model_description::OUTPUT_DEPENDENCIES;

    fn fmi3_float64(&self, value_reference: u32, values: &mut [f64]) -> bool {
        use model_description::vr3;
        if value_reference != vr3::STATE_ESTIMATE && value_reference != vr3::STATE_COVARIANCE {
            return false;
        }
        match &self.runner {
            Some(runner) => {
                runner.fill_estimate(value_reference, values);
            }
            None => values.fill(0.0),
        }
        true
    }

    fn fmi3_int32(&self, value_reference: u32) -> Option<i32> {
        (value_reference == model_description::vr3::STATE_DIMENSION).then(|| {
            let count = |runner: &ModelRunner| on_runner!(runner, r => r.filter().state().len());
            self.runner.as_ref().map_or(0, count) as i32
        })
    }

    /// One filter step per sample: fmi-export bounds the samples one doStep may process
    /// (a doStep of 1e6 s ran 1e9 filter steps, about half an hour).
    fn internal_step_size(&self) -> Option<f64> {
        Some(self.variables.sample_time)
    }

    fn instantiate(_context: &InstantiationContext) -> Self {
        Self {
            variables: Variables::default(),
            runner: None,
            status_awaits_publish: false,
            input_clamped: false,
            applied: None,
            sensors_seen: UnconnectedSensors::default(),
        }
    }

    fn value_adjusted(&mut self, variable: &'static fmi_export::VariableInfo) {
        // Parameters are clamped before initialisation and reported there by the fmi2Warning;
        // the status bit is about the inputs the filter consumes during the run.
        self.input_clamped |= variable.causality == fmi_export::Causality::Input;
    }

    fn variables(&self) -> &Variables {
        &self.variables
    }

    fn variables_mut(&mut self) -> &mut Variables {
        &mut self.variables
    }

    fn initialize(&mut self, start_time: f64) -> Result<(), String> {
        let mut runner = ModelRunner::build(&self.variables, start_time)?;
        let sensors = Sensors::of(&self.variables);
        self.sensors_seen = UnconnectedSensors::default();
        self.sensors_seen.see(&sensors);
        self.variables.status = on_runner!(&mut runner, r => r.initialisation_bits(&sensors));
        self.runner = Some(runner);
        self.applied = Some(Box::new(self.variables.clone()));
        self.defer_publish();
        self.status_awaits_publish = true;
        // Initialisation is not the hot path: publish at once.
        self.publish();
        Ok(())
    }

    fn do_step(&mut self, current_time: f64, step_size: f64) -> StepOutcome {
        if let Err(message) = self.apply_tuned_parameters() {
            return StepOutcome::Error(message);
        }
        let v = &self.variables;
        let driver = [
            v.steering_angle,
            v.drive_torque,
            v.brake_torque,
            v.drive_torque_rear,
        ];
        let sensors = Sensors::of(v);
        self.sensors_seen.see(&sensors);
        let Some(runner) = self.runner.as_mut() else {
            return StepOutcome::Error(String::from("the estimator was not initialised"));
        };
        let mut bits = 0;
        if std::mem::take(&mut self.input_clamped) {
            bits |= status::INPUT_CLAMPED;
        }
        let (sample_bits, processed) = on_runner!(runner, r => {
            for (i, value) in driver.into_iter().enumerate() {
                if value.is_finite() {
                    r.input[i] = value;
                } else {
                    bits |= status::INPUT_HELD;
                }
            }
            r.advance(current_time, step_size, &sensors)
        });
        bits |= sample_bits;
        if processed {
            self.defer_publish();
        }
        self.variables.status = bits;
        self.status_awaits_publish = processed;
        match self.sensors_seen.first_report() {
            Some(notice) => StepOutcome::Notice(notice),
            None => StepOutcome::Ok,
        }
    }

    fn refresh_outputs(&mut self) {
        self.publish();
    }

    fn write_state(&self, writer: &mut StateWriter) -> Result<(), String> {
        match &self.runner {
            None => writer.bool(false),
            Some(runner) => {
                writer.bool(true);
                on_runner!(runner, r => r.write_state(writer));
            }
        }
        Ok(())
    }

    fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        // The outputs were published before the state was taken (see `refresh_outputs`); a
        // restored run has passed its first doStep.
        self.status_awaits_publish = false;
        self.sensors_seen.reported = true;
        self.runner = if reader.bool("estimator present")? {
            Some(ModelRunner::read_state(&self.variables, reader)?)
        } else {
            None
        };
        // The restored filter was built from the restored parameters.
        self.applied = self
            .runner
            .as_ref()
            .map(|_| Box::new(self.variables.clone()));
        Ok(())
    }
}

fmi_export::export_fmi2!(VehicleStateEstimator);
fmi_export::export_fmi3!(VehicleStateEstimator);
