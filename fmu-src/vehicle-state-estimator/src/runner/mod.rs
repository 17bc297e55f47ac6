//! The estimator between samples, written once for every estimation model: the filter from
//! the `estimation` registry, the sample clock, the last finite driver input and the outputs
//! still to be computed. What differs between the models (how the sensors become a measurement
//! and an input, how the outputs are derived) is the [`EstimationModel`] trait.

mod fmu_state;
mod gate;
mod guard;
mod kinematic;
mod kinematic_check;
mod noise;
mod outputs;

use std::fmt::Debug;

use estimation::adaptive::{AdaptationStatus, Correction, NoiseAdaptation, MAX_WINDOW, MIN_WINDOW};
use estimation::innovation_monitor::InnovationMonitor;
use estimation::innovation_scaling::InnovationScaling;
use estimation::kalman::InitialEstimate;
use estimation::measurement_noise::NoiseMatching;
use estimation::registry::{
    self, BoxedEstimator, EstimatorChoice, EstimatorSettings, RegistryModel,
};
use estimation::{FilterIssue, UpdateReport};
use fmi_export::{StateError, StateReader, StateWriter};
use nalgebra::{SMatrix, SVector};

use crate::lateral_accelerometer::{AySample, LateralAccelerometer};
use crate::model_description::{RealOutputs, Variables};
use crate::parameters::{self, positive};
use crate::rolling_radius::{RadiusSample, RollingRadius};
use crate::status;
use crate::yaw_rate_offset::{OffsetSample, YawRateOffset};

pub(crate) use crate::estimation_model::ay_model_error_noise;
pub use crate::estimation_model::{
    InputVector, OutputSample, Sample, DRIVER_DIM, REAR_DRIVE_TORQUE,
};
pub use crate::sensors::{MeasuredSpeed, Measurements, Sensors, WheelRadii};
pub use gate::ChiSquareGate;
use gate::{innovation_window, Gate, InnovationWindow};
pub(crate) use outputs::stiffness_consider;
pub use outputs::{kinematic_sideslip, LOW_SPEED_SIDESLIP_STD};

/// One estimation model as the FMU runs it: `N` states, `M` measurements, `U` filter inputs.
pub trait EstimationModel<const N: usize, const M: usize, const U: usize>:
    RegistryModel<N, M, U>
{
    /// What the runner keeps beside the filter (model B: the speed input and the wheel speeds
    /// it passes through); part of the FMU state.
    type Extra: Clone + Copy + Debug + Send;

    /// Whether the model's filter estimates the lateral accelerometer's gain error itself (the
    /// grip model's `ay_gain` state, with `ay_gain_std` as its prior): the runner's learner
    /// (`lateral_accelerometer`) then learns the offset only, and the model reports
    /// `ay_gain_est`.
    const ESTIMATES_AY_GAIN: bool = false;

    /// Whether the model's filter estimates its tyres' force scale with a covariance that
    /// follows it (the grip model's EKF, UKFs and re-linearised LKF), so the reported std
    /// already holds the stiffness uncertainty that `runner::outputs::with_stiffness_consider` adds for the
    /// others, and the runner leaves that term out. `relinearised`: the linear estimators are
    /// gain-scheduled (their schedule threshold is above 0).
    fn estimates_tyre_scale(_choice: EstimatorChoice, _relinearised: bool) -> bool {
        false
    }

    /// The model from the parameters.
    fn from_parameters(v: &Variables) -> Result<Self, String>;

    /// The filter's start from the parameters.
    fn initial_estimate(v: &Variables) -> Result<InitialEstimate<N>, String>;

    /// The registry's settings from the parameters.
    fn registry_settings(&self, v: &Variables) -> EstimatorSettings<N, U>;

    /// The extra values before the first sample.
    fn start_extra(v: &Variables, min_speed: f64) -> Self::Extra;

    /// The measurement and input of one sample, or the status bits of a sample on which the
    /// filter holds. May re-seed the filter (`runner.rebuild`).
    fn sample(runner: &mut Runner<Self, N, M, U>, sensors: &Sensors) -> Result<Sample<M, U>, i32>;

    /// Where each measurement row is physically plausible, for the gate (a broken sample never re-seeds);
    /// `state` is the predicted estimate.
    /// `measurement_std` is each row's noise std as the filter uses it (learned or tuned), so
    /// that a limit can widen with a sensor's own noise.
    fn plausible(
        &self,
        sensors: &Sensors,
        state: &SVector<f64, N>,
        min_speed: f64,
        measurement_std: &[f64; M],
    ) -> [bool; M];

    /// The rows whose persistent disagreement with the model is the model's error, not the
    /// sensor's: inertial sensors (gyro, accelerometer) the model predicts from its states. The
    /// gate tests such a row about the median of its recent innovations (`runner::gate::InnovationWindow`),
    /// so that it is used again once the model's error has lasted a window; the other rows keep
    /// the plain test, since a wheel speed that disagrees for long is a locked or spinning wheel
    /// and must stay out.
    fn model_error_rows(&self) -> [bool; M];

    /// The rows of the gyro and the lateral accelerometer in the measurement vector.
    fn sensor_rows(&self) -> SensorRows;

    /// Whether the gate watches the gyro for a filter that has drifted off the car
    /// (`runner::gate::LOST_SIGMAS`): the gyro measures a state directly, so a lasting
    /// disagreement far beyond its noise is the filter's, not the car's.
    fn watches_gyro(&self) -> bool {
        true
    }

    /// Whether the model can take a model-error row's persistent disagreement as its own error
    /// at the predicted estimate `state` (`jacobian` = `∂h/∂x` there): where it cannot, the row
    /// gets the plain test, as every other row. The default: always.
    fn model_error_resolvable(
        &self,
        _state: &SVector<f64, N>,
        _input: &SVector<f64, U>,
        _jacobian: &SMatrix<f64, M, N>,
    ) -> bool {
        true
    }

    /// The start from the sensors of one sample (`start_from_measurements`, and the re-seed
    /// after a lock-out), or `None` while they show no speed of at least `min_speed`.
    fn measured_start(
        runner: &Runner<Self, N, M, U>,
        sensors: &Sensors,
    ) -> Option<InitialEstimate<N>>;

    /// Completes a start from the measurements on re-admission (`start` from
    /// [`Self::measured_start`]) with what the sensors do not measure, from the estimate the
    /// filter had (`current`). The default keeps the measured start as it is.
    fn readmitted_start(&self, _current: &SVector<f64, N>, _start: &mut InitialEstimate<N>) {}

    /// The operating point's state for the linear estimators (LKF, Luenberger) when the filter
    /// starts at `start` from the measurements: straight driving at the measured speed, instead
    /// of a parameter's guess. `None` keeps the parameters' operating point.
    fn operating_state_at(&self, _start: &SVector<f64, N>) -> Option<SVector<f64, N>> {
        None
    }

    /// The input the linear estimators are linearised about when gain scheduling re-schedules
    /// them in a sample with the filter input `sample` (`schedule_threshold`); `operating` is
    /// the input of the operating point from the parameters. The default is the sample's input.
    fn scheduling_input(
        &self,
        _operating: &SVector<f64, U>,
        sample: &SVector<f64, U>,
    ) -> SVector<f64, U> {
        *sample
    }

    /// Extra process noise for the coming sample, added to the covariance just predicted
    /// (model A: the wheels' slip while the torques are unknown, `unknown_torque_slip_std`, and
    /// the wheels' sliding step at low speed); `state` is the predicted estimate, `input` the
    /// sample's driver input, `filter_input` the filter's input of the sample (with what the
    /// sensors add, e.g. model A's measured `ax`), `measured_wheels` which of
    /// `[omega_front_meas, omega_rear_meas]` the sample measures. Estimators without a
    /// covariance (particle filter, Luenberger observer) ignore it.
    fn extra_process_noise(
        &self,
        _state: &SVector<f64, N>,
        _input: &InputVector,
        _filter_input: &SVector<f64, U>,
        _measured_wheels: [bool; 2],
        _v: &Variables,
    ) -> Option<SMatrix<f64, N, N>> {
        None
    }

    /// Extra measurement noise for this sample's update only, added to `R` (and to the gate's
    /// `S`; model B: the `ay` row's model error, [`ay_model_error_noise`]); `state`
    /// is the predicted estimate, `input` the sample's filter input. The Luenberger observer's
    /// fixed gain ignores it (its reported covariance does not).
    fn extra_measurement_noise(
        &self,
        _state: &SVector<f64, N>,
        _input: &SVector<f64, U>,
        _v: &Variables,
    ) -> Option<SMatrix<f64, M, M>> {
        None
    }

    /// The sideslip at the centre of gravity at `state` and its variance from `covariance`
    /// (to first order), rad and rad², for the integrity guard (`runner::guard`).
    fn sideslip_of(&self, state: &SVector<f64, N>, covariance: &SMatrix<f64, N, N>) -> (f64, f64);

    /// Puts the sideslip of `estimate` to `sideslip` with the variance `variance`, uncorrelated
    /// with the other states (the guard's re-seed).
    fn reseed_sideslip(&self, estimate: &mut InitialEstimate<N>, sideslip: f64, variance: f64);

    /// The rear axle's grip factor the model has learned at `state` (1 where it has none).
    fn rear_grip(&self, _state: &SVector<f64, N>) -> f64 {
        1.0
    }

    /// The outputs of one sample's result, as the filter's state and covariance give them; the
    /// runner adds the rear stiffness's consider term (`runner::outputs::with_stiffness_consider`).
    fn outputs(&self, sample: &OutputSample<N, Self::Extra>, v: &Variables) -> RealOutputs;

    /// The rate of the rear slip angle at the sample's estimate, rad/s, as the model's own
    /// derivatives give it, for models whose tyres build their force at once while a car's lag
    /// (the runner's tyre-lag consider term, `runner::outputs::with_stiffness_consider`); `None`: no such term.
    fn rear_slip_angle_rate(&self, _sample: &OutputSample<N, Self::Extra>) -> Option<f64> {
        None
    }

    fn write_extra(extra: &Self::Extra, writer: &mut StateWriter);

    fn read_extra(extra: &mut Self::Extra, reader: &mut StateReader<'_>) -> Result<(), StateError>;
}

/// Where the gyro and the lateral accelerometer are in a model's measurement vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SensorRows {
    pub yaw_rate: usize,
    pub ay: usize,
}

fn issue_bit(issue: FilterIssue) -> i32 {
    match issue {
        FilterIssue::CovarianceRepaired => status::COVARIANCE_REPAIRED,
        FilterIssue::UpdateSkipped => status::UPDATE_SKIPPED,
        FilterIssue::StateReset => status::STATE_RESET,
        FilterIssue::WeightsReset => status::WEIGHTS_RESET,
    }
}

pub(crate) fn finite_or(value: f64, fallback: f64) -> f64 {
    if value.is_finite() {
        value
    } else {
        fallback
    }
}

/// Status bits 4096 (adapting) and 8192 (inconsistent) of an adaptation's state.
fn adaptation_bits(state: AdaptationStatus) -> i32 {
    let adapting = i32::from(state.adapting) * status::ADAPTING;
    adapting | (i32::from(state.inconsistent) * status::INCONSISTENT)
}

/// The window of the Luenberger observer's innovation scaling
/// (`estimation::innovation_scaling`), in seconds. Measured on the mismatch campaigns (harness
/// robustness, Luenberger_A's 15 rows with a sideslip NEES in 0.5-2 and 90 % inside, offline on the recorded NIS):
/// no scaling 1, 1 s 10, 1.5 s 9, 2 s 8, 3 s 7: a longer window lags behind the manoeuvre's
/// transients (a shorter one sums fewer degrees of freedom, so its ratio scatters more).
const OBSERVER_SCALING_WINDOW: f64 = 1.0;

/// [`OBSERVER_SCALING_WINDOW`] in samples, at least the least window the scaling takes.
fn observer_scaling_window(sample_time: f64) -> usize {
    window_samples(OBSERVER_SCALING_WINDOW, sample_time)
}

/// The window of the innovation monitor (`estimation::innovation_monitor`), s: as long as the
/// observer's scaling window, about a manoeuvre's transient, so that a filter that leaves the
/// car is flagged within a second while one update's outlier is not.
const INNOVATION_MONITOR_WINDOW: f64 = 1.0;

/// `seconds` in samples, within the windows a moving NIS sum takes.
fn window_samples(seconds: f64, sample_time: f64) -> usize {
    let samples = (seconds / sample_time).round();
    samples.clamp(MIN_WINDOW as f64, MAX_WINDOW as f64) as usize
}

/// The schedule threshold of the estimator `choice`: `observer_schedule_threshold` for the
/// Luenberger observer, `schedule_threshold` for the others (only the LKF uses it), finite and at
/// least 0.
fn schedule_threshold(v: &Variables, choice: EstimatorChoice) -> Result<f64, String> {
    if choice == EstimatorChoice::Luenberger {
        non_negative("observer_schedule_threshold", v.observer_schedule_threshold)
    } else {
        non_negative("schedule_threshold", v.schedule_threshold)
    }
}

/// A sensor learner after a retune: what it has learned (`current`) with `tuned`'s settings, or
/// `tuned` as it starts where there was none; `None` where the tuned parameters switch it off.
fn carried_over<T: Copy>(current: Option<T>, tuned: Option<T>, carry: fn(&T, T) -> T) -> Option<T> {
    match (current, tuned) {
        (Some(current), Some(tuned)) => Some(carry(&current, tuned)),
        (_, tuned) => tuned,
    }
}

/// A parameter that must be finite and at least 0.
fn non_negative(name: &str, value: f64) -> Result<f64, String> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(format!(
            "parameter {name} = {value}; expected a finite value >= 0"
        ))
    }
}

/// How many doSteps with a sample may pass without an output read before the outputs are
/// computed anyway (bounds the memory; one evaluation per this many doSteps).
const PENDING_CAPACITY: usize = 8;

/// The estimator of one model between samples.
#[derive(Clone, Debug)]
pub struct Runner<Model, const N: usize, const M: usize, const U: usize>
where
    Model: EstimationModel<N, M, U>,
{
    pub(crate) model: Model,
    pub(crate) filter: BoxedEstimator<N, M, U>,
    choice: EstimatorChoice,
    settings: EstimatorSettings<N, U>,
    pub(crate) extra: Model::Extra,
    sample_time: f64,
    start_time: f64,
    /// Index of the next sample to process, at `start_time + next_sample * sample_time`.
    next_sample: u64,
    pub(crate) input: InputVector,
    pub(crate) min_speed: f64,
    pub(crate) nis: f64,
    pub(crate) rows_used: i32,
    /// The last sample held the estimate (for its outputs; not part of the FMU state, whose
    /// outputs are published before it is taken).
    holding: bool,
    /// What the sensors measured in the last sample (for its outputs, like `holding`: a held
    /// sample reports it, and the grip model tells a measured wheel from one it only models).
    measured: Measurements,
    gate: Option<Gate>,
    /// `schedule_threshold` (the LKF) or `observer_schedule_threshold` (the Luenberger
    /// observer): the linear estimators re-linearise when their linearisation errs at the
    /// estimate by more than this many noise standard deviations; 0 never.
    schedule_threshold: f64,
    /// Samples in a row for which each plausible row was gated (FMU state).
    gated_samples: [u64; M],
    /// Samples in a row for which the gyro was far off the estimate
    /// (`runner::gate::LOST_SIGMAS`; FMU state).
    lost_samples: u64,
    /// The recent innovations of each model-error row while gating (FMU state).
    innovations: [Option<InnovationWindow>; M],
    /// The filter has started: from the parameters, or with `start_from_measurements` from the
    /// first sample that showed a speed (FMU state).
    started: bool,
    /// The parameters, to rebuild the filter when it has to be re-seeded and for the outputs.
    pub(crate) parameters: Box<Variables>,
    /// The derived outputs (slip quantities, ay, standard deviations, sideslip) cost about as
    /// much as a filter step, so they are computed lazily: each doStep that processed a sample
    /// stores what its outputs are computed from, and the first output read (`publish`)
    /// computes them. The values are exactly those of publishing after every doStep: an output
    /// that is not finite keeps its previous value, so the samples since the last publish are
    /// kept and a non-finite output is looked up in the older ones, newest first.
    pending: Vec<OutputSample<N, Model::Extra>>,
    /// The adaptive process noise (`adaptive_process_noise`; FMU state).
    adaptation: Option<NoiseAdaptation<N>>,
    /// The Luenberger observer's reported covariance scaled to its innovations (FMU state).
    observer_scaling: Option<InnovationScaling>,
    /// Status bit 8192 for the filters whose covariance neither the adaptation nor the
    /// observer's scaling already tests (`estimation::innovation_monitor`).
    innovation_monitor: Option<InnovationMonitor>,
    /// Each row's noise variance learned from the innovations (`learn_measurement_noise`;
    /// FMU state).
    noise: Option<NoiseMatching<M>>,
    /// The integrity guard's car (`integrity_guard`), and the samples in a row the estimate
    /// has been outside its reference (FMU state).
    guard_car: Option<guard::GuardCar>,
    guard_samples: u32,
    /// Status bit 32768: the sideslip estimate against the kinematics (`kinematic_check`).
    kinematic_check: kinematic_check::KinematicCheck,
    /// The low-speed regime's car (`low_speed_kinematics`, `runner::kinematic`).
    kinematic_car: Option<guard::GuardCar>,
    /// The gyro's offset, taken off `yaw_rate_meas` before the filter sees it
    /// (`yaw_rate_offset_std`; FMU state).
    yaw_rate_offset: Option<YawRateOffset>,
    /// The lateral accelerometer's offset and gain, taken off `ay_meas` before the filter sees
    /// it (`ay_offset_std`, `ay_gain_std`; FMU state).
    lateral_accelerometer: Option<LateralAccelerometer>,
    /// The wheels' effective rolling radii, the wheel speeds corrected with them before the
    /// filter sees them (`wheel_radius_std`; FMU state).
    rolling_radius: Option<RollingRadius>,
}

impl<Model, const N: usize, const M: usize, const U: usize> Runner<Model, N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    pub fn build(v: &Variables, start_time: f64) -> Result<Self, String> {
        let v = &parameters::with_spectral_densities(v)?;
        let model = Model::from_parameters(v)?;
        let initial = Model::initial_estimate(v)?;
        let (kind, choice) = parameters::estimator_choice(v)?;
        let settings = model.registry_settings(v);
        let filter = registry::build(model.clone(), choice, &settings, &initial).map_err(|e| {
            let model_item = parameters::estimator_model(v).map_or("?", |m| m.name());
            format!(
                "parameter estimator = {} ({}) with model = {} ({model_item}): {}",
                i32::from(kind),
                kind.name(),
                v.model,
                e.0
            )
        })?;
        let min_speed = positive("min_speed", v.min_speed)?;
        non_negative("ay_model_error", v.ay_model_error)?;
        non_negative(
            "cornering_stiffness_uncertainty",
            v.cornering_stiffness_uncertainty,
        )?;
        let sample_time = positive("sample_time", v.sample_time)?;
        let gate = if v.gate_measurements {
            let readmit_time = finite_or(v.readmit_time, -1.0);
            if readmit_time < 0.0 {
                return Err(format!(
                    "parameter readmit_time = {}; expected a time >= 0 s",
                    v.readmit_time
                ));
            }
            Some(Gate {
                test: ChiSquareGate {
                    threshold: positive("gate_threshold", v.gate_threshold)?,
                    readmit_samples: (readmit_time / sample_time).ceil().max(1.0) as u64,
                },
                window: innovation_window(sample_time),
            })
        } else {
            None
        };
        let adaptation = parameters::adaptation(v)?
            .map(NoiseAdaptation::new)
            .transpose()
            .map_err(|e| e.0)?;
        let observer_scaling = (choice == EstimatorChoice::Luenberger)
            .then(|| InnovationScaling::new(observer_scaling_window(sample_time)))
            .transpose()
            .map_err(|e| e.0)?;
        // Status bit 8192 comes from whichever of the three tests the innovations.
        let innovation_monitor = (adaptation.is_none() && observer_scaling.is_none())
            .then(|| InnovationMonitor::new(window_samples(INNOVATION_MONITOR_WINDOW, sample_time)))
            .transpose()
            .map_err(|e| e.0)?;
        let error_rows = model.model_error_rows();
        let innovations = std::array::from_fn(|row| {
            gate.filter(|_| error_rows[row])
                .map(|gate| InnovationWindow::new(gate.window))
        });
        let noise = noise::learner(v, &model, sample_time, choice);
        Ok(Self {
            extra: Model::start_extra(v, min_speed),
            model,
            filter,
            choice,
            settings,
            sample_time,
            start_time,
            next_sample: 0,
            input: InputVector::new(
                finite_or(v.steering_angle, 0.0),
                finite_or(v.drive_torque, 0.0),
                finite_or(v.brake_torque, 0.0),
                finite_or(v.drive_torque_rear, 0.0),
            ),
            min_speed,
            nis: 0.0,
            rows_used: 0,
            holding: false,
            measured: Measurements::default(),
            gate,
            schedule_threshold: schedule_threshold(v, choice)?,
            gated_samples: [0; M],
            lost_samples: 0,
            innovations,
            started: !v.start_from_measurements,
            parameters: Box::new(v.clone()),
            pending: Vec::with_capacity(PENDING_CAPACITY),
            adaptation,
            noise,
            guard_car: v.integrity_guard.then(|| guard::guard_car(v)).transpose()?,
            guard_samples: 0,
            kinematic_check: kinematic_check::KinematicCheck::new(sample_time),
            kinematic_car: kinematic::kinematic_car(v)?,
            observer_scaling,
            innovation_monitor,
            yaw_rate_offset: YawRateOffset::from_parameters(v)?,
            lateral_accelerometer: LateralAccelerometer::from_parameters(
                v,
                !Model::ESTIMATES_AY_GAIN,
            )?,
            rolling_radius: RollingRadius::from_parameters(v)?,
        })
    }

    /// Takes the tunable parameters of `v` (XML variability `tunable`: the noise levels, the
    /// gate, the cornering-stiffness scales) from the next sample on: the model, the settings
    /// and the gate are built from `v` as at initialisation, and the filter continues from its
    /// current estimate and covariance (the particle filter redraws its particles from them).
    /// The linear estimators keep the operating point they run at.
    pub fn retune(&mut self, v: &Variables) -> Result<(), String> {
        let tuned = Self::build(v, self.start_time)?;
        let current = InitialEstimate {
            state: *self.filter.state(),
            covariance: *self.filter.covariance(),
        };
        let operating_point = self.settings.operating_point.clone();
        self.model = tuned.model;
        self.settings = tuned.settings;
        self.settings.operating_point = operating_point;
        self.gate = tuned.gate;
        self.parameters = tuned.parameters;
        self.yaw_rate_offset = carried_over(
            self.yaw_rate_offset,
            tuned.yaw_rate_offset,
            YawRateOffset::retuned,
        );
        self.rolling_radius = carried_over(
            self.rolling_radius,
            tuned.rolling_radius,
            RollingRadius::retuned,
        );
        self.guard_car = tuned.guard_car;
        self.kinematic_car = tuned.kinematic_car;
        self.noise = match (&self.noise, tuned.noise) {
            (Some(current), Some(tuned)) => Some(current.retuned_as(&tuned)),
            (_, tuned) => tuned,
        };
        self.lateral_accelerometer = carried_over(
            self.lateral_accelerometer,
            tuned.lateral_accelerometer,
            LateralAccelerometer::retuned,
        );
        if self.rebuild(&current) {
            Ok(())
        } else {
            Err(String::from(
                "the estimator cannot continue from its estimate with the tuned parameters",
            ))
        }
    }

    /// The gate's test (`gate_measurements`), for a model's own tests of a measurement outside
    /// the filter (the speed filter of models A and B).
    pub(crate) fn speed_gate(&self) -> Option<ChiSquareGate> {
        self.gate.map(|gate| gate.test)
    }

    /// Whether the running filter's covariance carries its tyres' force scale
    /// ([`EstimationModel::estimates_tyre_scale`]).
    pub(crate) fn estimates_tyre_scale(&self) -> bool {
        Model::estimates_tyre_scale(self.choice, self.schedule_threshold > 0.0)
    }

    /// The factor on the covariance the estimator reports ([`OutputSample::covariance_scale`]).
    pub(crate) fn covariance_scale(&self) -> f64 {
        self.observer_scaling.as_ref().map_or(1.0, |s| s.scale())
    }

    /// The running filter (for tests and benchmarks).
    pub fn filter(&self) -> &BoxedEstimator<N, M, U> {
        &self.filter
    }

    /// Replaces the filter by a new one of the same kind and settings started at `initial`;
    /// returns whether that worked.
    pub(crate) fn rebuild(&mut self, initial: &InitialEstimate<N>) -> bool {
        match registry::build(self.model.clone(), self.choice, &self.settings, initial) {
            Ok(rebuilt) => {
                self.filter = rebuilt;
                true
            }
            Err(_) => false,
        }
    }

    /// [`Self::rebuild`] from a start taken from the measurements, the linear estimators
    /// linearised about straight driving at the measured speed
    /// ([`EstimationModel::operating_state_at`]).
    fn rebuild_at_measured(&mut self, initial: &InitialEstimate<N>) -> bool {
        if let (Some(state), Ok((_, input))) = (
            self.model.operating_state_at(&initial.state),
            &self.settings.operating_point,
        ) {
            self.settings.operating_point = Ok((state, *input));
        }
        self.reseed(initial)
    }

    /// [`Self::rebuild`] for a filter that lost its estimate (or starts): the gate forgets the
    /// innovations of the old estimate.
    pub(crate) fn reseed(&mut self, initial: &InitialEstimate<N>) -> bool {
        let rebuilt = self.rebuild(initial);
        if rebuilt {
            self.innovations
                .iter_mut()
                .flatten()
                .for_each(InnovationWindow::clear);
        }
        rebuilt
    }

    /// The sensors as the filters take them: the wheels' rolling radii, the gyro's offset and
    /// the lateral accelerometer's offset and gain learned from this sample
    /// ([`crate::rolling_radius`], [`crate::yaw_rate_offset`], [`crate::lateral_accelerometer`])
    /// and taken off their signals.
    fn calibrated(&mut self, sensors: &Sensors) -> Sensors {
        let mut corrected = *sensors;
        if let Some(radius) = self.rolling_radius.as_mut() {
            let speed = MeasuredSpeed::vx_meas(sensors, &self.parameters).unwrap_or(f64::NAN);
            radius.step(&RadiusSample {
                omega: [sensors.omega_front, sensors.omega_rear],
                speed,
                ax: sensors.ax,
                ay: sensors.ay,
                yaw_rate: sensors.yaw_rate,
                steering: self.input[0],
            });
            [corrected.omega_front, corrected.omega_rear] =
                radius.corrected([sensors.omega_front, sensors.omega_rear]);
        }
        if self.yaw_rate_offset.is_none() && self.lateral_accelerometer.is_none() {
            return corrected;
        }
        let measured = MeasuredSpeed::of(sensors, &self.parameters);
        let all_zero = sensors.all_zero();
        let steering = self.input[0];
        if let Some(offset) = self.yaw_rate_offset.as_mut() {
            offset.step(&OffsetSample {
                yaw_rate: sensors.yaw_rate,
                ay: sensors.ay,
                all_zero,
                steering,
                speed: measured.map(|measured| (measured.speed, measured.std)),
            });
            corrected.yaw_rate -= offset.offset;
        }
        let ay_variance = self.measurement_variance(self.model.sensor_rows().ay);
        if let Some(accelerometer) = self.lateral_accelerometer.as_mut() {
            accelerometer.step(&AySample {
                ay: sensors.ay,
                yaw_rate: corrected.yaw_rate,
                all_zero,
                steering,
                speed: measured.map(|measured| measured.speed),
                ay_variance,
            });
            corrected.ay = accelerometer.corrected(sensors.ay);
        }
        corrected
    }

    /// One sample: measurement update with the sensors, then time update to the next sample.
    /// Returns the status bits of the sample.
    pub fn process_sample(&mut self, sensors: &Sensors) -> i32 {
        let corrected = self.calibrated(sensors);
        let sensors = &corrected;
        // the gyro's learned offset is already off the corrected yaw rate
        self.measured = Measurements::of(sensors, &self.parameters, 0.0);
        let mut bits = 0;
        self.holding = false;
        if !self.started {
            match Model::measured_start(self, sensors) {
                Some(initial) if self.rebuild_at_measured(&initial) => {
                    self.started = true;
                    bits |= status::INITIALISING;
                }
                _ => return self.hold(status::INITIALISING),
            }
        }
        let mut sample = match Model::sample(self, sensors) {
            Ok(sample) => sample,
            Err(hold_bits) => return self.hold(bits | hold_bits),
        };
        bits |= sample.bits;
        let offered_rows = sample.offered.iter().zip(sample.measurement.iter());
        if offered_rows
            .into_iter()
            .any(|(&offered, value)| offered && !value.is_finite())
        {
            bits |= status::ROW_SKIPPED;
        }
        // The model's extra noise at the predicted estimate, for the gate's S and the update's R:
        // evaluated once, again only if the gate re-seeded the filter to another estimate.
        self.learn_noise(sensors, &sample);
        let mut extra_noise = self.extra_measurement_noise(&sample.input);
        let (mut mask, gate_bits) = self.gate(sensors, &mut sample, extra_noise.as_ref());
        if gate_bits & status::SENSOR_READMITTED != 0 {
            extra_noise = self.extra_measurement_noise(&sample.input);
        }
        bits |= gate_bits;
        for (used, offered) in mask.iter_mut().zip(sample.offered) {
            *used &= offered;
        }
        // Non-finite rows are skipped by the filters themselves (SPEC §6).
        // The adaptation compares the update's correction with the variance it removed.
        let prior = self
            .adaptation
            .is_some()
            .then(|| (*self.filter.state(), *self.filter.covariance()));
        let report = match &extra_noise {
            Some(extra) => self.filter.update_with_extra_noise(
                &sample.measurement,
                &sample.input,
                &mask,
                extra,
            ),
            None => self
                .filter
                .update(&sample.measurement, &sample.input, &mask),
        };
        let report = report.unwrap_or_else(|issue| {
            bits |= issue_bit(issue);
            self.filter.last_report()
        });
        self.nis = report.nis;
        self.rows_used = report.rows_used as i32;
        let correction = prior.map(|(x, p)| {
            Correction::between((&x, &p), (self.filter.state(), self.filter.covariance()))
        });
        self.hold_to_kinematics(sensors);
        bits |= self.guard(sensors);
        bits |= self.check_kinematics(sensors);
        self.reschedule(&sample.input);
        if let Err(issue) = self.filter.predict(&sample.input) {
            bits |= issue_bit(issue);
        }
        if let Some(extra) = self.model.extra_process_noise(
            self.filter.state(),
            &self.input,
            &sample.input,
            [sensors.omega_front, sensors.omega_rear].map(f64::is_finite),
            &self.parameters,
        ) {
            self.filter.inflate_covariance(&extra);
        }
        bits | self.adapt(&report, correction.as_ref())
            | self.scale_observer(&report)
            | self.monitor_innovations(&report)
    }

    /// The kinematic check of the updated sideslip (`kinematic_check`); returns status bit
    /// 32768 while the estimate's change of `vy` is off the kinematic one.
    fn check_kinematics(&mut self, sensors: &Sensors) -> i32 {
        let speed = MeasuredSpeed::of(sensors, &self.parameters).map_or(f64::NAN, |s| s.speed);
        let (sideslip, _) = self
            .model
            .sideslip_of(self.filter.state(), self.filter.covariance());
        let off = self
            .kinematic_check
            .observe(sensors.ay, sensors.yaw_rate, speed, sideslip);
        i32::from(off) * status::OFF_THE_KINEMATICS
    }

    /// The innovation monitor: the update's NIS into its window; returns status bit 8192 while
    /// the window's NIS is above its 99.9 % quantile.
    fn monitor_innovations(&mut self, report: &UpdateReport<M>) -> i32 {
        let Some(monitor) = self.innovation_monitor.as_mut() else {
            return 0;
        };
        i32::from(monitor.observe(report)) * status::INCONSISTENT
    }

    /// The model's extra measurement noise at the filter's current (predicted) estimate, with
    /// what the noise learner adds to each row's tuned variance (`None`: nothing to add).
    fn extra_measurement_noise(&self, input: &SVector<f64, U>) -> Option<SMatrix<f64, M, M>> {
        let model = self.model_measurement_noise(input);
        let Some(learner) = &self.noise else {
            return model;
        };
        let mut extra = model.unwrap_or_else(SMatrix::zeros);
        let mut added = model.is_some();
        for row in 0..M {
            let excess = learner.excess(row);
            if excess > 0.0 {
                extra[(row, row)] += excess;
                added = true;
            }
        }
        added.then_some(extra)
    }

    /// The model's own extra measurement noise at the filter's current (predicted) estimate.
    fn model_measurement_noise(&self, input: &SVector<f64, U>) -> Option<SMatrix<f64, M, M>> {
        self.model
            .extra_measurement_noise(self.filter.state(), input, &self.parameters)
    }

    /// Gain scheduling of the linear estimators (`schedule_threshold`; the others ignore it):
    /// between the update and the prediction, so the prediction runs on a linearisation about
    /// the corrected estimate (see `RunningEstimator::reschedule`).
    fn reschedule(&mut self, input: &SVector<f64, U>) {
        if self.schedule_threshold == 0.0 {
            return;
        }
        if let Ok((_, operating)) = &self.settings.operating_point {
            let input = self.model.scheduling_input(operating, input);
            self.filter.reschedule(&input, self.schedule_threshold);
        }
    }

    /// The adaptive process noise (`adaptive_process_noise`, `estimation::adaptive`): the
    /// update's NIS and state correction into the window, the prior just predicted inflated by
    /// `diag((s_i − 1) Q_ii)`; returns status bits 4096 and 8192.
    fn adapt(&mut self, report: &UpdateReport<M>, correction: Option<&Correction<N>>) -> i32 {
        let (Some(adaptation), Some(correction)) = (self.adaptation.as_mut(), correction) else {
            return 0;
        };
        let process_noise = self.model.process_noise();
        let state = adaptation.observe(report, correction, &process_noise);
        if let Some(extra) = adaptation.inflation(&process_noise) {
            self.filter.inflate_covariance(&extra);
        }
        adaptation_bits(state)
    }

    /// The Luenberger observer's innovation scaling ([`OBSERVER_SCALING_WINDOW`]): the update's
    /// NIS into its window; returns status bits 4096 and 8192.
    fn scale_observer(&mut self, report: &UpdateReport<M>) -> i32 {
        let Some(scaling) = self.observer_scaling.as_mut() else {
            return 0;
        };
        adaptation_bits(scaling.observe(report))
    }

    /// Status bits of the outputs of initialisation, before any sample is processed: while
    /// the filter waits for its measured start (`start_from_measurements`), those outputs are
    /// the held ones of the sensors set so far (the measured speed, the steering geometry's
    /// sideslip with a std that says it is a guess), not the parameters' start (`vx_initial`)
    /// with its confident std, and `status` says the filter is initialising, so that no importer reads a guess as an estimate.
    pub fn initialisation_bits(&mut self, sensors: &Sensors) -> i32 {
        if self.started {
            0
        } else {
            let offset = self.yaw_rate_offset.map_or(0.0, |offset| offset.offset);
            self.measured = Measurements::of(sensors, &self.parameters, offset);
            self.hold(status::INITIALISING)
        }
    }

    /// A sample on which the filter holds its estimate (`measured` already this sample's).
    fn hold(&mut self, bits: i32) -> i32 {
        self.nis = 0.0;
        self.rows_used = 0;
        self.holding = true;
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
}
