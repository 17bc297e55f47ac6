//! What differs between the estimation models the runner drives: how the sensors become a
//! measurement and a filter input, which rows the gate treats as the model's error, and how the
//! outputs are derived ([`EstimationModel`]), with the types that cross that boundary.

use std::fmt::Debug;

use estimation::kalman::InitialEstimate;
use estimation::registry::{EstimatorChoice, EstimatorSettings, RegistryModel};
use fmi_export::{StateError, StateReader, StateWriter};
use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::INPUT_DIM;

use crate::model_description::{RealOutputs, Variables};
use crate::runner::Runner;
use crate::sensors::{HeldMeasurements, Sensors};

/// Number of driver inputs: the models' `[steering_angle, drive_torque, brake_torque]`
/// ([`vehicle_models::driver_input`]) and `drive_torque_rear`.
pub const DRIVER_DIM: usize = INPUT_DIM + 1;

/// Position of `drive_torque_rear` in [`InputVector`].
pub const REAR_DRIVE_TORQUE: usize = INPUT_DIM;

/// The driver input `[steering_angle, drive_torque, brake_torque, drive_torque_rear]`.
pub type InputVector = SVector<f64, DRIVER_DIM>;

/// The measurement and filter input of one sample, with the status bits found on the way.
pub struct Sample<const M: usize, const U: usize> {
    pub measurement: SVector<f64, M>,
    pub input: SVector<f64, U>,
    /// The rows the model offers in this sample; a row left out (model A's `vx` row without
    /// `use_speed_measurements` or without `vx_meas`) is neither used nor reported as skipped.
    pub offered: [bool; M],
    pub bits: i32,
}

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
    /// sensors add, e.g. model A's measured `ax`). Estimators without a covariance (particle
    /// filter, Luenberger observer) ignore it.
    fn extra_process_noise(
        &self,
        _state: &SVector<f64, N>,
        _input: &InputVector,
        _filter_input: &SVector<f64, U>,
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

/// What the outputs after a sample are computed from: the filter's estimate and covariance and
/// the values beside them, copied when the sample is processed.
#[derive(Clone, Copy, Debug)]
pub struct OutputSample<const N: usize, Extra> {
    pub state: SVector<f64, N>,
    pub covariance: SMatrix<f64, N, N>,
    /// The driver input of the sample.
    pub input: InputVector,
    pub extra: Extra,
    pub nis: f64,
    pub rows_used: i32,
    /// The filter held its estimate in this sample (low speed, or waiting for a measured speed).
    pub holding: bool,
    /// What the sensors measured in a held sample.
    pub held: HeldMeasurements,
    /// The factor on everything the estimator reports of its uncertainty, `covariance` and the
    /// consider terms: the Luenberger observer's innovation scaling, 1 for the other estimators.
    pub covariance_scale: f64,
    /// The gyro's offset taken off `yaw_rate_meas` in this sample (0 without the learner).
    pub yaw_rate_offset: f64,
    /// The lateral accelerometer's offset and gain error taken off `ay_meas` in this sample (0
    /// without the learner).
    pub ay_calibration: [f64; 2],
}

/// The `ay` row's model error as measurement noise (`ay_model_error` = k): `(k ŷ_ay)²` on row
/// `row`'s variance, `predicted_ay` the model's `ay` at the predicted estimate (evaluated only
/// for `k > 0`); `None` for `k = 0` (the filter's `R` as it is, bit for bit).
///
/// The measured `ay` is the tyre forces over the mass, so it enters the update through the
/// model's tyre law; on another car that law errs by a share of the force, not by a constant
/// (the sensor's noise). That error is the effect of a parameter the filter does not estimate
/// (Schmidt's "consider" parameters; Zanetti & D'Souza, "Recursive implementations of the
/// consider filter", AAS 12-619, 2012), carried here as white noise on the row it enters, with
/// a variance that grows with the predicted `ay`: at small `ay` the sensor dominates, near the
/// limit the model error does, and `ay` no longer pins the lateral states through a wrong tyre
/// law.
pub(crate) fn ay_model_error_noise<const M: usize>(
    v: &Variables,
    row: usize,
    predicted_ay: impl FnOnce() -> f64,
) -> Option<SMatrix<f64, M, M>> {
    if v.ay_model_error == 0.0 {
        return None;
    }
    let deviation = v.ay_model_error * predicted_ay();
    if !(deviation != 0.0 && deviation.is_finite()) {
        return None;
    }
    let mut noise = SMatrix::<f64, M, M>::zeros();
    noise[(row, row)] = deviation * deviation;
    Some(noise)
}
