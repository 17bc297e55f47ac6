//! Model A (the 5-state single-track model with HSRI tyres of seed 000,
//! `SingleTrackEstimationModel`, with the speed anchor `SpeedAnchoredModel`) as the
//! FMU runs it: `y = [yaw_rate, ay, omega_front, omega_rear, vx]` from the sensors (the `vx` row
//! and the `ax` kinematics only with `use_speed_measurements`), `u` = the driver input and the
//! measured `ax`, outputs from the state and one model evaluation; re-seeded from the measured
//! speed when the speed estimate falls below `min_speed`.

use estimation::kalman::InitialEstimate;
use estimation::models::single_track::{
    SingleTrackEstimationModel, SpeedAnchoredModel, ANCHORED_INPUT_DIM, ANCHORED_MEASUREMENT_DIM,
    AX_INPUT, AX_VALID_INPUT, VX_ROW,
};
use estimation::models::unknown_torques;
use estimation::registry::EstimatorSettings;
use fmi_export::{StateError, StateReader, StateWriter};
use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::{index as input_index, INPUT_DIM};
use vehicle_models::single_track::{measurement_index, state_index, SingleTrackParams, STATE_DIM};
use vehicle_models::{HsriTyre, SingleTrackModel, GRAVITY};

use crate::model_description::{RealOutputs, Variables};
use crate::parameters::{self, positive, variances};
use crate::runner::{
    finite_or, stiffness_consider, EstimationModel, InputVector, OutputSample, Runner, Sample,
    SensorRows, Sensors, WheelRadii, REAR_DRIVE_TORQUE,
};
use crate::speed_filter::{SpeedFilter, SpeedSample};
use crate::status;

/// The sideslip `β = atan2(vy, vx)` of a state whose first entries are model A's `(vx, vy, …)`
/// and its variance to first order (`∂β/∂vx = −vy / v²`, `∂β/∂vy = vx / v²`), for the
/// integrity guard.
pub(crate) fn single_track_sideslip<const N: usize>(
    state: &SVector<f64, N>,
    covariance: &SMatrix<f64, N, N>,
) -> (f64, f64) {
    let (vx, vy) = (state[state_index::VX], state[state_index::VY]);
    let speed_squared = (vx * vx + vy * vy).max(f64::MIN_POSITIVE);
    let (dvx, dvy) = (-vy / speed_squared, vx / speed_squared);
    let (pxx, pxy, pyy) = (
        covariance[(state_index::VX, state_index::VX)],
        covariance[(state_index::VX, state_index::VY)],
        covariance[(state_index::VY, state_index::VY)],
    );
    (
        vy.atan2(vx),
        dvx * dvx * pxx + 2.0 * dvx * dvy * pxy + dvy * dvy * pyy,
    )
}

/// Puts `vy = vx tan β` with the variance `(vx / cos² β)² σβ²`, uncorrelated with the other
/// states, into a state whose first entries are model A's (the guard's re-seed).
pub(crate) fn reseed_single_track_sideslip<const N: usize>(
    estimate: &mut InitialEstimate<N>,
    sideslip: f64,
    variance: f64,
) {
    let vx = estimate.state[state_index::VX];
    let cos = sideslip.cos();
    let vy = state_index::VY;
    estimate.state[vy] = vx * sideslip.tan();
    estimate.covariance.row_mut(vy).fill(0.0);
    estimate.covariance.column_mut(vy).fill(0.0);
    let gain = vx / (cos * cos);
    estimate.covariance[(vy, vy)] = gain * gain * variance;
}

/// Model A as the filters see it.
pub type ModelA = SpeedAnchoredModel<HsriTyre>;
type StateA = SVector<f64, STATE_DIM>;

/// The running estimator on model A.
pub type RunnerA = Runner<ModelA, STATE_DIM, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>;

/// Above this |ay| no passenger car's tyres transmit the force (1.5 g, road friction at most
/// about 1.2): the sample is a glitch, unless the sensor's own noise reaches it
/// ([`plausible_ay`]).
pub const MAX_PLAUSIBLE_AY: f64 = 15.0;

/// How many of the accelerometer's noise standard deviations a reading may lie beyond
/// [`MAX_PLAUSIBLE_AY`]: a body that vibrates (1-4 m/s² RMS on a real car) puts its peaks on
/// top of 12-13 m/s² of cornering, and those are the car's, not glitches. Four standard
/// deviations of a Gaussian are passed by all but 6 in 100 000 samples.
const PLAUSIBLE_AY_NOISE_SIGMAS: f64 = 4.0;

/// Whether a lateral acceleration reading is physically possible for a car whose accelerometer
/// has the noise std `noise_std` (learned or tuned, `learn_measurement_noise`).
pub fn plausible_ay(ay: f64, noise_std: f64) -> bool {
    ay.abs() <= MAX_PLAUSIBLE_AY + PLAUSIBLE_AY_NOISE_SIGMAS * noise_std
}

/// Above this a wheel speed is a glitch (1000 rad/s is 1080 km/h on a 0.3 m wheel).
pub const MAX_PLAUSIBLE_WHEEL_SPEED: f64 = 1e3;

/// The longitudinal slip at which a passenger car tyre's force peaks on a dry road (10-20 %;
/// Pacejka, Tyre and Vehicle Dynamics, 3rd ed., §1.2), for the low-speed wheel rule of
/// `extra_process_noise`.
const PEAK_SLIP: f64 = 0.15;

/// The largest sideslip model A keeps when the filter is re-seeded on re-admission, rad (about
/// 11°: beyond it a passenger car spins; with ESC the sideslip stays within a few degrees, van
/// Zanten, Bosch ESP Systems: 5 Years of Experience, SAE 2000-01-1633). Beyond it model A's own
/// estimate is more often lost than the car: on drawn cars that did not spin (`harness
/// population`, lane changes and slow ramps) keeping up to 1.2 rad made model A's EKF and UKFs
/// worse on 3-5 runs each (EKF 5.5° → 12.2° summed over 3).
const MAX_KEPT_SIDESLIP: f64 = 0.2;

/// Below this speed a start from the measurements takes its lateral speed from the rear axle's
/// kinematics, m/s (18 km/h: parking and manoeuvring, where the lateral acceleration and with it
/// the tyres' slip angles are small against the steering geometry's angles; Rajamani, Vehicle
/// Dynamics and Control, 2nd ed., §2.2 assumes zero slip angles for the kinematic model at low
/// speed).
pub(crate) const KINEMATIC_SPEED: f64 = 5.0;

/// The road-wheel angle of full lock, rad: 45°, the declared range of `steering_angle` (parking
/// manoeuvres).
const FULL_LOCK: f64 = std::f64::consts::FRAC_PI_4;

/// Above this |vx_meas| is a glitch, m/s (360 km/h).
pub const MAX_PLAUSIBLE_SPEED: f64 = 100.0;

/// `vx_meas` and `ax_meas` as model A takes them: only with `use_speed_measurements`, only
/// finite and plausible, and not in an all-zero sensor row.
pub(crate) fn speed_measurements(v: &Variables, sensors: &Sensors) -> (Option<f64>, Option<f64>) {
    if !v.use_speed_measurements || sensors.all_zero() {
        return (None, None);
    }
    let vx = Some(sensors.vx).filter(|vx| vx.is_finite() && vx.abs() <= MAX_PLAUSIBLE_SPEED);
    let ax = Some(sensors.ax).filter(|ax| ax.is_finite() && ax.abs() <= MAX_PLAUSIBLE_AY);
    (vx, ax)
}

impl ReportsFilteredSpeed<STATE_DIM> for ModelA {
    fn single_track(&self) -> &SingleTrackModel<HsriTyre> {
        self.vehicle()
    }
}

impl EstimationModel<STATE_DIM, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM> for ModelA {
    type Extra = SpeedFilter;

    fn from_parameters(v: &Variables) -> Result<Self, String> {
        let source = parameters::source(v);
        let vehicle = SingleTrackParams {
            chassis: source.chassis()?,
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
        let tyre = HsriTyre::new(source.hsri()?);
        let integrator = parameters::integrator(v)?;
        // Q = diag(std²) per sample, R = diag(std²) (000: ch. 7 uses Q = diag(w²), R = diag(v²)).
        let process = variances([
            ("process_noise_std_vx", v.process_noise_std_vx),
            ("process_noise_std_vy", v.process_noise_std_vy),
            ("process_noise_std_yaw_rate", v.process_noise_std_yaw_rate),
            (
                "process_noise_std_omega_front",
                v.process_noise_std_omega_front,
            ),
            (
                "process_noise_std_omega_rear",
                v.process_noise_std_omega_rear,
            ),
        ])?;
        let measurement = variances([
            (
                "measurement_noise_std_yaw_rate",
                v.measurement_noise_std_yaw_rate,
            ),
            ("measurement_noise_std_ay", v.measurement_noise_std_ay),
            (
                "measurement_noise_std_omega_front",
                v.measurement_noise_std_omega_front,
            ),
            (
                "measurement_noise_std_omega_rear",
                v.measurement_noise_std_omega_rear,
            ),
        ])?;
        let speed_std = positive("measurement_noise_std_vx", v.measurement_noise_std_vx)?;
        SingleTrackEstimationModel::new(
            SingleTrackModel::new(vehicle, tyre),
            positive("sample_time", v.sample_time)?,
            integrator,
            process,
            measurement,
        )
        .and_then(|inner| SpeedAnchoredModel::new(inner, speed_std * speed_std))
        .map_err(|error| format!("estimator set-up: {}", error.0))
    }

    fn initial_estimate(v: &Variables) -> Result<InitialEstimate<STATE_DIM>, String> {
        let variances = variances([
            ("initial_std_vx", v.initial_std_vx),
            ("initial_std_vy", v.initial_std_vy),
            ("initial_std_yaw_rate", v.initial_std_yaw_rate),
            ("initial_std_omega_front", v.initial_std_omega_front),
            ("initial_std_omega_rear", v.initial_std_omega_rear),
        ])?;
        Ok(InitialEstimate::diagonal(
            StateA::from([
                v.vx_initial,
                v.vy_initial,
                v.yaw_rate_initial,
                v.omega_front_initial,
                v.omega_rear_initial,
            ]),
            StateA::from(variances),
        ))
    }

    fn registry_settings(&self, v: &Variables) -> EstimatorSettings<STATE_DIM, ANCHORED_INPUT_DIM> {
        // The LKF/Luenberger operating point: straight driving, zero inputs (000: 5.58-5.62).
        let operating_state = StateA::from([
            v.lkf_vx,
            v.lkf_vy,
            v.lkf_yaw_rate,
            v.lkf_omega_front,
            v.lkf_omega_rear,
        ]);
        // The LKF predicts vx by the kinematics when the speed is measured. The Luenberger
        // observer keeps seed 000's linearisation: its design observes (vx, ωF, ωR) through the
        // front wheel speed alone, which the kinematic vx row would decouple (ωR unobservable).
        self.estimator_settings(
            (operating_state, SVector::zeros()),
            v.use_speed_measurements && !parameters::runs_luenberger(v),
            parameters::scaled_sigma_points(v),
            parameters::particle_config(v),
        )
    }

    /// Not filtering until a sample measures the speed and `ax` ([`step_reported_speed`]).
    fn start_extra(v: &Variables, _: f64) -> SpeedFilter {
        SpeedFilter::measured(v.vx_initial)
    }

    fn sample(
        runner: &mut RunnerA,
        sensors: &Sensors,
    ) -> Result<Sample<ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>, i32> {
        reported_speed_sample(runner, sensors)
    }

    /// `|ay| <= 1.5 g`, wheel speeds up to 1000 rad/s, `|vx| <= 100 m/s`, and no row of an
    /// all-zero sample while the estimate moves.
    fn sideslip_of(
        &self,
        state: &StateA,
        covariance: &SMatrix<f64, STATE_DIM, STATE_DIM>,
    ) -> (f64, f64) {
        single_track_sideslip(state, covariance)
    }

    fn reseed_sideslip(
        &self,
        estimate: &mut InitialEstimate<STATE_DIM>,
        sideslip: f64,
        variance: f64,
    ) {
        reseed_single_track_sideslip(estimate, sideslip, variance);
    }

    fn plausible(
        &self,
        sensors: &Sensors,
        state: &StateA,
        min_speed: f64,
        measurement_std: &[f64; ANCHORED_MEASUREMENT_DIM],
    ) -> [bool; ANCHORED_MEASUREMENT_DIM] {
        if sensors.all_zero() && state[state_index::VX].abs() >= min_speed {
            return [false; ANCHORED_MEASUREMENT_DIM];
        }
        let mut plausible = [true; ANCHORED_MEASUREMENT_DIM];
        let ay_row = measurement_index::LATERAL_ACCELERATION;
        plausible[ay_row] = plausible_ay(sensors.ay, measurement_std[ay_row]);
        plausible[measurement_index::OMEGA_FRONT] =
            sensors.omega_front.abs() <= MAX_PLAUSIBLE_WHEEL_SPEED;
        plausible[measurement_index::OMEGA_REAR] =
            sensors.omega_rear.abs() <= MAX_PLAUSIBLE_WHEEL_SPEED;
        plausible
    }

    fn measured_start(runner: &RunnerA, sensors: &Sensors) -> Option<InitialEstimate<STATE_DIM>> {
        measured_start(&runner.parameters, runner.min_speed, sensors)
    }

    fn model_error_rows(&self) -> [bool; ANCHORED_MEASUREMENT_DIM] {
        model_error_rows()
    }

    fn sensor_rows(&self) -> SensorRows {
        sensor_rows()
    }

    /// Not on the flat top of the tyre curve ([`tyres_hold_the_sideslip`]).
    fn model_error_resolvable(
        &self,
        state: &StateA,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
        jacobian: &SMatrix<f64, ANCHORED_MEASUREMENT_DIM, STATE_DIM>,
    ) -> bool {
        tyres_hold_the_sideslip(self, state, input, jacobian)
    }

    /// [`keep_sideslip`] up to [`MAX_KEPT_SIDESLIP`].
    fn readmitted_start(&self, current: &StateA, start: &mut InitialEstimate<STATE_DIM>) {
        keep_sideslip(current, start, MAX_KEPT_SIDESLIP);
    }

    /// Straight driving at the start's speed, the wheels free rolling (the form of the seed's
    /// operating point, 000: 5.58-5.62).
    fn operating_state_at(&self, start: &StateA) -> Option<StateA> {
        Some(
            self.vehicle()
                .straight_rolling_state(start[state_index::VX]),
        )
    }

    /// The sample's driver input with the operating point's `ax` and `ax_valid`: gain scheduling
    /// keeps the linear estimator's form of the `vx` row (the kinematics at `ax_valid = 1`, seed
    /// 000's force balance at 0, see `SpeedAnchoredModel::estimator_settings`) and `ax` enters
    /// `f` linearly, so its value at the operating point does not change the Jacobians.
    fn scheduling_input(
        &self,
        operating: &SVector<f64, ANCHORED_INPUT_DIM>,
        sample: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SVector<f64, ANCHORED_INPUT_DIM> {
        let mut input = *sample;
        input[AX_INPUT] = operating[AX_INPUT];
        input[AX_VALID_INPUT] = operating[AX_VALID_INPUT];
        input
    }

    /// Extra variance of the wheel states, per sample, from two limits of the wheel model
    /// (only with `use_speed_measurements`: the seeds' filters stay seed 000's). Each wheel gets
    /// the larger of:
    ///
    /// - **Torques unknown**: while every torque input reads exactly 0,
    ///   `(unknown_torque_slip_std |vx| / r)²`. A wheel speed measures the car's speed only
    ///   through the wheel's slip, `r ω = v (1 + s)`, and the model knows the slip from the torque
    ///   on the wheel (000: 5.45-5.46). Told 0 while the engine drives (or the brakes act), the
    ///   model pulls the wheel to free rolling in every prediction and the measured wheel,
    ///   several per cent faster (the Escort's driven front wheel at the limit of the slow ramp:
    ///   6 %), was read as speed: the estimate followed that slip (4.3 % vx error). The unknown
    ///   torque is a disturbance of the wheel's own dynamics, so it enters as process noise of
    ///   the wheel state: the wheel state follows its own measurement and the gain from its
    ///   innovation to vx, `P(vx,ω) / (P(ω) + R)`, becomes small; the speed rests on `vx_meas`
    ///   and `ax_meas`, the wheels still carrying it (with less weight) when those are missing.
    ///   The drive layout is not a parameter and unknown brakes slow every wheel, so both axles
    ///   get it. The slip settles within a sample (time constant `J vx / (r² Cs)`, a few ms),
    ///   hence a per-sample variance sized by the slip itself rather than a torque rate.
    /// - **Low speed**: the seed scheme damps the wheel step by
    ///   `1 / (1 − T ∂ω̇/∂ω)` (000: 6.1-6.5), which vanishes once the tyre slides (its force no
    ///   longer depends on ω). One sample of a sliding axle's friction force moves the wheel by
    ///   up to `Δω = f00 (2 FZ) r T / J` (f00 the HSRI friction at zero load, its largest; 4.5
    ///   rad/s for the Escort's rear axle at 10 ms), which at speeds below
    ///   `v = Δω r / (2 s_peak)` is more than twice the peak slip `s_peak` = 0.15 (passenger car
    ///   tyres on a dry road peak at 10-20 % slip; Pacejka, Tyre and Vehicle Dynamics, 3rd ed.,
    ///   §1.2): the predicted wheel jumps from one sliding side to the other in every sample, a
    ///   limit cycle of the discretisation, not of the car (pulling away, the wheel estimates
    ///   alternated 7.5 / 2.3 rad/s about a true 5.0, the gate rejected the wheel rows and the
    ///   re-admission re-seeded every 0.5 s, each time 0.2-0.4 m/s off). Below that speed the
    ///   wheel state gets `Δω²`, so each update puts it back on its measurement (the wheel is
    ///   algebraic at this sample time) and the limit cycle cannot build up.
    ///
    /// And below [`KINEMATIC_SPEED`] (manoeuvring) `vx` and `vy` each get
    /// `(|δ| / δ_lock · f00 g T)²`, δ_lock = [`FULL_LOCK`]: at full lock one sample of the
    /// friction-limited acceleration. At walking pace and full lock the single-track model's
    /// tyre forces are its largest error (the front tyres scrub at their limit, the slip angles
    /// are tens of degrees), of the order of what a tyre can transmit; steering straight or
    /// nearly so, the model holds and the term vanishes with the steering angle. Without it the filter trusted that model over `vx_meas`: at 45° steer and 3 m/s
    /// its vx std was 0.02 m/s against an error of 0.2 m/s, the gate rejected the measured
    /// speed, and the robustness case `out_of_range` ended 146 % off in vx.
    fn extra_process_noise(
        &self,
        state: &StateA,
        input: &InputVector,
        _filter_input: &SVector<f64, ANCHORED_INPUT_DIM>,
        _measured_wheels: [bool; 2],
        v: &Variables,
    ) -> Option<SMatrix<f64, STATE_DIM, STATE_DIM>> {
        if !v.use_speed_measurements {
            return None;
        }
        let speed = state[state_index::VX].abs();
        let slip = if unknown_torques::torques_read_zero(&input.data.0[0]) {
            v.unknown_torque_slip_std
        } else {
            0.0
        };
        // The filter's own car (the parameters as mapped once, vehicle_models::parameters).
        let vehicle = self.vehicle();
        let chassis = &vehicle.vehicle.chassis;
        let friction_base = vehicle.tyre.params.friction_base;
        let axles = [
            (
                state_index::OMEGA_FRONT,
                chassis.front_wheel_radius,
                chassis.front_wheel_load,
                chassis.front_wheel_inertia,
            ),
            (
                state_index::OMEGA_REAR,
                chassis.rear_wheel_radius,
                chassis.rear_wheel_load,
                chassis.rear_wheel_inertia,
            ),
        ];
        let mut noise = SMatrix::<f64, STATE_DIM, STATE_DIM>::zeros();
        for (index, radius, wheel_load, inertia) in axles {
            let unknown_torque = slip * speed / radius;
            let sliding_step = friction_base * 2.0 * wheel_load * radius * v.sample_time / inertia;
            let low_speed = if speed < sliding_step * radius / (2.0 * PEAK_SLIP) {
                sliding_step
            } else {
                0.0
            };
            noise[(index, index)] = unknown_torque.max(low_speed).powi(2);
        }
        if speed < KINEMATIC_SPEED {
            let lock = (input[input_index::STEERING_ANGLE] / FULL_LOCK)
                .abs()
                .min(1.0);
            let step = lock * friction_base * GRAVITY * v.sample_time;
            noise[(state_index::VX, state_index::VX)] = step * step;
            noise[(state_index::VY, state_index::VY)] = step * step;
        }
        noise.iter().any(|&q| q > 0.0).then_some(noise)
    }

    /// The filter's outputs, with the reported speed's while it filters
    /// ([`step_reported_speed`]).
    fn outputs(&self, sample: &OutputSample<STATE_DIM, SpeedFilter>, _: &Variables) -> RealOutputs {
        at_reported_speed(estimate_outputs(self, sample), &sample.extra)
    }

    /// `d/dt atan(w / vx)` of the rear axle's lateral velocity `w = vy − lR r` (000: 5.22), from
    /// the model's derivatives at the estimate (000: 5.42-5.46).
    fn rear_slip_angle_rate(&self, sample: &OutputSample<STATE_DIM, SpeedFilter>) -> Option<f64> {
        let x = sample.state;
        let driver = sample.input.fixed_rows::<INPUT_DIM>(0).into_owned();
        let rates = self.vehicle().derivatives(&x, &driver);
        let rear = self.vehicle().vehicle.chassis.cog_to_rear_axle;
        let (vx, w) = (
            x[state_index::VX],
            x[state_index::VY] - rear * x[state_index::YAW_RATE],
        );
        let w_rate = rates[state_index::VY] - rear * rates[state_index::YAW_RATE];
        Some((w_rate * vx - w * rates[state_index::VX]) / (vx * vx + w * w))
    }

    fn write_extra(speed: &SpeedFilter, writer: &mut StateWriter) {
        speed.write(writer);
    }

    fn read_extra(speed: &mut SpeedFilter, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        *speed = SpeedFilter::read(reader)?;
        Ok(())
    }
}

/// A model built on model A that reports the speed of [`step_reported_speed`]: model A, and the
/// grip model of `model_grip`.
pub(crate) trait ReportsFilteredSpeed<const N: usize>:
    EstimationModel<N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM, Extra = SpeedFilter>
{
    /// The model's single-track vehicle (model A's, whose first five states the model shares).
    fn single_track(&self) -> &SingleTrackModel<HsriTyre>;
}

/// Model A's sample ([`anchored_sample`]) and one step of its reported speed
/// ([`step_reported_speed`]); while the filter holds, the speed filter restarts at its value.
pub(crate) fn reported_speed_sample<Model, const N: usize>(
    runner: &mut Runner<Model, N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
    sensors: &Sensors,
) -> Result<Sample<ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>, i32>
where
    Model: ReportsFilteredSpeed<N>,
{
    let mut sample = anchored_sample(runner, sensors);
    // The speed filter's accelerometer offset, learned in straight driving (speed_filter's
    // module docs): an offset left in the kinematics reads as `b / r` of lateral velocity.
    if let Ok(sample) = &mut sample {
        if runner.extra.filtering() && sample.input[AX_VALID_INPUT] == 1.0 {
            sample.input[AX_INPUT] -= runner.extra.ax_offset;
        }
    }
    match &mut sample {
        Ok(sample) => sample.bits |= step_reported_speed(runner, sensors),
        Err(_) => runner.extra = SpeedFilter::measured(runner.extra.value),
    }
    sample
}

/// Model A's reported speed. Model A's own `vx` is a state of its force
/// balance, and with the torques unknown it is where the model's error of the tyre forces goes:
/// braked or spinning wheels whose slip the HSRI combined slip reads as lost side force pull it
/// off the car's speed by up to 9 % on the campaigns, and every attempt to hold it on `vx_meas`
/// moved that error into the sideslip (fmu-src/estimation/README.md, "Model A's speed with the
/// torques unknown"). So the speed model A reports comes, while `vx_meas` (at least `min_speed`)
/// and a non-zero `ax_meas` are measured, from the same scalar Kalman filter on
/// `dvx/dt = ax + r vy` that gives model B its speed ([`crate::speed_filter`]), with `r` and
/// `β` of model A's estimate: a cascade, the longitudinal estimate beside the lateral one, as
/// production estimators split them (van Zanten, Bosch ESP Systems: 5 Years of Experience, SAE
/// 2000-01-1633). Model A's filter, its sideslip and its wheels are unchanged. Otherwise (the
/// seeds' `use_speed_measurements = false`, no measured speed to start from, `ax` or `vx_meas`
/// missing for longer than [`crate::speed_filter::HELD_AX_TIME`]) the filter stops and model A
/// reports its own speed. Returns the speed filter's status bits.
fn step_reported_speed<Model, const N: usize>(
    runner: &mut Runner<Model, N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
    sensors: &Sensors,
) -> i32
where
    Model: ReportsFilteredSpeed<N>,
{
    let (measured, ax) = speed_measurements(&runner.parameters, sensors);
    let measured = measured.filter(|&speed| speed >= runner.min_speed);
    let sample = SpeedSample::at(
        &runner.parameters,
        measured.unwrap_or(f64::NAN),
        ax,
        lateral_motion(runner),
        runner.min_speed,
    );
    let gate = runner.speed_gate();
    let bits = runner.extra.step(&sample, gate);
    if !runner.extra.filtering() {
        runner.extra = SpeedFilter::measured(runner.filter.state()[state_index::VX]);
    }
    // A missing `vx_meas` the filter's own `vx` row already reports.
    bits & !status::ROW_SKIPPED
}

/// The yaw rate, lateral velocity and its variance of model A's estimate for the speed filter
/// ([`SpeedSample`]): `vy = vx tan β` at the filter's speed, its variance as reported, with the
/// rear stiffness's consider term `σ |αR| vx` (`αR` the model's kinematic slip, 000: 5.22) and
/// the Luenberger observer's innovation scaling.
fn lateral_motion<Model, const N: usize>(
    runner: &Runner<Model, N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
) -> (f64, f64, f64)
where
    Model: ReportsFilteredSpeed<N>,
{
    let state = runner.filter.state();
    let (vx, vy, yaw_rate) = (
        state[state_index::VX],
        state[state_index::VY],
        state[state_index::YAW_RATE],
    );
    let body: [f64; STATE_DIM] = std::array::from_fn(|i| state[i]);
    let driver = runner.input.fixed_rows::<INPUT_DIM>(0).into_owned().data.0[0];
    let [_, rear] = runner.model.single_track().kinematic_slip(&body, &driver);
    let rear_slip = rear.tan_slip_angle.atan();
    // Not where the filter's covariance carries the tyres' scale (its runner adds no such term).
    let consider = if runner.estimates_tyre_scale() {
        0.0
    } else {
        stiffness_consider(&runner.parameters, rear_slip) * vx
    };
    let variance = (runner.filter.covariance()[(state_index::VY, state_index::VY)]
        + consider * consider)
        * runner.covariance_scale();
    let sideslip = vy.atan2(vx);
    (yaw_rate, runner.extra.value * sideslip.tan(), variance)
}

/// `values` at the speed filter's reported speed while it filters (its one-step prediction,
/// std from its variance): `vy = vx tan β` with the filter's β, its std propagated to first
/// order from both. Unchanged while it does not filter.
pub(crate) fn at_reported_speed(mut values: RealOutputs, speed: &SpeedFilter) -> RealOutputs {
    let Some(vx_std) = speed.std() else {
        return values;
    };
    let vx = speed.ahead;
    let (tan, cos) = (values.sideslip_est.tan(), values.sideslip_est.cos());
    values.vx_est = vx;
    values.vx_std = vx_std;
    values.vy_est = vx * tan;
    values.vy_std = (tan * vx_std).hypot(vx * values.sideslip_std / (cos * cos));
    values
}

/// Re-admission re-seeds because one sensor stayed gated; the speed, yaw rate and wheel speeds
/// are measured, but the lateral speed is not, and `vy = 0` in a corner is a wrong sideslip
/// whose `ay` innovation the first update spreads into `vx` (on the slow ramp each re-admission
/// moved vx by up to 0.4 m/s, 1.8 %). So the estimate's sideslip `β` is kept, `vy = vx tan β`
/// at the measured speed, when the model's estimate of that size is to be believed
/// (`|β| <= max_kept`); a filter that lost its way further starts from 0 as at the start.
/// Below [`KINEMATIC_SPEED`] the start's rear-axle kinematics are kept instead (see
/// [`measured_start`]): manoeuvring at full lock a car's sideslip exceeds any such bound (24°
/// at 45° steer on the Escort) without spinning.
pub(crate) fn keep_sideslip(
    current: &StateA,
    start: &mut InitialEstimate<STATE_DIM>,
    max_kept: f64,
) {
    let sideslip = current[state_index::VY].atan2(current[state_index::VX]);
    let manoeuvring = start.state[state_index::VX] < KINEMATIC_SPEED;
    if sideslip.abs() <= max_kept && !manoeuvring {
        start.state[state_index::VY] = start.state[state_index::VX] * sideslip.tan();
    }
}

/// The outputs of one sample as the filter's state and covariance give them (the grip model's
/// too), before the runner adds the consider term of `runner::outputs::with_stiffness_consider`.
pub(crate) fn estimate_outputs<Extra>(
    model: &ModelA,
    sample: &OutputSample<STATE_DIM, Extra>,
) -> RealOutputs {
    let x = sample.state;
    let variances = sample.covariance.diagonal();
    let u = sample.input;
    // One model evaluation for every derived output: its ay is v̇y + vx r (000: 5.40), the
    // measurement function h(x, u) of the ay row in exact arithmetic, so evaluating h again
    // would only repeat the tyre forces.
    let derived = model
        .vehicle()
        .outputs(&x, &u.fixed_rows::<INPUT_DIM>(0).into_owned());
    let std = |i: usize| variances[i].max(0.0).sqrt();
    // First-order propagation of P through atan2(vy, vx).
    let (vx, vy) = (x[state_index::VX], x[state_index::VY]);
    let speed_squared = vx * vx + vy * vy;
    let gradient = [-vy / speed_squared, vx / speed_squared];
    let covariance_vx_vy = sample.covariance[(state_index::VX, state_index::VY)];
    let sideslip_variance = gradient[0] * gradient[0] * variances[state_index::VX]
        + 2.0 * gradient[0] * gradient[1] * covariance_vx_vy
        + gradient[1] * gradient[1] * variances[state_index::VY];
    RealOutputs {
        vx_est: x[state_index::VX],
        vy_est: x[state_index::VY],
        yaw_rate_est: x[state_index::YAW_RATE],
        omega_front_est: x[state_index::OMEGA_FRONT],
        omega_rear_est: x[state_index::OMEGA_REAR],
        sideslip_est: derived.sideslip,
        ay_est: derived.lateral_acceleration,
        slip_angle_front_est: derived.slip_angle_front,
        slip_angle_rear_est: derived.slip_angle_rear,
        slip_front_est: derived.slip_front,
        slip_rear_est: derived.slip_rear,
        vx_std: std(state_index::VX),
        vy_std: std(state_index::VY),
        yaw_rate_std: std(state_index::YAW_RATE),
        omega_front_std: std(state_index::OMEGA_FRONT),
        omega_rear_std: std(state_index::OMEGA_REAR),
        sideslip_std: sideslip_variance.max(0.0).sqrt(),
        nis: sample.nis,
        // the runner's three, set by `Runner::outputs_of`
        yaw_rate_offset_est: 0.0,
        ay_offset_est: 0.0,
        ay_gain_est: 0.0,
    }
}

/// Model A's gyro and accelerometer rows (see [`EstimationModel::sensor_rows`]), for every model
/// built on it.
pub(crate) fn sensor_rows() -> SensorRows {
    SensorRows {
        yaw_rate: measurement_index::YAW_RATE,
        ay: measurement_index::LATERAL_ACCELERATION,
    }
}

/// Model A's model-error rows (see [`EstimationModel::model_error_rows`]), for every model built
/// on it: the yaw rate. Not the wheel speeds (a locked wheel under braking in a turn disagrees
/// with the single-track axle for seconds) nor `vx_meas` (a GNSS or the ABS unit's reference
/// speed), and not `ay` either, though inertial: under a wrong tyre law the filter meets `ay`
/// through `vy`, and letting its persistent innovation in as well made the sideslip worse on the
/// harness campaigns (model A's 78 rows, sum of the sideslip RMSEs: 71.0 deg with the plain
/// gate, 63.0 with the yaw rate, 79.7 with the yaw rate and `ay`; the grip model's 30 rows
/// 16.8, 17.0 and 23.6 deg).
pub(crate) fn model_error_rows() -> [bool; ANCHORED_MEASUREMENT_DIM] {
    let mut rows = [false; ANCHORED_MEASUREMENT_DIM];
    rows[measurement_index::YAW_RATE] = true;
    rows
}

/// The share of its straight-running value below which model A's `∂ay/∂vy` means its tyres are
/// on the flat top of their curve ([`tyres_hold_the_sideslip`]). Measured (harness robustness and
/// the replay of `harness/logs/ford_escort_limit.csv`, held-out 20-30 s, map's parameters;
/// zero-sideslip baseline 2.28 deg): without the test 3.64 deg and 131.8 deg summed over the
/// campaigns' 195 rows; 0.05: 2.08 and 132.0 deg; 0.1: 1.35 and 134.3 deg with the BMW 320i slow
/// ramp's UKF rows worse than zero (1.83-1.86 against 1.72); 0.2: 1.26 and 138.5 deg.
const FLAT_TOP_STIFFNESS_SHARE: f64 = 0.05;

/// Whether model A's tyres still tie its lateral velocity to the forces, the condition for taking
/// the gyro's persistent disagreement as the model's error. The lateral acceleration's
/// sensitivity to the lateral velocity, `∂ay/∂vy` (the tyres' local cornering stiffness over
/// the mass, 000: 5.40, 5.72-5.73), at the predicted estimate is compared with its value in
/// straight running at the same speed; below [`FLAT_TOP_STIFFNESS_SHARE`] of it the tyres slide
/// on the flat top of the HSRI curve, where a persistent yaw-rate innovation let into the update
/// drags the state along that top: on the drive past the limit the sideslip ran from −2.6° to
/// −11.7° against a true −2.4° (harness/logs/README.md). There the gyro gets the plain test.
fn tyres_hold_the_sideslip(
    model: &ModelA,
    state: &StateA,
    input: &SVector<f64, ANCHORED_INPUT_DIM>,
    jacobian: &SMatrix<f64, ANCHORED_MEASUREMENT_DIM, STATE_DIM>,
) -> bool {
    let row = measurement_index::LATERAL_ACCELERATION;
    let mut straight = *state;
    straight[state_index::VY] = 0.0;
    straight[state_index::YAW_RATE] = 0.0;
    let mut straight_input = *input;
    straight_input[input_index::STEERING_ANGLE] = 0.0;
    let linear =
        estimation::StateSpaceModel::measurement_jacobian(model, &straight, &straight_input);
    let (local, linear) = (
        jacobian[(row, state_index::VY)],
        linear[(row, state_index::VY)],
    );
    // A non-finite sensitivity says nothing about the tyres: the rule applies as before.
    let on_flat_top = local.abs() < FLAT_TOP_STIFFNESS_SHARE * linear.abs();
    !on_flat_top
}

/// The measurement and input of one sample on model A's sensors and speed anchor, for every
/// model built on it (model A, the grip model of `model_grip`): the sensors' rows, the `vx` row
/// and `ax` only as [`speed_measurements`] takes them; re-seeds the filter first when its speed
/// estimate is below `min_speed` (see [`reseed`]).
pub(crate) fn anchored_sample<Model, const N: usize>(
    runner: &mut Runner<Model, N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
    sensors: &Sensors,
) -> Result<Sample<ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>, i32>
where
    Model: EstimationModel<N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
{
    let mut bits = 0;
    if runner.filter.state()[state_index::VX] < runner.min_speed {
        if !reseed(runner, sensors) {
            // The slip quantities are singular at standstill and the wheels confirm it:
            // hold instead of guessing.
            return Err(status::BELOW_MIN_SPEED);
        }
        bits |= status::BELOW_MIN_SPEED | status::STATE_RESET;
    }
    let (vx, ax) = speed_measurements(&runner.parameters, sensors);
    let mut offered = [true; ANCHORED_MEASUREMENT_DIM];
    offered[VX_ROW] = vx.is_some();
    Ok(Sample {
        measurement: SVector::from([
            sensors.yaw_rate,
            sensors.ay,
            sensors.omega_front,
            sensors.omega_rear,
            vx.unwrap_or(f64::NAN),
        ]),
        input: ModelA::extend_input(
            &runner.input.fixed_rows::<INPUT_DIM>(0).into_owned(),
            runner.input[REAR_DRIVE_TORQUE],
            ax,
        ),
        offered,
        bits,
    })
}

/// Re-seeds the filter from the measurements when its speed estimate fell below `min_speed`
/// but the sensors report a speed above it: the estimate is lost (e.g. after zero sensor
/// signals before the bus delivered data) and waiting for the filter to find back is hopeless,
/// because the model is singular near standstill. Returns whether it re-seeded.
fn reseed<Model, const N: usize>(
    runner: &mut Runner<Model, N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
    sensors: &Sensors,
) -> bool
where
    Model: EstimationModel<N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
{
    match Model::measured_start(runner, sensors) {
        Some(initial) => runner.reseed(&initial),
        None => false,
    }
}

/// The start from one sample's sensors: `vx` = `vx_meas` (with `use_speed_measurements`), else
/// the mean of `r_F ωF`, `r_R ωR` over the plausible wheel speeds; `vy = 0`, below
/// [`KINEMATIC_SPEED`] `vy = lR r` (the rear axle rolls without sliding sideways, Rajamani,
/// Vehicle Dynamics and Control, 2nd ed., §2.2: at 4 m/s and 45° steer `vy = 0` was a sideslip
/// 27° off, and the next updates drove vx to twice the measured speed); `r` = measured yaw
/// rate; wheel speeds as measured (free rolling on each axle's radius where missing); the
/// initial covariance of the parameters. `None` unless that speed is at least `min_speed`.
pub(crate) fn measured_start(
    v: &Variables,
    min_speed: f64,
    sensors: &Sensors,
) -> Option<InitialEstimate<STATE_DIM>> {
    let radii = WheelRadii::of(v);
    let plausible_wheel = |omega: f64| {
        if omega.abs() <= MAX_PLAUSIBLE_WHEEL_SPEED {
            omega
        } else {
            f64::NAN
        }
    };
    let wheels = Sensors {
        omega_front: plausible_wheel(sensors.omega_front),
        omega_rear: plausible_wheel(sensors.omega_rear),
        ..*sensors
    };
    let (measured_vx, _) = speed_measurements(v, sensors);
    let speed = measured_vx.or_else(|| wheels.wheel_speed(radii))?;
    if !(speed >= min_speed && speed.is_finite()) {
        return None;
    }
    let [front_rolling, rear_rolling] = radii.free_rolling(speed);
    let mut initial = ModelA::initial_estimate(v).ok()?;
    let yaw_rate = finite_or(sensors.yaw_rate, 0.0);
    // Rear axle without slip (Rajamani §2.2): its lateral velocity vy − lR r vanishes.
    let lateral_speed = if speed < KINEMATIC_SPEED {
        v.cog_to_rear_axle * yaw_rate
    } else {
        0.0
    };
    initial.state = StateA::from([
        speed,
        lateral_speed,
        yaw_rate,
        finite_or(wheels.omega_front, front_rolling),
        finite_or(wheels.omega_rear, rear_rolling),
    ]);
    Some(initial)
}
