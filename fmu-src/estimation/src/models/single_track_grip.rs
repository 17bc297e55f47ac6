//! Model A with per-axle lateral grip states and tyre relaxation as a
//! [`StateSpaceModel<11, 5, 6>`].
//!
//! - state `x = [vx, vy, yaw_rate, omega_front, omega_rear, grip_front, grip_rear,
//!   transient_slip_front, transient_slip_rear, relaxation_factor, ay_gain]`: model A's five
//!   states, one factor per axle on model A's lateral tyre force
//!   ([`SingleTrackModel::step_with_lateral_states`]; 1 is the user's tyre), per axle the tyre's
//!   transient slip angle `tan α'`, the share of the lag the tyres actually have (see
//!   **Tyre lag** and **How much lag**), and the lateral accelerometer's gain error (see
//!   **The accelerometer's gain**);
//! - measurement and input as [`SpeedAnchoredModel`]'s: `y = [yaw_rate, ay, omega_front,
//!   omega_rear, vx]`, `u = [steering_angle, drive_torque, brake_torque, drive_torque_rear, ax,
//!   ax_valid]`, with the `vx` row and the `ax` kinematics of the speed anchor.
//!
//! **Why.** Against a car that is not the filter's model (load transfer, another tyre, another
//! road), model A's lateral tyre forces are wrong by a persistent amount. In a quasi-steady corner
//! the yaw rate and `ay` fix the two axle forces only, not `vy` and both axles' stiffness
//! together: one direction is unobservable, the bias in it invisible to the filter, and model A's
//! sideslip covariance (a few thousandths of a degree) does not cover errors of tenths. Making
//! the force error a state puts that direction into the covariance (the Schmidt consider-state
//! argument, Schmidt 1966, here with the states estimated): where the data make a grip factor
//! observable (at the limit, the road friction; in a corner the understeer balance) the filter
//! estimates it, and along the unobservable direction it keeps the prior uncertainty `sigma`,
//! which the sideslip std then carries.
//!
//! **Grip dynamics.** Each factor is a first-order Gauss-Markov process about the user's tyre
//! (Brown and Hwang, Introduction to Random Signals and Applied Kalman Filtering, 4th ed.,
//! §2.9 and §4.2): `g(k+1) = 1 + a (g(k) − 1) + w(k)`, `a = exp(−T/τ)`,
//! `var(w) = σ² (1 − a²)`, so the stationary standard deviation is `σ` whatever the sample time.
//!
//! **Tyre lag.** A tyre builds its side force over a rolling distance, the relaxation length
//! `σ` (0.3-0.7 m for passenger car tyres): Pacejka, Tyre and Vehicle Dynamics, 3rd ed.,
//! §7.2.1, `σ dα'/dt + |Vcx| α' = |Vcx| α` with `α` the kinematic slip angle of the axle
//! ([`SingleTrackModel::kinematic_slip`]) and `α'` the one the force follows. Model A has
//! none; against cars whose tyres relax over 0.5 m its sideslip error on lane changes and sines
//! was mostly this lag (fmu-src/vehicle-state-estimator/README.md, "What model A's sideslip
//! error is made of"). Over a sample `α'(k+1) = α'(k) + min(T |Vcx| / σ, 1) (α(k) − α'(k))`
//! (explicit Euler, held at a one-sample delay where `T |Vcx| > σ`): under a steadily changing
//! `α` this lags by `σ / |Vcx|` as the tyre does, whereas the exact solution with `α` held over
//! the sample, `α + (α' − α) exp(−T |Vcx| / σ)`, lags by `T/2` more (0.11 m of rolling at
//! 80 km/h and 10 ms, a fifth of a tyre's `σ`). It is monotonic and stable at any speed and
//! holds `α'` at standstill. `σ = 0` is model A's instantaneous tyre: the forces use the
//! kinematic slip angles and the transient states merely follow them.
//!
//! **How much lag.** The car's relaxation length is rarely known, and a wrong one is a wrong
//! phase between the slip angle and the force in every transient, which the filter puts into
//! its sideslip. So the tyre law is evaluated at
//! `tan α_eff = tan α + κ (tan α' − tan α)`, with the relaxation factor `κ` a state: `κ = 1` is
//! the lag of `σ`, `κ = 0` none, and for a slowly changing `α` the force lags by `κ σ / |Vcx|`,
//! as a tyre of relaxation length `κ σ` does (to first order in the rate: the blend of the
//! lagged and the instantaneous slip angle rather than `σ` itself inside the lag, so that the
//! force is linear in `κ` and the filter's linearisation holds at any `κ`). `κ` is a
//! Gauss-Markov process about 1 of stationary std `ε` (the relative uncertainty of `σ`,
//! [`GripPrior::relaxation_std`]) and correlation time [`RELAXATION_FACTOR_TIME_CONSTANT`]; a
//! `κ` below 0 (a force ahead of its slip) is taken as 0. Where the slip angles do not change,
//! `α' = α` and `κ` is unobservable and harmless. Measured on the mismatch campaigns (`harness
//! robustness`, EKF_G's sideslip RMSEs summed over full vehicle / model 1 / model 2, 15 runs
//! each; fmu-src/vehicle-state-estimator/README.md, "The tyres' lag estimated"): `ε` 0 / 0.1 /
//! 0.2 / 0.5 gave 1.24 / 1.45 / 1.57 / 1.69°, 2.41 / 1.25 / 0.85 / 0.85° and 2.22 / 1.47 /
//! 1.23 / 1.24°. The other form, `κ σ` inside the lag equation, gave 1.62 / 1.39 / 1.50° at 0.5.
//!
//! **The accelerometer's gain.** A series car's `ay` sensor sits in the body, which rolls by `φ`
//! in a corner, and reads `g sin φ` of gravity besides the lateral acceleration (ISO 8855
//! specific force): with a roll proportional to `ay` (4-7°/g on passenger cars) a gain error `e`
//! of 0.07-0.13. The grip factors make the tyres' force free to follow `ay_meas`, so `vy`
//! integrates what `ay_meas` says beyond `r vx` (`dvy/dt = Fy/m − r vx`): an `e` of 0.13 on the
//! full vehicle's campaigns took the sideslip RMSE summed over its 15 runs from 1.85° to 13.0°,
//! and even the right `e` fixed ahead of the filter left 4.8°, because the grip learned in the
//! step before a steady corner stays (the direction is unobservable there). So the `ay` row is
//! `(1 + e) Fy / m` (below a few m/s² less of `e`: [`AY_GAIN_ONSET`]) with `e` a state, a
//! Gauss-Markov process about 0 of stationary std
//! [`GripPrior::ay_gain_std`] and correlation time [`AY_GAIN_TIME_CONSTANT`]: where `ay_meas`
//! and `r vx` disagree for longer than the grip's prior lets `vy` drift, `e` takes it, and its
//! covariance with `vy` and the grip carries them back. 0 (the FMU's default, `ay_gain_std`)
//! fixes `e` at 0, the filter then as without the state. Measured in
//! fmu-src/vehicle-state-estimator/README.md, "The accelerometer gain in the grip filter".
//!
//! **Unknown torques.** With [`SingleTrackGripModel::with_unknown_torques`] (the FMU's default),
//! while every torque input reads 0 (with or without `ax` measured), the tyre forces are those
//! of freely rolling wheels and each wheel keeps its slip velocity ([`unknown_torques`]): the wheels'
//! spin balance against a torque told 0 otherwise lets the filter trade slip angle against
//! grip along the direction its sensors cannot see.
//!
//! The Jacobians are forward-mode derivatives of the vehicle-models step (dual numbers, only the
//! directions a call needs), as for model A.

use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::INPUT_DIM;
use vehicle_models::single_track::{measurement_index, state_index, MEASUREMENT_DIM, STATE_DIM};
use vehicle_models::{
    AxleSlipKinematics, HsriTyre, LateralTyreStates, Scalar, SingleTrackModel, TyreModel,
};

use super::dual_passes::{columns_pass, input_pass, state_pass};
use super::unknown_torques;

use super::single_track::{
    SpeedAnchoredModel, ANCHORED_INPUT_DIM, ANCHORED_MEASUREMENT_DIM, AX_INPUT, AX_VALID_INPUT,
    REAR_DRIVE_INPUT,
};
use crate::kalman::{InitialEstimate, SettingsError};
use crate::luenberger::ObserverDesign;
use crate::registry::EstimatorSettings;
use crate::StateSpaceModel;

/// Number of states of the grip model.
pub const GRIP_STATE_DIM: usize = STATE_DIM + 6;

/// Index of the front axle's grip factor.
pub const GRIP_FRONT: usize = STATE_DIM;

/// Index of the rear axle's grip factor.
pub const GRIP_REAR: usize = STATE_DIM + 1;

/// The grip factors' indices, front and rear.
pub const GRIP_FACTORS: [usize; 2] = [GRIP_FRONT, GRIP_REAR];

/// Index of the front tyres' transient slip angle `tan α'`.
pub const TRANSIENT_SLIP_FRONT: usize = STATE_DIM + 2;

/// Index of the rear tyres' transient slip angle `tan α'`.
pub const TRANSIENT_SLIP_REAR: usize = STATE_DIM + 3;

/// Index of the relaxation factor `κ`, the share of the lag of the relaxation length that the
/// tyres have (module docs, **How much lag**).
pub const RELAXATION_FACTOR: usize = STATE_DIM + 4;

/// The states a marginalised particle filter keeps per particle as a Gaussian
/// ([`StateSpaceModel::conditionally_linear_states`]).
const CONDITIONALLY_LINEAR_STATES: [usize; 3] = [GRIP_FRONT, GRIP_REAR, RELAXATION_FACTOR];

/// Index of the lateral accelerometer's gain error `e` (module docs, **The accelerometer's
/// gain**).
pub const AY_GAIN: usize = STATE_DIM + 5;

/// The lateral acceleration below which the `ay` row hardly sees the gain error, m/s² (see
/// [`read_ay`]): driving straight, the model's `ay` is the sensors' noise passed through the
/// filter, and as the regressor of `e` it biased it (errors in variables, as the FMU runner's
/// learner had found below 2 m/s²): with `(1 + e) a` the gain drifted to −0.1 in the first
/// second of straight driving. With 1 m/s² it stays within 0.0003 there; at 2 m/s² the row sees
/// 80 % of the gain, at 3 m/s² 90 %. Measured on the campaigns at `ay_gain_std` 0.1 (EKF_G's
/// sums): with the roll's gravity 3.02° → 2.81° (2 m/s²: 2.76°), without 2.72° / 1.13° / 1.69° →
/// 2.67° / 1.14° / 1.68° (2 m/s²: 2.73° / 1.13° / 1.69°).
pub const AY_GAIN_ONSET: f64 = 1.0;

/// Correlation time of the accelerometer's gain error, s: the roll gradient is the car's and
/// changes with its load, not within a drive; the same as the FMU's runner-level learner of the
/// offset (600 s).
pub const AY_GAIN_TIME_CONSTANT: f64 = 600.0;

/// Correlation time of the relaxation factor's Gauss-Markov process, s: the relaxation length
/// is the tyre's (it changes with load and wear, not within a manoeuvre), so the factor is
/// nearly a random constant. Measured on the campaigns at `ε = 0.5`: 30 s and 3000 s gave the
/// same sideslip RMSEs as 300 s to within 0.02° summed per reference model.
pub const RELAXATION_FACTOR_TIME_CONSTANT: f64 = 300.0;

/// The least standard deviation the relaxation factor and the accelerometer's gain error are
/// given, so that the covariance stays positive definite where a std of 0 fixes them (`ε = 0`:
/// the lag at the relaxation length's; `ay_gain_std` 0: no gain error).
const LEAST_PRIOR_STD: f64 = 1e-6;

/// Standard deviation of each transient slip angle at the start, rad: the start knows the car's
/// speed and yaw rate, not its slip angles (a few degrees in a corner).
const TRANSIENT_SLIP_START_STD: f64 = 0.02;

/// Process noise of each transient slip angle, rad²/s (continuous-time density, so the same
/// at any sample time): the lag equation is exact for a tyre of relaxation length `σ`, and this
/// small density (0.2 mrad per sample at 10 ms) stands for a `σ` that is not exactly the car's
/// while keeping the covariance of these nearly deterministic states positive definite.
const TRANSIENT_SLIP_NOISE_DENSITY: f64 = 4e-6;

/// The grip model's state.
pub type GripState = SVector<f64, GRIP_STATE_DIM>;

/// The first-order Gauss-Markov prior of each grip factor (Brown and Hwang, §2.9), and of the
/// relaxation factor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GripPrior {
    /// Stationary standard deviation `σ` of each factor about 1.
    pub std: f64,
    /// Correlation time `τ`, s.
    pub time_constant: f64,
    /// Stationary standard deviation `ε` of the relaxation factor `κ` about 1: the relative
    /// uncertainty of the relaxation length (module docs, **How much lag**); 0 fixes the lag
    /// at the relaxation length's ([`LEAST_PRIOR_STD`]).
    pub relaxation_std: f64,
    /// Stationary standard deviation of the accelerometer's gain error `e` about 0 (module docs,
    /// **The accelerometer's gain**); 0 fixes it at 0 ([`LEAST_PRIOR_STD`] keeps the
    /// covariance positive definite).
    pub ay_gain_std: f64,
}

impl GripPrior {
    fn check(&self) -> Result<(), SettingsError> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !(positive(self.std) && positive(self.time_constant)) {
            return Err(SettingsError(format!(
                "the grip factors' std and time constant must be positive, got {self:?}"
            )));
        }
        for (what, std) in [
            ("the relaxation factor's", self.relaxation_std),
            ("the accelerometer's gain error's", self.ay_gain_std),
        ] {
            if !(std.is_finite() && std >= 0.0) {
                return Err(SettingsError(format!(
                    "{what} std must be at least 0, got {std}"
                )));
            }
        }
        Ok(())
    }

    /// The relaxation factor's stationary variance, at least [`LEAST_PRIOR_STD`]².
    fn relaxation_variance(&self) -> f64 {
        Self::least_variance(self.relaxation_std)
    }

    /// The accelerometer's gain error's stationary variance, at least
    /// [`LEAST_PRIOR_STD`]².
    fn ay_gain_variance(&self) -> f64 {
        Self::least_variance(self.ay_gain_std)
    }

    /// `std²`, at least [`LEAST_PRIOR_STD`]².
    fn least_variance(std: f64) -> f64 {
        let std = std.max(LEAST_PRIOR_STD);
        std * std
    }

    /// Model A's start extended by the grip factors' prior (mean 1, variance `σ²`), the
    /// transient slip angles (straight running, [`TRANSIENT_SLIP_START_STD`]), the relaxation
    /// factor's prior (mean 1, variance `ε²`) and the accelerometer's gain error's (mean 0),
    /// uncorrelated.
    pub fn extend_initial(
        &self,
        start: &InitialEstimate<STATE_DIM>,
    ) -> InitialEstimate<GRIP_STATE_DIM> {
        let mut covariance = SMatrix::<f64, GRIP_STATE_DIM, GRIP_STATE_DIM>::zeros();
        covariance
            .fixed_view_mut::<STATE_DIM, STATE_DIM>(0, 0)
            .copy_from(&start.covariance);
        let variance = self.std * self.std;
        covariance[(GRIP_FRONT, GRIP_FRONT)] = variance;
        covariance[(GRIP_REAR, GRIP_REAR)] = variance;
        for i in [TRANSIENT_SLIP_FRONT, TRANSIENT_SLIP_REAR] {
            covariance[(i, i)] = TRANSIENT_SLIP_START_STD * TRANSIENT_SLIP_START_STD;
        }
        covariance[(RELAXATION_FACTOR, RELAXATION_FACTOR)] = self.relaxation_variance();
        covariance[(AY_GAIN, AY_GAIN)] = self.ay_gain_variance();
        InitialEstimate {
            state: extend_state(&start.state),
            covariance,
        }
    }
}

/// Model A with the speed anchor, one lateral grip factor and one transient slip angle per axle
/// (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SingleTrackGripModel<T: TyreModel = HsriTyre> {
    anchored: SpeedAnchoredModel<T>,
    prior: GripPrior,
    /// `a = exp(−T/τ)`.
    decay: f64,
    /// The relaxation factor's `exp(−T/τκ)` ([`RELAXATION_FACTOR_TIME_CONSTANT`]).
    relaxation_decay: f64,
    /// The accelerometer's gain error's `exp(−T/τe)` ([`AY_GAIN_TIME_CONSTANT`]).
    ay_gain_decay: f64,
    /// The tyres' relaxation length `σ`, m; 0: no lag.
    relaxation_length: f64,
    /// Whether zero torques mean unknown ones ([`Self::with_unknown_torques`]).
    unknown_torques: bool,
}

impl<T: TyreModel> SingleTrackGripModel<T> {
    /// `anchored` with grip factors of prior `prior` and tyres without lag (relaxation length
    /// 0; [`Self::with_relaxation_length`]).
    pub fn new(anchored: SpeedAnchoredModel<T>, prior: GripPrior) -> Result<Self, SettingsError> {
        prior.check()?;
        let sample_time = anchored.inner().sample_time();
        let decay = (-sample_time / prior.time_constant).exp();
        let relaxation_decay = (-sample_time / RELAXATION_FACTOR_TIME_CONSTANT).exp();
        Ok(Self {
            anchored,
            prior,
            decay,
            relaxation_decay,
            ay_gain_decay: (-sample_time / AY_GAIN_TIME_CONSTANT).exp(),
            relaxation_length: 0.0,
            unknown_torques: false,
        })
    }

    /// The same model whose zero torques mean unknown ones (`unknown_torques`): while every
    /// torque input reads 0, the tyre forces are those of freely rolling
    /// wheels and each wheel keeps its slip (see [`unknown_torques`]); otherwise model A's
    /// wheels. Without it (the default) zero torques are zero torques.
    pub fn with_unknown_torques(self, unknown_torques: bool) -> Self {
        Self {
            unknown_torques,
            ..self
        }
    }

    /// Whether zero torques mean unknown ones ([`Self::with_unknown_torques`]).
    pub fn takes_zero_torques_as_unknown(&self) -> bool {
        self.unknown_torques
    }

    /// The same model with tyres that relax over `relaxation_length` m (see the module docs);
    /// finite and at least 0.
    pub fn with_relaxation_length(self, relaxation_length: f64) -> Result<Self, SettingsError> {
        if relaxation_length.is_finite() && relaxation_length >= 0.0 {
            Ok(Self {
                relaxation_length,
                ..self
            })
        } else {
            Err(SettingsError(format!(
                "the tyres' relaxation length must be at least 0 m, got {relaxation_length}"
            )))
        }
    }

    /// Model A with the speed anchor, without the grip states.
    pub fn anchored(&self) -> &SpeedAnchoredModel<T> {
        &self.anchored
    }

    /// The vehicle model (grip factors 1).
    pub fn vehicle(&self) -> &SingleTrackModel<T> {
        self.anchored.vehicle()
    }

    /// The grip factors' prior.
    pub fn prior(&self) -> GripPrior {
        self.prior
    }

    /// The registry's settings from the anchored model's (see
    /// [`SpeedAnchoredModel::estimator_settings`]): the operating point at grip 1, and model
    /// A's observer design with the grip factors and the transient slip angles left without
    /// feedback ([`ObserverDesign::open_loop`]). At the observer's operating point (straight
    /// driving) no lateral force acts, so no output observes the grip factors and no pole can be
    /// placed for them: the observer lets each relax to 1 by its Gauss-Markov step
    /// (`a = exp(−T/τ)`, stable) and the transient slip angles follow the kinematic ones by the
    /// tyre lag (stable at any speed above standstill), so it is model A's observer with the
    /// tyres' lag. The accelerometer's gain error, 0 in a straight line's `ay` row as well, is
    /// left to decay to 0 the same way.
    ///
    /// The gain is placed with the relaxation factor at 0 ([`ObserverDesign::placement_state`]):
    /// on the quasi-static tyre, where it is model A's gain. At the relaxation factor's own value
    /// (1) the `ay` row sees `vy` only through the transient slip angles, one sample's share
    /// `T |vx| / σ` of it at a time (0.36 at 18 m/s, 10 ms and σ = 0.5 m), so the one-state
    /// `vy` block's gain came out 3.6 times model A's, and with the lag left out of the
    /// design the error rang: on the Escort's step steer against model 1, whose tyres do not
    /// lag, sideslip errors of −0.30° to +0.26° within 60 ms of the step and a straight-line
    /// spread of ±0.05°. The block `(vy, α'F, α'R)` through `ay` cannot be placed instead: about
    /// straight driving one combination of it is unobservable (observability matrix singular
    /// values 36, 2.1 and 4e-15). Measured on the mismatch campaigns (`harness robustness`,
    /// fmu-src/vehicle-state-estimator/README.md, "The grip observer's gain placed on the
    /// quasi-static tyre").
    pub fn extend_settings(
        &self,
        anchored: EstimatorSettings<STATE_DIM, ANCHORED_INPUT_DIM>,
    ) -> EstimatorSettings<GRIP_STATE_DIM, ANCHORED_INPUT_DIM> {
        EstimatorSettings {
            operating_point: anchored
                .operating_point
                .map(|(state, input)| (extend_state(&state), input)),
            scaled_sigma_points: anchored.scaled_sigma_points,
            observer_design: anchored.observer_design.map(|design| ObserverDesign {
                open_loop: (design.open_loop.into_iter())
                    .chain(GRIP_FACTORS)
                    .chain([
                        TRANSIENT_SLIP_FRONT,
                        TRANSIENT_SLIP_REAR,
                        RELAXATION_FACTOR,
                        AY_GAIN,
                    ])
                    .collect(),
                placement_state: vec![(RELAXATION_FACTOR, 0.0)],
                ..design
            }),
            particles: anchored.particles,
        }
    }

    /// Model A's step with the grip factors on the lateral forces (the anchored model's
    /// driver input and rear drive torque), generic over the scalar.
    fn body_step<S: Scalar>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        u: &[S; ANCHORED_INPUT_DIM],
        kinematic: &[AxleSlipKinematics<S>; 2],
    ) -> [S; STATE_DIM] {
        let inner = self.anchored.inner();
        let body: [S; STATE_DIM] = core::array::from_fn(|i| x[i]);
        let driver: [S; INPUT_DIM] = core::array::from_fn(|j| u[j]);
        inner.vehicle().step_with_lateral_states(
            &body,
            &driver,
            Some(u[REAR_DRIVE_INPUT]),
            Some(self.lateral_states(x, kinematic)),
            inner.sample_time(),
            inner.integrator(),
        )
    }

    /// Model A's kinematic slip of each axle at `x` (its body; the wheel speeds do not enter)
    /// with the driver input of `u`, which the lag and the tyre law both take.
    fn kinematic_slip<S: Scalar, const K: usize>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        u: &[S; K],
    ) -> [AxleSlipKinematics<S>; 2] {
        let body: [S; STATE_DIM] = core::array::from_fn(|i| x[i]);
        let driver: [S; INPUT_DIM] = core::array::from_fn(|j| u[j]);
        self.vehicle().kinematic_slip(&body, &driver)
    }

    /// The grip factors and, with a relaxation length, the slip angles the tyre law is
    /// evaluated at: `tan α + κ (tan α' − tan α)` per axle, the kinematic slip angle `α`
    /// ([`Self::kinematic_slip`]) moved towards the transient one by the relaxation factor
    /// `κ ≥ 0` (module docs, **How much lag**).
    fn lateral_states<S: Scalar>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        kinematic: &[AxleSlipKinematics<S>; 2],
    ) -> LateralTyreStates<S> {
        LateralTyreStates {
            grip: [x[GRIP_FRONT], x[GRIP_REAR]],
            transient_tan_slip_angle: (self.relaxation_length > 0.0).then(|| {
                let factor = x[RELAXATION_FACTOR];
                // a force ahead of its slip angle is no tyre's: κ < 0 is held at 0
                let factor = if factor.value() < 0.0 {
                    S::constant(0.0)
                } else {
                    factor
                };
                let transient = [x[TRANSIENT_SLIP_FRONT], x[TRANSIENT_SLIP_REAR]];
                core::array::from_fn(|axle| {
                    let kinematic = kinematic[axle].tan_slip_angle;
                    kinematic + (transient[axle] - kinematic) * factor
                })
            }),
        }
    }

    /// Each axle's transient slip angle one sample on: the relaxation-length lag towards the
    /// kinematic slip angle `kinematic` at `x`, one explicit-Euler step (module docs).
    fn transient_slip_step<S: Scalar>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        kinematic: &[AxleSlipKinematics<S>; 2],
    ) -> [S; 2] {
        let transient = [x[TRANSIENT_SLIP_FRONT], x[TRANSIENT_SLIP_REAR]];
        core::array::from_fn(|axle| {
            let target = kinematic[axle].tan_slip_angle;
            if self.relaxation_length > 0.0 {
                // (Pacejka §7.2.1) over one sample (module docs):
                // α'(k+1) = α'(k) + min(T |Vcx| / σ, 1) (α − α'(k))
                let share = kinematic[axle].wheel_velocity.abs()
                    * (self.anchored.inner().sample_time() / self.relaxation_length);
                if share.value() < 1.0 {
                    transient[axle] + (target - transient[axle]) * share
                } else {
                    target
                }
            } else {
                target
            }
        })
    }

    /// The transition, generic over the scalar: model A's step with the grip factors, the
    /// speed anchor's kinematic `vx` when `ax` is measured (`vx + T (ax + r vy)`, see
    /// [`SpeedAnchoredModel`]), and the Gauss-Markov decay of the grip factors.
    fn step<S: Scalar>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        u: &[S; ANCHORED_INPUT_DIM],
    ) -> [S; GRIP_STATE_DIM] {
        let rolling = self.rolling_body(x, u);
        // the rolling body changes the wheel speeds only, which the kinematic slip does not read
        let kinematic = self.kinematic_slip(x, u);
        let body = self.body_step(&Self::force_state(x, rolling.as_ref()), u, &kinematic);
        let mut next: [S; GRIP_STATE_DIM] =
            core::array::from_fn(|i| if i < STATE_DIM { body[i] } else { x[i] });
        if u[AX_VALID_INPUT].value() == 1.0 {
            next[state_index::VX] = self.anchored.kinematic_speed(x, u[AX_INPUT]);
        }
        if let Some(rolling) = rolling {
            let body: [S; STATE_DIM] = core::array::from_fn(|i| x[i]);
            let driver: [S; INPUT_DIM] = core::array::from_fn(|j| u[j]);
            let [front, rear] = unknown_torques::keeping_slip(
                self.vehicle(),
                &body,
                &rolling,
                next[state_index::VX],
                &driver,
            );
            next[state_index::OMEGA_FRONT] = front;
            next[state_index::OMEGA_REAR] = rear;
        }
        for i in GRIP_FACTORS {
            // g(k+1) = 1 + a (g(k) − 1) (Brown and Hwang, §2.9)
            next[i] = (x[i] - 1.0) * self.decay + 1.0;
        }
        next[RELAXATION_FACTOR] = (x[RELAXATION_FACTOR] - 1.0) * self.relaxation_decay + 1.0;
        // e(k+1) = a e(k) (Brown and Hwang, §2.9)
        next[AY_GAIN] = x[AY_GAIN] * self.ay_gain_decay;
        let [front, rear] = self.transient_slip_step(x, &kinematic);
        next[TRANSIENT_SLIP_FRONT] = front;
        next[TRANSIENT_SLIP_REAR] = rear;
        next
    }

    /// While the torques are unknown ([`Self::with_unknown_torques`]), model A's states of `x`
    /// with both wheels at free rolling; otherwise `None`.
    fn rolling_body<S: Scalar, const K: usize>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        u: &[S; K],
    ) -> Option<[S; STATE_DIM]> {
        (self.unknown_torques && unknown_torques::torques_read_zero(u)).then(|| {
            let body: [S; STATE_DIM] = core::array::from_fn(|i| x[i]);
            let driver: [S; INPUT_DIM] = core::array::from_fn(|j| u[j]);
            unknown_torques::free_rolling(self.vehicle(), &body, &driver)
        })
    }

    /// The state the tyre forces are evaluated at: `x`, with the body of `rolling` where the
    /// torques are unknown ([`Self::rolling_body`]).
    fn force_state<S: Scalar>(
        x: &[S; GRIP_STATE_DIM],
        rolling: Option<&[S; STATE_DIM]>,
    ) -> [S; GRIP_STATE_DIM] {
        let mut forces = *x;
        if let Some(rolling) = rolling {
            forces[..STATE_DIM].copy_from_slice(rolling);
        }
        forces
    }

    /// Model A's measurement with the grip factors and transient slip angles, its tyre forces
    /// at [`Self::force_state`] (freely rolling wheels while the torques are unknown): the
    /// sensors' rows before the accelerometer's gain error, generic over the scalar.
    fn body_measurement<S: Scalar, const K: usize>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        u: &[S; K],
    ) -> [S; MEASUREMENT_DIM] {
        let forces = Self::force_state(x, self.rolling_body(x, u).as_ref());
        let body: [S; STATE_DIM] = core::array::from_fn(|i| forces[i]);
        let driver: [S; INPUT_DIM] = core::array::from_fn(|j| u[j]);
        self.vehicle().measurement_with_lateral_states(
            &body,
            &driver,
            Some(self.lateral_states(x, &self.kinematic_slip(x, u))),
        )
    }

    /// The lateral acceleration of the centre of gravity at `(state, input)`: the `ay` the
    /// model's `ay` row predicts before the accelerometer's gain error, from the same tyre
    /// forces (with the torques unknown, those of freely rolling wheels, not of the wheel
    /// states, which keep the wheels' measured slip). `input` is any input that begins with the
    /// driver input and the rear drive torque (the anchored model's, the FMU runner's).
    pub fn lateral_acceleration<const K: usize>(
        &self,
        state: &GripState,
        input: &SVector<f64, K>,
    ) -> f64 {
        self.body_measurement(&state.data.0[0], &input.data.0[0])
            [measurement_index::LATERAL_ACCELERATION]
    }

    /// The measurement, generic over the scalar: model A's with the grip factors and transient
    /// slip angles ([`Self::body_measurement`]), the accelerometer's gain error, and `vx`.
    fn observe<S: Scalar>(
        &self,
        x: &[S; GRIP_STATE_DIM],
        u: &[S; ANCHORED_INPUT_DIM],
    ) -> [S; ANCHORED_MEASUREMENT_DIM] {
        let y = self.body_measurement(x, u);
        core::array::from_fn(|i| match i {
            // the wheel rows measure the wheel states themselves
            measurement_index::OMEGA_FRONT => x[state_index::OMEGA_FRONT],
            measurement_index::OMEGA_REAR => x[state_index::OMEGA_REAR],
            measurement_index::LATERAL_ACCELERATION => read_ay(y[i], x[AY_GAIN]),
            _ if i < MEASUREMENT_DIM => y[i],
            _ => x[state_index::VX],
        })
    }
}

/// What the body-fixed accelerometer reads of the lateral acceleration `a` with the gain error
/// `e` (module docs, **The accelerometer's gain**): `a + e a³ / (a² + a₀²)`, `a₀` =
/// [`AY_GAIN_ONSET`], which is `(1 + e) a` once `|a|` is a few `a₀`.
fn read_ay<S: Scalar>(a: S, e: S) -> S {
    a + e * (a * a * a / (a * a + AY_GAIN_ONSET * AY_GAIN_ONSET))
}

/// Model A's state with both grip factors and the relaxation factor at 1 and the transient slip
/// angles of straight running (0).
pub fn extend_state(state: &SVector<f64, STATE_DIM>) -> GripState {
    GripState::from_fn(|i, _| match i {
        _ if i < STATE_DIM => state[i],
        GRIP_FRONT | GRIP_REAR | RELAXATION_FACTOR => 1.0,
        _ => 0.0,
    })
}

impl<T: TyreModel> StateSpaceModel<GRIP_STATE_DIM, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>
    for SingleTrackGripModel<T>
{
    fn state_names(&self) -> [&'static str; GRIP_STATE_DIM] {
        let [vx, vy, r, front, rear] = self.anchored.state_names();
        [
            vx,
            vy,
            r,
            front,
            rear,
            "grip_front",
            "grip_rear",
            "transient_slip_front",
            "transient_slip_rear",
            "relaxation_factor",
            "ay_gain",
        ]
    }

    fn measurement_names(&self) -> [&'static str; ANCHORED_MEASUREMENT_DIM] {
        self.anchored.measurement_names()
    }

    fn transition(&self, state: &GripState, input: &SVector<f64, ANCHORED_INPUT_DIM>) -> GripState {
        SVector::from(self.step(&state.data.0[0], &input.data.0[0]))
    }

    fn transition_jacobian(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, GRIP_STATE_DIM, GRIP_STATE_DIM> {
        self.transition_and_jacobian(state, input).1
    }

    fn transition_and_jacobian(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> (GripState, SMatrix<f64, GRIP_STATE_DIM, GRIP_STATE_DIM>) {
        state_pass(state, input, |x, u| self.step(x, u))
    }

    fn transition_and_linear_columns(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> (GripState, SMatrix<f64, GRIP_STATE_DIM, GRIP_STATE_DIM>) {
        columns_pass(state, input, CONDITIONALLY_LINEAR_STATES, |x, u| {
            self.step(x, u)
        })
    }

    fn transition_input_jacobian(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, GRIP_STATE_DIM, ANCHORED_INPUT_DIM> {
        input_pass(state, input, Some(AX_VALID_INPUT), |x, u| self.step(x, u))
    }

    fn measurement(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SVector<f64, ANCHORED_MEASUREMENT_DIM> {
        SVector::from(self.observe(&state.data.0[0], &input.data.0[0]))
    }

    fn measurement_jacobian(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, ANCHORED_MEASUREMENT_DIM, GRIP_STATE_DIM> {
        self.measurement_and_jacobian(state, input).1
    }

    fn measurement_and_jacobian(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> (
        SVector<f64, ANCHORED_MEASUREMENT_DIM>,
        SMatrix<f64, ANCHORED_MEASUREMENT_DIM, GRIP_STATE_DIM>,
    ) {
        state_pass(state, input, |x, u| self.observe(x, u))
    }

    fn measurement_input_jacobian(
        &self,
        state: &GripState,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM> {
        input_pass(state, input, Some(AX_VALID_INPUT), |x, u| {
            self.observe(x, u)
        })
    }

    /// The grip factors and the relaxation factor, the model's slowly varying parameters
    /// (which a particle filter that samples them learns only by the chance of its resampling):
    /// each grip factor scales its axle's side force, which enters `vy`, `r` and `ay` linearly;
    /// the relaxation factor moves the slip angle linearly (the tyre law then bends it); each
    /// follows its own Gauss-Markov process. Not the accelerometer's gain, which multiplies the
    /// grip factors in the `ay` row.
    fn conditionally_linear_states(&self) -> &'static [usize] {
        &CONDITIONALLY_LINEAR_STATES
    }

    /// Model A's `Q`, per grip factor `σ² (1 − a²)` (Brown and Hwang, §2.9), per transient slip
    /// angle [`TRANSIENT_SLIP_NOISE_DENSITY`] `· T`, for the relaxation factor `ε² (1 − aκ²)`,
    /// for the accelerometer's gain error its stationary variance times `1 − ae²`;
    /// uncorrelated.
    fn process_noise(&self) -> SMatrix<f64, GRIP_STATE_DIM, GRIP_STATE_DIM> {
        let mut noise = SMatrix::<f64, GRIP_STATE_DIM, GRIP_STATE_DIM>::zeros();
        noise
            .fixed_view_mut::<STATE_DIM, STATE_DIM>(0, 0)
            .copy_from(&self.anchored.process_noise());
        let variance = self.prior.std * self.prior.std * (1.0 - self.decay * self.decay);
        noise[(GRIP_FRONT, GRIP_FRONT)] = variance;
        noise[(GRIP_REAR, GRIP_REAR)] = variance;
        let slip_variance = TRANSIENT_SLIP_NOISE_DENSITY * self.anchored.inner().sample_time();
        noise[(TRANSIENT_SLIP_FRONT, TRANSIENT_SLIP_FRONT)] = slip_variance;
        noise[(TRANSIENT_SLIP_REAR, TRANSIENT_SLIP_REAR)] = slip_variance;
        noise[(RELAXATION_FACTOR, RELAXATION_FACTOR)] = self.prior.relaxation_variance()
            * (1.0 - self.relaxation_decay * self.relaxation_decay);
        noise[(AY_GAIN, AY_GAIN)] =
            self.prior.ay_gain_variance() * (1.0 - self.ay_gain_decay * self.ay_gain_decay);
        noise
    }

    fn measurement_noise(
        &self,
    ) -> SMatrix<f64, ANCHORED_MEASUREMENT_DIM, ANCHORED_MEASUREMENT_DIM> {
        self.anchored.measurement_noise()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::SigmaPoints;
    use crate::models::single_track::{SingleTrackEstimationModel, VX_ROW};
    use crate::particle::ParticleFilterConfig;
    use crate::registry::{self, EstimatorChoice};
    use crate::test_oracle::central_difference;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};
    use vehicle_models::driver_input::index as input_index;
    use vehicle_models::single_track::SingleTrackParams;
    use vehicle_models::Integrator;

    const SAMPLE_TIME: f64 = 0.01;
    /// The FMU's default process noise, per sample, `[vx, vy, r, ωF, ωR]`.
    const PROCESS_STD: [f64; STATE_DIM] = [0.005, 0.005, 0.001, 0.05, 0.05];
    /// Series-production sensor noise (the campaigns' ReferenceVehicle settings):
    /// `[r, ay, ωF, ωR, vx]`.
    const SENSOR_STD: [f64; ANCHORED_MEASUREMENT_DIM] = [0.0035, 0.1, 0.1, 0.1, 0.05];
    const PRIOR: GripPrior = GripPrior {
        std: 0.15,
        time_constant: 2.0,
        relaxation_std: 0.2,
        ay_gain_std: 0.1,
    };

    fn anchored(rear_scale: f64) -> SpeedAnchoredModel<HsriTyre> {
        let vehicle = SingleTrackModel::new(
            SingleTrackParams {
                cornering_stiffness_scale_rear: rear_scale,
                ..SingleTrackParams::default()
            },
            HsriTyre::default(),
        );
        let inner = SingleTrackEstimationModel::new(
            vehicle,
            SAMPLE_TIME,
            Integrator::SemiImplicitEuler,
            PROCESS_STD.map(|s| s * s),
            core::array::from_fn(|i| SENSOR_STD[i] * SENSOR_STD[i]),
        )
        .unwrap();
        SpeedAnchoredModel::new(inner, SENSOR_STD[VX_ROW].powi(2)).unwrap()
    }

    fn grip_model() -> SingleTrackGripModel<HsriTyre> {
        SingleTrackGripModel::new(anchored(1.0), PRIOR).unwrap()
    }

    #[test]
    fn jacobians_match_finite_differences_in_a_braked_turn() {
        for relaxation_length in [0.0, 0.4] {
            jacobians_match_finite_differences(
                grip_model()
                    .with_relaxation_length(relaxation_length)
                    .unwrap(),
            );
        }
    }

    fn jacobians_match_finite_differences(model: SingleTrackGripModel<HsriTyre>) {
        let x = GripState::from([17.0, -0.4, 0.3, 55.5, 56.0, 0.9, 1.2, 0.01, 0.02, 0.7, 0.05]);
        let driver = SVector::<f64, INPUT_DIM>::from([0.06, 50.0, 800.0]);
        for ax in [None, Some(-2.0)] {
            let u = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 120.0, ax);
            let relative =
                |a: SMatrix<f64, GRIP_STATE_DIM, GRIP_STATE_DIM>,
                 b: SMatrix<f64, GRIP_STATE_DIM, GRIP_STATE_DIM>| {
                    (a - b).amax() / b.amax()
                };
            let numeric = central_difference(|x| model.transition(x, &u), &x);
            assert!(relative(model.transition_jacobian(&x, &u), numeric) < 1e-5);
            let numeric = central_difference(|x| model.measurement(x, &u), &x);
            let analytic = model.measurement_jacobian(&x, &u);
            assert!((analytic - numeric).amax() < 1e-5 * numeric.amax());
            // the ax_valid switch (last column) has no derivative
            let numeric = central_difference(|u| model.transition(&x, u), &u);
            let analytic = model.transition_input_jacobian(&x, &u);
            assert!((analytic - numeric).columns(0, 5).amax() < 1e-5 * numeric.amax());
            let numeric = central_difference(|u| model.measurement(&x, u), &u);
            let analytic = model.measurement_input_jacobian(&x, &u);
            assert!((analytic - numeric).columns(0, 5).amax() < 1e-5 * numeric.amax());
            // the one-pass value is the transition
            assert_eq!(
                model.transition_and_jacobian(&x, &u).0,
                model.transition(&x, &u)
            );
            // the marginalised particle filter's pass: the same value and linear columns
            let (value, columns) = model.transition_and_linear_columns(&x, &u);
            let (_, full) = model.transition_and_jacobian(&x, &u);
            assert_eq!(value, model.transition(&x, &u));
            for &state in model.conditionally_linear_states() {
                assert_eq!(columns.column(state), full.column(state));
            }
        }
    }

    /// A braked turn's state with the brake torque not reported: every torque input 0, `ax`
    /// measured (the case of [`unknown_torques`]).
    fn torques_unknown_case() -> (GripState, SVector<f64, ANCHORED_INPUT_DIM>) {
        let x = GripState::from([17.0, -0.4, 0.3, 55.5, 56.0, 0.9, 1.2, 0.01, 0.02, 0.7, 0.05]);
        let driver = SVector::<f64, INPUT_DIM>::from([0.06, 0.0, 0.0]);
        let u = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 0.0, Some(-4.0));
        (x, u)
    }

    /// With the torques unknown the Jacobians still match finite differences (in the steering
    /// angle and `ax`; a torque of exactly 0 is the switch, so it has no derivative).
    #[test]
    fn jacobians_match_finite_differences_with_the_torques_unknown() {
        let model = grip_model()
            .with_relaxation_length(0.4)
            .unwrap()
            .with_unknown_torques(true);
        let (x, u) = torques_unknown_case();
        let numeric = central_difference(|x| model.transition(x, &u), &x);
        let analytic = model.transition_jacobian(&x, &u);
        assert!((analytic - numeric).amax() < 1e-5 * numeric.amax());
        let numeric = central_difference(|x| model.measurement(x, &u), &x);
        let analytic = model.measurement_jacobian(&x, &u);
        assert!((analytic - numeric).amax() < 1e-5 * numeric.amax());
        let columns = [input_index::STEERING_ANGLE, AX_INPUT];
        let numeric = central_difference(|u| model.transition(&x, u), &u);
        let analytic = model.transition_input_jacobian(&x, &u);
        for j in columns {
            assert!((analytic.column(j) - numeric.column(j)).amax() < 1e-5 * numeric.amax());
        }
        let numeric = central_difference(|u| model.measurement(&x, u), &u);
        let analytic = model.measurement_input_jacobian(&x, &u);
        for j in columns {
            assert!((analytic.column(j) - numeric.column(j)).amax() < 1e-5 * numeric.amax());
        }
    }

    /// The lateral acceleration the outputs report is the `ay` row's prediction before the
    /// accelerometer's gain error: with the torques unknown it does not depend on the wheel
    /// states either, and with a gain error the row reads it through the gain.
    #[test]
    fn the_lateral_acceleration_is_the_ay_row_s_before_the_accelerometer_s_gain() {
        let model = grip_model()
            .with_relaxation_length(0.4)
            .unwrap()
            .with_unknown_torques(true);
        let (mut x, u) = torques_unknown_case();
        let ay = measurement_index::LATERAL_ACCELERATION;
        let driver = u.fixed_rows::<4>(0).into_owned();
        x[AY_GAIN] = 0.0;
        let lateral = model.lateral_acceleration(&x, &u);
        assert_eq!(lateral, model.measurement(&x, &u)[ay]);
        // the runner's input (driver and rear drive torque) gives the same
        assert_eq!(model.lateral_acceleration(&x, &driver), lateral);
        let mut spun = x;
        spun[state_index::OMEGA_FRONT] *= 0.5;
        spun[state_index::OMEGA_REAR] = 0.0;
        assert_eq!(model.lateral_acceleration(&spun, &u), lateral);
        x[AY_GAIN] = 0.05;
        assert_eq!(model.lateral_acceleration(&x, &u), lateral);
        assert_eq!(model.measurement(&x, &u)[ay], read_ay(lateral, 0.05));
    }

    /// With the torques unknown the tyre forces are those of freely rolling wheels, whatever the
    /// wheel states, and each wheel keeps its slip velocity, also without `ax`; with a torque
    /// given, or with the switch off, the wheels are model A's, to the bit.
    #[test]
    fn unknown_torques_leave_the_forces_to_freely_rolling_wheels() {
        let known = grip_model().with_relaxation_length(0.4).unwrap();
        let unknown = known.clone().with_unknown_torques(true);
        let (x, u) = torques_unknown_case();
        let mut spun = x;
        spun[state_index::OMEGA_FRONT] += 3.0;
        spun[state_index::OMEGA_REAR] -= 2.0;
        let (next, spun_next) = (unknown.transition(&x, &u), unknown.transition(&spun, &u));
        for i in (0..GRIP_STATE_DIM)
            .filter(|&i| i != state_index::OMEGA_FRONT && i != state_index::OMEGA_REAR)
        {
            assert_eq!(next[i], spun_next[i], "state {i}");
        }
        let ay = measurement_index::LATERAL_ACCELERATION;
        assert_eq!(
            unknown.measurement(&x, &u)[ay],
            unknown.measurement(&spun, &u)[ay]
        );
        // slip velocities r ω − Vx,wheel kept (000: 5.16 at the front, with the start's vy, r)
        let chassis = &unknown.vehicle().vehicle.chassis;
        let steer = u[input_index::STEERING_ANGLE];
        let front_slip = |s: &GripState, vx: f64| {
            s[state_index::OMEGA_FRONT] * chassis.front_wheel_radius
                - (vx * steer.cos()
                    + (x[state_index::VY] + chassis.cog_to_front_axle * x[state_index::YAW_RATE])
                        * steer.sin())
        };
        let rear_slip =
            |s: &GripState, vx: f64| s[state_index::OMEGA_REAR] * chassis.rear_wheel_radius - vx;
        let (vx, next_vx) = (x[state_index::VX], next[state_index::VX]);
        assert!((front_slip(&next, next_vx) - front_slip(&x, vx)).abs() < 1e-12);
        assert!((rear_slip(&next, next_vx) - rear_slip(&x, vx)).abs() < 1e-12);
        assert_ne!(next, known.transition(&x, &u));
        // without ax the same wheels, the speed from the body's force balance
        let no_ax = SpeedAnchoredModel::<HsriTyre>::extend_input(
            &SVector::<f64, INPUT_DIM>::from([0.06, 0.0, 0.0]),
            0.0,
            None,
        );
        let coasting = unknown.transition(&x, &no_ax);
        assert_eq!(
            unknown.measurement(&x, &no_ax)[ay],
            unknown.measurement(&spun, &no_ax)[ay]
        );
        let coasting_vx = coasting[state_index::VX];
        assert!((rear_slip(&coasting, coasting_vx) - rear_slip(&x, vx)).abs() < 1e-12);
        assert_ne!(coasting, known.transition(&x, &no_ax));
        // a brake torque reported: model A's wheels
        let braked = SpeedAnchoredModel::<HsriTyre>::extend_input(
            &SVector::<f64, INPUT_DIM>::from([0.06, 0.0, 800.0]),
            0.0,
            Some(-4.0),
        );
        assert_eq!(
            unknown.transition(&x, &braked),
            known.transition(&x, &braked)
        );
        assert_eq!(
            unknown.measurement(&x, &braked),
            known.measurement(&x, &braked)
        );
    }

    /// The `ay` row reads `(1 + e)` times model A's `ay` in a corner (less near 0:
    /// [`AY_GAIN_ONSET`]), the other rows do not see `e`, and `e` is a Gauss-Markov process about
    /// 0 of stationary std `ay_gain_std`.
    #[test]
    fn the_accelerometer_gain_scales_the_ay_row_only() {
        let model = grip_model();
        let x = extend_state(&SVector::<f64, STATE_DIM>::from([
            17.0, -0.4, 0.3, 55.5, 56.0,
        ]));
        let driver = SVector::<f64, INPUT_DIM>::from([0.06, 50.0, 800.0]);
        let u = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 120.0, Some(-2.0));
        let mut reading = x;
        reading[AY_GAIN] = 0.12;
        let (plain, scaled) = (model.measurement(&x, &u), model.measurement(&reading, &u));
        let ay = measurement_index::LATERAL_ACCELERATION;
        assert!(plain[ay].abs() > 1.0, "a corner: {}", plain[ay]);
        let share = plain[ay].powi(2) / (plain[ay].powi(2) + AY_GAIN_ONSET.powi(2));
        assert!((scaled[ay] - (1.0 + 0.12 * share) * plain[ay]).abs() < 1e-12 * plain[ay].abs());
        assert!(share > 0.8, "{share}");
        for row in (0..ANCHORED_MEASUREMENT_DIM).filter(|&row| row != ay) {
            assert_eq!(scaled[row], plain[row], "row {row}");
        }
        let (_, jacobian) = model.measurement_and_jacobian(&x, &u);
        assert!((jacobian[(ay, AY_GAIN)] - share * plain[ay]).abs() < 1e-12 * plain[ay].abs());
        // driving straight the row hardly sees the gain (AY_GAIN_ONSET)
        assert_eq!(read_ay(0.0, 0.12), 0.0);
        assert!((read_ay(0.1, 0.12) - 0.1).abs() < 0.12 * 0.1 * 0.02);
        let next = model.transition(&reading, &u);
        assert_eq!(
            next.fixed_rows::<STATE_DIM>(0),
            model.transition(&x, &u).fixed_rows::<STATE_DIM>(0),
            "the gain is the sensor's, not the car's"
        );
        let a = (-SAMPLE_TIME / AY_GAIN_TIME_CONSTANT).exp();
        assert!((next[AY_GAIN] - 0.12 * a).abs() < 1e-15);
        let q = model.process_noise()[(AY_GAIN, AY_GAIN)];
        assert!((q / (1.0 - a * a) - PRIOR.ay_gain_std.powi(2)).abs() < 1e-12);
        let start = PRIOR.extend_initial(&InitialEstimate {
            state: SVector::zeros(),
            covariance: SMatrix::identity(),
        });
        assert_eq!(start.state[AY_GAIN], 0.0);
        assert_eq!(
            start.covariance[(AY_GAIN, AY_GAIN)],
            PRIOR.ay_gain_std.powi(2)
        );
        for std in [-0.1, f64::NAN] {
            let prior = GripPrior {
                ay_gain_std: std,
                ..PRIOR
            };
            assert!(prior.check().is_err(), "{std}");
        }
        let fixed = GripPrior {
            ay_gain_std: 0.0,
            ..PRIOR
        };
        assert!(fixed.ay_gain_variance() > 0.0);
    }

    /// At grip 1 the first five states and the measurement are the speed-anchored model A's to
    /// the bit; a grip factor relaxes to 1 with `a = exp(−T/τ)`; the stationary std is `σ`.
    #[test]
    fn unit_grip_is_model_a_and_the_grip_is_gauss_markov() {
        let model = grip_model();
        let plain = anchored(1.0);
        let x5 = SVector::<f64, STATE_DIM>::from([17.0, -0.4, 0.3, 55.5, 56.0]);
        let x = extend_state(&x5);
        let driver = SVector::<f64, INPUT_DIM>::from([0.06, 50.0, 800.0]);
        for ax in [None, Some(-2.0)] {
            let u = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 120.0, ax);
            let next = model.transition(&x, &u);
            assert_eq!(next.fixed_rows::<STATE_DIM>(0), plain.transition(&x5, &u));
            assert_eq!(next[GRIP_FRONT], 1.0);
            assert_eq!(model.measurement(&x, &u), plain.measurement(&x5, &u));
        }
        let u = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 0.0, None);
        let mut gripped = x;
        gripped[GRIP_REAR] = 1.2;
        let a = (-SAMPLE_TIME / PRIOR.time_constant).exp();
        assert!((model.transition(&gripped, &u)[GRIP_REAR] - (1.0 + 0.2 * a)).abs() < 1e-15);
        let q = model.process_noise()[(GRIP_REAR, GRIP_REAR)];
        // stationary variance of g(k+1) = a g(k) + w: q / (1 − a²) = σ²
        assert!((q / (1.0 - a * a) - PRIOR.std * PRIOR.std).abs() < 1e-12);
        assert!(GripPrior { std: 0.0, ..PRIOR }.check().is_err());
        // the relaxation factor: the same Gauss-Markov law with its own time constant
        let mut relaxing = x;
        relaxing[RELAXATION_FACTOR] = 0.5;
        let a = (-SAMPLE_TIME / RELAXATION_FACTOR_TIME_CONSTANT).exp();
        let next = model.transition(&relaxing, &u)[RELAXATION_FACTOR];
        assert!((next - (1.0 - 0.5 * a)).abs() < 1e-15);
        let q = model.process_noise()[(RELAXATION_FACTOR, RELAXATION_FACTOR)];
        let variance = PRIOR.relaxation_std * PRIOR.relaxation_std;
        assert!((q / (1.0 - a * a) - variance).abs() < 1e-12);
        let fixed = GripPrior {
            relaxation_std: 0.0,
            ..PRIOR
        };
        assert!(fixed.relaxation_variance() > 0.0);
        assert!(GripPrior {
            relaxation_std: -0.1,
            ..PRIOR
        }
        .check()
        .is_err());
        let anchored_settings = model.anchored().estimator_settings(
            (x5, driver),
            true,
            SigmaPoints::Symmetric,
            Ok(ParticleFilterConfig::default()),
        );
        let design = model
            .extend_settings(anchored_settings)
            .observer_design
            .unwrap();
        assert_eq!(
            design.blocks,
            plain.inner().default_observer_design().blocks
        );
        assert_eq!(
            design.open_loop,
            [
                GRIP_FRONT,
                GRIP_REAR,
                TRANSIENT_SLIP_FRONT,
                TRANSIENT_SLIP_REAR,
                RELAXATION_FACTOR,
                AY_GAIN
            ]
        );
    }

    /// With tyres that lag the observer's gain is placed on the quasi-static tyre (relaxation
    /// factor 0), where it is the speed-anchored model A's gain: its body rows are model A's,
    /// its rows of the states left open loop zero. Placed at the relaxation factor's own value,
    /// the `vy` block sees `vy` only through the lag and its gain on `ay` is 3.6 times
    /// model A's (18 m/s, 10 ms, 0.5 m: `T |vx| / σ = 0.36`).
    #[test]
    fn the_observer_gain_is_model_a_s_placed_on_the_quasi_static_tyre() {
        use crate::luenberger::LuenbergerObserver;
        let model = grip_model().with_relaxation_length(0.5).unwrap();
        let x5 = SVector::<f64, STATE_DIM>::from([18.0, 0.0, 0.0, 60.0, 60.0]);
        let driver = SVector::<f64, INPUT_DIM>::zeros();
        // seed 000's linearisation of vx (no kinematics), as the FMU's observer
        let anchored_settings = model.anchored().estimator_settings(
            (x5, driver),
            false,
            SigmaPoints::Symmetric,
            Ok(ParticleFilterConfig::default()),
        );
        let (state5, input) = anchored_settings.operating_point.clone().unwrap();
        let design5 = anchored_settings.observer_design.clone().unwrap();
        let settings = model.extend_settings(anchored_settings);
        let (state, _) = settings.operating_point.clone().unwrap();
        let design = settings.observer_design.unwrap();
        assert_eq!(design.placement_state, [(RELAXATION_FACTOR, 0.0)]);
        let start =
            |x: &SVector<f64, GRIP_STATE_DIM>| InitialEstimate::diagonal(*x, x.map(|_| 1.0));
        let observer =
            LuenbergerObserver::new(model.clone(), &state, &input, &design, &start(&state))
                .unwrap();
        let start5 = InitialEstimate::diagonal(state5, state5.map(|_| 1.0));
        let model_a =
            LuenbergerObserver::new(model.anchored().clone(), &state5, &input, &design5, &start5)
                .unwrap();
        let gain = observer.gain();
        let scale = model_a.gain().amax();
        let body = gain.fixed_rows::<STATE_DIM>(0) - model_a.gain();
        assert!(body.amax() < 1e-12 * scale, "{body}");
        for &open in &design.open_loop {
            assert_eq!(gain.row(open).amax(), 0.0, "state {open}");
        }
        let at_the_lag = LuenbergerObserver::new(
            model,
            &state,
            &input,
            &ObserverDesign {
                placement_state: Vec::new(),
                ..design
            },
            &start(&state),
        )
        .unwrap();
        let ay = measurement_index::LATERAL_ACCELERATION;
        let ratio = at_the_lag.gain()[(state_index::VY, ay)] / gain[(state_index::VY, ay)];
        assert!(ratio > 3.0 && ratio < 4.5, "{ratio}");
    }

    /// With a relaxation length the transient slip angles close `T |Vcx| / σ` of their gap to
    /// the kinematic ones per sample (all of it when that is 1 or more), the forces use them (a
    /// transient slip angle equal to the kinematic one is model A to the bit), and without one
    /// they only track the kinematic ones.
    #[test]
    fn transient_slip_angles_lag_the_kinematic_ones_by_the_relaxation_length() {
        let sigma = 0.5;
        let lagged = grip_model().with_relaxation_length(sigma).unwrap();
        let plain = anchored(1.0);
        let x5 = SVector::<f64, STATE_DIM>::from([20.0, -0.3, 0.25, 66.0, 66.0]);
        let driver = SVector::<f64, INPUT_DIM>::from([0.04, 0.0, 0.0]);
        let u = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 0.0, None);
        let kinematic = lagged
            .vehicle()
            .kinematic_slip(&x5.data.0[0], &driver.data.0[0]);
        // settled: the transient slip angles are the kinematic ones, the body is model A's
        let mut settled = extend_state(&x5);
        settled[TRANSIENT_SLIP_FRONT] = kinematic[0].tan_slip_angle;
        settled[TRANSIENT_SLIP_REAR] = kinematic[1].tan_slip_angle;
        let next = lagged.transition(&settled, &u);
        assert_eq!(next.fixed_rows::<STATE_DIM>(0), plain.transition(&x5, &u));
        assert_eq!(lagged.measurement(&settled, &u), plain.measurement(&x5, &u));
        // from straight running, one sample closes T |Vcx| / σ (0.4 here) of the gap
        let start = extend_state(&x5);
        let next = lagged.transition(&start, &u);
        for (axle, index) in [(0, TRANSIENT_SLIP_FRONT), (1, TRANSIENT_SLIP_REAR)] {
            let share = SAMPLE_TIME * kinematic[axle].wheel_velocity.abs() / sigma;
            assert!(share > 0.3 && share < 0.5);
            let expected = share * kinematic[axle].tan_slip_angle;
            assert!((next[index] - expected).abs() < 1e-15 * expected.abs().max(1.0));
        }
        // a relaxation length shorter than a sample's rolling: one sample's delay
        let short = grip_model().with_relaxation_length(0.1).unwrap();
        let next = short.transition(&start, &u);
        assert_eq!(next[TRANSIENT_SLIP_REAR], kinematic[1].tan_slip_angle);
        // not yet settled, the lagged tyres carry less side force than model A's
        assert!(lagged.measurement(&start, &u)[1].abs() < plain.measurement(&x5, &u)[1].abs());
        // without lag the states track the kinematic slip angles and change no force
        let unlagged = grip_model();
        let next = unlagged.transition(&start, &u);
        assert_eq!(next[TRANSIENT_SLIP_REAR], kinematic[1].tan_slip_angle);
        assert_eq!(unlagged.measurement(&start, &u), plain.measurement(&x5, &u));
        assert!(grip_model().with_relaxation_length(-0.1).is_err());
        assert!(grip_model().with_relaxation_length(f64::NAN).is_err());
    }

    /// The relaxation factor `κ` blends the slip angle the tyre law sees between the transient
    /// one (`κ = 1`) and the kinematic one (`κ = 0`, model A to the bit; below 0 held at 0), and
    /// the force follows it linearly between.
    #[test]
    fn the_relaxation_factor_blends_the_lagged_and_the_instantaneous_slip_angle() {
        let lagged = grip_model().with_relaxation_length(0.5).unwrap();
        let plain = anchored(1.0);
        let x5 = SVector::<f64, STATE_DIM>::from([20.0, -0.3, 0.25, 66.0, 66.0]);
        let driver = SVector::<f64, INPUT_DIM>::from([0.04, 0.0, 0.0]);
        let u = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 0.0, None);
        let ay = |factor: f64| {
            // transient slip angles of straight running, a corner's kinematic ones
            let mut x = extend_state(&x5);
            x[RELAXATION_FACTOR] = factor;
            lagged.measurement(&x, &u)[1]
        };
        let instantaneous = plain.measurement(&x5, &u)[1];
        assert_eq!(ay(0.0), instantaneous);
        assert_eq!(ay(-0.5), instantaneous);
        assert!(ay(1.0).abs() < 0.1 * instantaneous.abs(), "{}", ay(1.0));
        // between: the slip angle is the blend, so a small step moves ay by a share of the gap
        let half = ay(0.5);
        assert!(half.abs() > ay(1.0).abs() && half.abs() < instantaneous.abs());
        // the Jacobian sees the factor: ∂ay/∂κ of the sign that takes force away
        let (_, jacobian) = lagged.measurement_and_jacobian(&extend_state(&x5), &u);
        assert!(jacobian[(1, RELAXATION_FACTOR)] * instantaneous < 0.0);
    }

    /// The truth: model A with 15 % stiffer rear tyres, a 2° steering sine of 4 s period at
    /// 20 m/s, simulated at 1 ms and sampled at 10 ms with series sensor noise; measurement,
    /// driver input and true sideslip per sample.
    struct Truth {
        measurements: Vec<SVector<f64, ANCHORED_MEASUREMENT_DIM>>,
        inputs: Vec<SVector<f64, ANCHORED_INPUT_DIM>>,
        sideslip: Vec<f64>,
    }

    fn truth(samples: usize) -> Truth {
        let model = anchored(1.15);
        let vehicle = model.vehicle();
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let noise: Vec<Normal<f64>> = SENSOR_STD
            .iter()
            .map(|&s| Normal::new(0.0, s).unwrap())
            .collect();
        let mut x = vehicle.straight_rolling_state(20.0);
        let mut out = Truth {
            measurements: Vec::new(),
            inputs: Vec::new(),
            sideslip: Vec::new(),
        };
        for k in 0..samples {
            let t = k as f64 * SAMPLE_TIME;
            let steer = 2f64.to_radians() * (2.0 * std::f64::consts::PI * t / 4.0).sin();
            let driver = SVector::<f64, INPUT_DIM>::from([steer, 0.0, 0.0]);
            let o = vehicle.outputs(&x, &driver);
            let exact = [x[2], o.lateral_acceleration, x[3], x[4], x[0]];
            out.measurements.push(SVector::from_fn(|i, _| {
                exact[i] + noise[i].sample(&mut rng)
            }));
            let ax = o.longitudinal_acceleration + noise[1].sample(&mut rng);
            out.inputs
                .push(SpeedAnchoredModel::<HsriTyre>::extend_input(
                    &driver,
                    0.0,
                    Some(ax),
                ));
            out.sideslip.push(o.sideslip);
            for _ in 0..10 {
                x = vehicle.step(&x, &driver, 1e-3, Integrator::SemiImplicitEuler);
            }
        }
        out
    }

    /// Time-averaged sideslip NEES after 2 s of an EKF on `model` over `truth`.
    fn sideslip_nees<const N: usize, Model>(
        model: Model,
        start: InitialEstimate<N>,
        truth: &Truth,
    ) -> f64
    where
        Model: crate::registry::RegistryModel<N, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>,
    {
        let settings = EstimatorSettings {
            operating_point: Err(SettingsError(String::from("unused"))),
            scaled_sigma_points: SigmaPoints::Symmetric,
            observer_design: Err(SettingsError(String::from("unused"))),
            particles: Err(SettingsError(String::from("unused"))),
        };
        let mut filter = registry::build(model, EstimatorChoice::Ekf, &settings, &start).unwrap();
        let (mut sum, mut count) = (0.0, 0);
        for (k, (y, u)) in truth.measurements.iter().zip(&truth.inputs).enumerate() {
            filter
                .update(y, u, &[true; ANCHORED_MEASUREMENT_DIM])
                .unwrap();
            let (x, p) = (filter.state(), filter.covariance());
            let (vx, vy) = (x[0], x[1]);
            let s2 = vx * vx + vy * vy;
            let g = [-vy / s2, vx / s2];
            let variance =
                g[0] * g[0] * p[(0, 0)] + 2.0 * g[0] * g[1] * p[(0, 1)] + g[1] * g[1] * p[(1, 1)];
            if k as f64 * SAMPLE_TIME >= 2.0 {
                sum += (vy.atan2(vx) - truth.sideslip[k]).powi(2) / variance;
                count += 1;
            }
            filter.predict(u).unwrap();
        }
        sum / count as f64
    }

    /// Against a truth whose rear tyres are 15 % stiffer than the filter's, model A is
    /// overconfident in sideslip; with the grip states the sideslip NEES is that of a filter
    /// that knows the true tyres (within a factor 2) and below 2. Both are below 1 because the
    /// truth has no process noise while the filters assume the FMU's default `Q`. The test fails
    /// if the grip states are frozen: their model is then model A.
    #[test]
    fn grip_states_make_the_sideslip_covariance_honest_under_a_stiffness_mismatch() {
        let truth = truth(1500);
        let x5 = SVector::<f64, STATE_DIM>::from([20.0, 0.0, 0.0, 20.0 / 0.3, 20.0 / 0.3]);
        let start = InitialEstimate::diagonal(x5, SVector::from([0.25, 0.01, 1e-4, 1.0, 1.0]));
        let model_a = sideslip_nees(anchored(1.0), start, &truth);
        let true_tyres = sideslip_nees(anchored(1.15), start, &truth);
        let grip = grip_model();
        let with_grip = sideslip_nees(grip.clone(), grip.prior().extend_initial(&start), &truth);
        // measured: model A 11.6, true tyres 0.53, grip model 0.29
        let report = format!("model A {model_a}, true tyres {true_tyres}, grip {with_grip}");
        assert!(model_a > 10.0 * true_tyres, "{report}");
        assert!(with_grip < 2.0 && with_grip > 0.5 * true_tyres, "{report}");
    }

    /// Every estimator of the registry runs on the grip model and stays finite (the Luenberger
    /// observer linearised with the force balance's `vx`, as the FMU runs it: its design
    /// observes `(vx, ωF, ωR)` through the front wheel speed, which the kinematic `vx` row would
    /// decouple).
    #[test]
    fn the_registry_builds_every_estimator() {
        let model = grip_model();
        let truth = truth(300);
        let x5 = SVector::<f64, STATE_DIM>::from([20.0, 0.0, 0.0, 20.0 / 0.3, 20.0 / 0.3]);
        let start = model.prior().extend_initial(&InitialEstimate::diagonal(
            x5,
            SVector::from([0.25, 0.01, 1e-4, 1.0, 1.0]),
        ));
        for &choice in EstimatorChoice::ALL {
            let settings = model.extend_settings(model.anchored().estimator_settings(
                (x5, SVector::zeros()),
                choice != EstimatorChoice::Luenberger,
                SigmaPoints::scaled(0.5, 2.0, 0.0),
                Ok(ParticleFilterConfig::default()),
            ));
            let mut filter = registry::build(model.clone(), choice, &settings, &start).unwrap();
            for (y, u) in truth.measurements.iter().zip(&truth.inputs) {
                let _ = filter.update(y, u, &[true; ANCHORED_MEASUREMENT_DIM]);
                let _ = filter.predict(u);
            }
            assert!(filter.state().iter().all(|v| v.is_finite()), "{choice:?}");
            assert!((filter.state()[GRIP_REAR] - 1.0).abs() < 0.5, "{choice:?}");
        }
    }
}
