//! Model A (5-state single-track with HSRI tyres, seed 000) as a [`StateSpaceModel<5, 4, 3>`].
//!
//! - state `x = [vx, vy, yaw_rate, omega_front, omega_rear]`,
//! - measurement `y = [yaw_rate, ay, omega_front, omega_rear]` (000: 5.63),
//! - input `u = [steering_angle, drive_torque, brake_torque]`, `brake_torque ≥ 0` being the
//!   magnitude (the seed's `M_B = −brake_torque`, see [`vehicle_models::driver_input`]).
//!
//! The discrete transition is the vehicle-models crate's step over the adapter's sample time
//! (seed scheme 000: 6.1-6.5 by default, RK4 optional); the Jacobians are that crate's
//! forward-mode automatic derivatives of the same code (exact to rounding). The adapter seeds
//! only the directions a call needs (5 for `∂f/∂x`, 3 for `∂f/∂u`), which keeps the EKF step cheap.

use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::INPUT_DIM;
use vehicle_models::single_track::{state_index, MEASUREMENT_DIM, STATE_DIM};
use vehicle_models::{Dual, HsriTyre, Integrator, Scalar, SingleTrackModel, TyreModel};

use crate::kalman::{SettingsError, SigmaPoints};
use crate::luenberger::{DesignBlock, ObserverDesign};
use crate::particle::ParticleFilterConfig;
use crate::registry::{EstimatorSettings, OperatingPoint};
use crate::StateSpaceModel;

/// Process noise standard deviations of seed 000's experiments, per step,
/// `[vx, vy, r, ωF, ωR]` (SPEC §7).
pub const SEED_PROCESS_NOISE_STD: [f64; STATE_DIM] = [1e-3, 1e-4, 1e-4, 1e-3, 1e-3];

/// Measurement noise standard deviation of seed 000's experiments, on all four outputs (SPEC §7).
pub const SEED_MEASUREMENT_NOISE_STD: f64 = 1e-4;

/// Operating point of the LKF and the Luenberger observer: straight driving at
/// `vx0 = 18 m/s, vy0 = 0, r0 = 0, ωF0 = ωR0 = 60 rad/s`, no input (000: 5.58-5.62, ch. 7 intro).
pub fn seed_operating_point() -> (SVector<f64, STATE_DIM>, SVector<f64, INPUT_DIM>) {
    (
        SVector::<f64, STATE_DIM>::from([18.0, 0.0, 0.0, 60.0, 60.0]),
        SVector::<f64, INPUT_DIM>::zeros(),
    )
}

/// Model A with a sample time, an integrator and the noise covariances a filter assumes.
#[derive(Debug, Clone, PartialEq)]
pub struct SingleTrackEstimationModel<T: TyreModel = HsriTyre> {
    vehicle: SingleTrackModel<T>,
    sample_time: f64,
    integrator: Integrator,
    process_noise: SMatrix<f64, STATE_DIM, STATE_DIM>,
    measurement_noise: SMatrix<f64, MEASUREMENT_DIM, MEASUREMENT_DIM>,
}

impl<T: TyreModel> SingleTrackEstimationModel<T> {
    /// Model A over `sample_time` seconds with diagonal `Q` and `R` given by their variances.
    pub fn new(
        vehicle: SingleTrackModel<T>,
        sample_time: f64,
        integrator: Integrator,
        process_noise_variances: [f64; STATE_DIM],
        measurement_noise_variances: [f64; MEASUREMENT_DIM],
    ) -> Result<Self, SettingsError> {
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(SettingsError(format!(
                "the sample time must be a positive number of seconds, got {sample_time}"
            )));
        }
        if let Some(v) = process_noise_variances
            .iter()
            .find(|v| !(v.is_finite() && **v > 0.0))
        {
            return Err(SettingsError(format!(
                "the process noise variances (Q diagonal) must be positive, got {v} in {process_noise_variances:?}"
            )));
        }
        if let Some(v) = measurement_noise_variances
            .iter()
            .find(|v| !(v.is_finite() && **v > 0.0))
        {
            return Err(SettingsError(format!(
                "the measurement noise variances (R diagonal) must be positive, got {v} in {measurement_noise_variances:?}"
            )));
        }
        Ok(Self {
            vehicle,
            sample_time,
            integrator,
            process_noise: SMatrix::from_diagonal(&SVector::from(process_noise_variances)),
            measurement_noise: SMatrix::from_diagonal(&SVector::from(measurement_noise_variances)),
        })
    }

    /// The vehicle model.
    pub fn vehicle(&self) -> &SingleTrackModel<T> {
        &self.vehicle
    }

    /// Sample time of one `transition`, s.
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// The integrator of one `transition`.
    pub fn integrator(&self) -> Integrator {
        self.integrator
    }

    /// The observer design used by default for model A: `vy` observed through the lateral
    /// acceleration, `r` through the yaw rate, and `(vx, ωF, ωR)` through the front wheel speed
    /// (see [`crate::luenberger`]). The lateral acceleration drives `vy` because it measures the
    /// tyre forces, hence `vy`, directly: on the moderate ramp of seed 000 at 10 ms the vy RMSE
    /// is 3e-4 m/s with `ay` against 0.14 m/s with the yaw rate driving both lateral states
    /// (tests/luenberger_model_a.rs). The gyro drives `r`: near the tyres' limit `ay`
    /// hardly depends on `vy` any more (the flat top of the tyre curve), and a lateral block
    /// observed through `ay` alone lost the yaw rate (on the Escort's slow ramp of the mismatch
    /// campaigns 0.70 rad/s against a true 0.42; fmu-src/estimation/README.md, "Luenberger
    /// observer"). In a corner `vy` and `r` are coupled, so the two one-state blocks
    /// get their poles only up to that coupling ([`crate::luenberger::scheduled_observer_gain`]).
    /// Poles (continuous time, mapped by `z = exp(s T)`): lateral `-40 1/s` each, longitudinal
    /// `-30, -250, -400 1/s`, a few times faster than the vehicle's own modes at 18 m/s (lateral
    /// about -10 1/s, wheel spin about -110 and -370 1/s, the free-rolling speed mode neutral),
    /// in the spirit of seed 002's "observer poles a multiple of the system's eigenvalues".
    pub fn default_observer_design(&self) -> ObserverDesign {
        use vehicle_models::single_track::measurement_index;
        let t = self.sample_time;
        ObserverDesign {
            blocks: vec![
                DesignBlock::real_poles(
                    vec![state_index::VY],
                    measurement_index::LATERAL_ACCELERATION,
                    &[-40.0],
                    t,
                ),
                DesignBlock::real_poles(
                    vec![state_index::YAW_RATE],
                    measurement_index::YAW_RATE,
                    &[-40.0],
                    t,
                ),
                DesignBlock::real_poles(
                    vec![
                        state_index::VX,
                        state_index::OMEGA_FRONT,
                        state_index::OMEGA_REAR,
                    ],
                    measurement_index::OMEGA_FRONT,
                    &[-30.0, -250.0, -400.0],
                    t,
                ),
            ],
            open_loop: Vec::new(),
            placement_state: Vec::new(),
        }
    }
}

impl<T: TyreModel> SingleTrackEstimationModel<T> {
    /// The registry's settings for model A: the linear estimators' operating point, the scaled
    /// UKF's sigma points, the particle filter's configuration and the default observer design
    /// ([`Self::default_observer_design`]).
    pub fn estimator_settings(
        &self,
        operating_point: OperatingPoint<STATE_DIM, INPUT_DIM>,
        scaled_sigma_points: SigmaPoints,
        particles: Result<ParticleFilterConfig, SettingsError>,
    ) -> EstimatorSettings<STATE_DIM, INPUT_DIM> {
        EstimatorSettings {
            operating_point: Ok(operating_point),
            scaled_sigma_points,
            observer_design: Ok(self.default_observer_design()),
            particles,
        }
    }

    /// The settings of seed 000's experiments: the seed's operating point
    /// ([`seed_operating_point`]), the scaled UKF with `alpha, beta, kappa = 0.5, 2, 0`, the
    /// default particle filter.
    pub fn seed_settings(&self) -> EstimatorSettings<STATE_DIM, INPUT_DIM> {
        self.estimator_settings(
            seed_operating_point(),
            SigmaPoints::scaled(0.5, 2.0, 0.0),
            Ok(ParticleFilterConfig::default()),
        )
    }
}

impl SingleTrackEstimationModel<HsriTyre> {
    /// Model A with the seed's vehicle and tyre data, the seed scheme and the noise of seed
    /// 000's experiments (`Q = diag(w²)`, `R = diag(v²)`, SPEC §7).
    pub fn seed_000(sample_time: f64) -> Result<Self, SettingsError> {
        Self::new(
            SingleTrackModel::default(),
            sample_time,
            Integrator::SemiImplicitEuler,
            SEED_PROCESS_NOISE_STD.map(|w| w * w),
            [SEED_MEASUREMENT_NOISE_STD * SEED_MEASUREMENT_NOISE_STD; MEASUREMENT_DIM],
        )
    }
}

/// Model A's transition with an optional drive torque on the rear axle
/// ([`SingleTrackModel::step_with_rear_drive`]): `None` is seed 000's front-driven model, which
/// the [`StateSpaceModel`] implementation is; [`SpeedAnchoredModel`] passes its rear drive
/// torque input.
impl<T: TyreModel> SingleTrackEstimationModel<T> {
    fn step<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        rear: Option<S>,
    ) -> [S; STATE_DIM] {
        self.vehicle
            .step_with_rear_drive(x, u, rear, self.sample_time, self.integrator)
    }

    /// `f(x, u)` with the rear drive torque `rear`, N·m.
    pub fn transition_with_rear_drive(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
        rear: Option<f64>,
    ) -> SVector<f64, STATE_DIM> {
        let next = self.step(&as_array(state), &as_array(input), rear.map(Remembering));
        SVector::from(next.map(|v| v.0))
    }

    /// One dual-number pass: its value parts are `f(x, u)` (the same operations on the same
    /// numbers as [`Self::transition_with_rear_drive`]), its gradients `∂f/∂x`.
    pub fn transition_and_jacobian_with_rear_drive(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
        rear: Option<f64>,
    ) -> (SVector<f64, STATE_DIM>, SMatrix<f64, STATE_DIM, STATE_DIM>) {
        let x = as_array(state);
        let u = as_array(input);
        let xs: [StateDual; STATE_DIM] = core::array::from_fn(|i| Dual::variable(x[i], i));
        let us: [StateDual; INPUT_DIM] = core::array::from_fn(|j| Dual::from_value(u[j]));
        let rear = rear.map(|torque| Dual::from_value(Remembering(torque)));
        let next = self.step(&xs, &us, rear);
        (
            SVector::from_fn(|i, _| next[i].value.0),
            SMatrix::from_fn(|i, j| next[i].gradient[j].0),
        )
    }

    /// `∂f/∂u` over the `K` input directions: the driver input's, and with `K = INPUT_DIM + 1`
    /// the rear drive torque's as the last column.
    pub fn input_jacobian_with_rear_drive<const K: usize>(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
        rear: Option<f64>,
    ) -> SMatrix<f64, STATE_DIM, K> {
        let x = as_array(state);
        let u = as_array(input);
        let xs: [Dual<Remembering, K>; STATE_DIM] =
            core::array::from_fn(|i| Dual::from_value(x[i]));
        let us: [Dual<Remembering, K>; INPUT_DIM] =
            core::array::from_fn(|j| Dual::variable(u[j], j));
        let rear = rear.map(|torque| {
            if K > INPUT_DIM {
                Dual::variable(Remembering(torque), INPUT_DIM)
            } else {
                Dual::from_value(Remembering(torque))
            }
        });
        let next = self.step(&xs, &us, rear);
        SMatrix::from_fn(|i, j| next[i].gradient[j].0)
    }
}

type StateDual = Dual<Remembering, STATE_DIM>;
type InputDual = Dual<Remembering, INPUT_DIM>;

fn as_array<const K: usize>(v: &SVector<f64, K>) -> [Remembering; K] {
    v.data.0[0].map(Remembering)
}

/// `f64` for the model equations, except that it remembers, per thread, the sine and cosine of
/// the last angle it took them of.
///
/// A filter evaluates the model at many states but one input per step (2n + 1 sigma points, a
/// thousand particles, the Jacobians at the estimate), and the steering angle's `sin` and `cos`
/// (000: 5.16, 5.42-5.44) were a tenth of a UKF step. The remembered values are those `f64`
/// gives for the same argument bits, and every other operation is `f64`'s, so the results are
/// bit-identical to evaluating in `f64` (tested below).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Remembering(f64);

thread_local! {
    /// The bits of the last angle, its sine and its cosine (initially those of 0).
    static LAST_ANGLE: std::cell::Cell<(u64, f64, f64)> = const { std::cell::Cell::new((0, 0.0, 1.0)) };
}

impl Remembering {
    #[inline(always)]
    fn sin_cos(self) -> (f64, f64) {
        let angle = self.0;
        LAST_ANGLE.with(|last| {
            let (bits, sin, cos) = last.get();
            if bits == angle.to_bits() {
                (sin, cos)
            } else {
                let (sin, cos) = (angle.sin(), angle.cos());
                last.set((angle.to_bits(), sin, cos));
                (sin, cos)
            }
        })
    }
}

macro_rules! remembering_operators {
    ($($operator:ident $method:ident $symbol:tt),*) => {$(
        impl std::ops::$operator for Remembering {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: Self) -> Self {
                Self(self.0 $symbol rhs.0)
            }
        }
        impl std::ops::$operator<f64> for Remembering {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: f64) -> Self {
                Self(self.0 $symbol rhs)
            }
        }
    )*};
}
remembering_operators!(Add add +, Sub sub -, Mul mul *, Div div /);

impl std::ops::Neg for Remembering {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self(-self.0)
    }
}

impl Scalar for Remembering {
    #[inline(always)]
    fn constant(value: f64) -> Self {
        Self(value)
    }
    #[inline(always)]
    fn value(&self) -> f64 {
        self.0
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Self(self.0.sqrt())
    }
    #[inline(always)]
    fn sin(self) -> Self {
        Self(self.sin_cos().0)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        Self(self.sin_cos().1)
    }
    #[inline(always)]
    fn atan(self) -> Self {
        Self(self.0.atan())
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        Self(self.0.atan2(x.0))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Self(self.0.abs())
    }
    #[inline(always)]
    fn exp(self) -> Self {
        Self(self.0.exp())
    }
}

impl<T: TyreModel> StateSpaceModel<STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>
    for SingleTrackEstimationModel<T>
{
    fn state_names(&self) -> [&'static str; STATE_DIM] {
        [
            "longitudinal_velocity",
            "lateral_velocity",
            "yaw_rate",
            "omega_front",
            "omega_rear",
        ]
    }

    fn measurement_names(&self) -> [&'static str; MEASUREMENT_DIM] {
        [
            "yaw_rate",
            "lateral_acceleration",
            "omega_front",
            "omega_rear",
        ]
    }

    fn transition(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SVector<f64, STATE_DIM> {
        self.transition_with_rear_drive(state, input, None)
    }

    fn transition_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        // The same dual-number pass; its value parts cost nothing extra.
        self.transition_and_jacobian(state, input).1
    }

    /// One dual-number pass: its value parts are `f(x, u)` (the same operations on the same
    /// numbers as [`Self::transition`]), its gradients `∂f/∂x`.
    fn transition_and_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> (SVector<f64, STATE_DIM>, SMatrix<f64, STATE_DIM, STATE_DIM>) {
        self.transition_and_jacobian_with_rear_drive(state, input, None)
    }

    fn transition_input_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, STATE_DIM, INPUT_DIM> {
        self.input_jacobian_with_rear_drive(state, input, None)
    }

    fn measurement(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SVector<f64, MEASUREMENT_DIM> {
        let y = self
            .vehicle
            .measurement_generic(&as_array(state), &as_array(input));
        SVector::from(y.map(|v| v.0))
    }

    fn measurement_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, MEASUREMENT_DIM, STATE_DIM> {
        self.measurement_and_jacobian(state, input).1
    }

    /// One dual-number pass for `h(x, u)` and `∂h/∂x`, as in [`Self::transition_and_jacobian`].
    fn measurement_and_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> (
        SVector<f64, MEASUREMENT_DIM>,
        SMatrix<f64, MEASUREMENT_DIM, STATE_DIM>,
    ) {
        let x = as_array(state);
        let u = as_array(input);
        let xs: [StateDual; STATE_DIM] = core::array::from_fn(|i| Dual::variable(x[i], i));
        let us: [StateDual; INPUT_DIM] = core::array::from_fn(|j| Dual::from_value(u[j]));
        let y = self.vehicle.measurement_generic(&xs, &us);
        (
            SVector::from_fn(|i, _| y[i].value.0),
            SMatrix::from_fn(|i, j| y[i].gradient[j].0),
        )
    }

    fn measurement_input_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, MEASUREMENT_DIM, INPUT_DIM> {
        let x = as_array(state);
        let u = as_array(input);
        let xs: [InputDual; STATE_DIM] = core::array::from_fn(|i| Dual::from_value(x[i]));
        let us: [InputDual; INPUT_DIM] = core::array::from_fn(|j| Dual::variable(u[j], j));
        let y = self.vehicle.measurement_generic(&xs, &us);
        SMatrix::from_fn(|i, j| y[i].gradient[j].0)
    }

    fn process_noise(&self) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        self.process_noise
    }

    fn measurement_noise(&self) -> SMatrix<f64, MEASUREMENT_DIM, MEASUREMENT_DIM> {
        self.measurement_noise
    }
}

/// Measurements of the speed-anchored model A: `y = [yaw_rate, ay, omega_front, omega_rear, vx]`.
pub const ANCHORED_MEASUREMENT_DIM: usize = MEASUREMENT_DIM + 1;

/// Inputs of the speed-anchored model A: `u = [steering_angle, drive_torque, brake_torque,
/// drive_torque_rear, ax, ax_valid]`: the driver input (`drive_torque` on the front axle) with a
/// drive torque on the rear axle (rear- and all-wheel drive cars), and `ax_valid` 1
/// when `ax` is a measured longitudinal acceleration, else 0.
pub const ANCHORED_INPUT_DIM: usize = INPUT_DIM + 3;

/// Row of the measured speed `vx` in `y` of [`SpeedAnchoredModel`].
pub const VX_ROW: usize = MEASUREMENT_DIM;

/// Index of the rear axle's drive torque (N·m, both rear wheels) in `u` of
/// [`SpeedAnchoredModel`]; it enters the rear wheel dynamics as the front's drive torque enters
/// the front's (000: 5.45-5.46).
pub const REAR_DRIVE_INPUT: usize = INPUT_DIM;

/// Index of the measured longitudinal acceleration in `u` of [`SpeedAnchoredModel`].
pub const AX_INPUT: usize = INPUT_DIM + 1;

/// Index of the flag that says whether [`AX_INPUT`] holds a measurement.
pub const AX_VALID_INPUT: usize = INPUT_DIM + 2;

/// Model A with a speed anchor: series cars rarely report the drive and
/// brake torques, and without them model A's `vx` follows the tyre forces of guessed torques
/// and runs away once the tyres slide. Two measurements fix the speed independently of the
/// torques:
///
/// - a measurement row `vx` (`h = vx`, from `vx_meas`: a GNSS or the ABS unit's reference speed);
/// - when `ax_valid = 1`, the longitudinal kinematics of a rigid body in the body frame,
///   `dvx/dt = ax + r vy` (ISO 8855; the same relation as `ay = dvy/dt + r vx`, 000: 5.40), replace
///   the force balance of the `vx` row in the transition: `vx(k+1) = vx + T (ax + r vy)` (explicit
///   Euler with the state at the start of the sample).
///
/// The wheel speeds keep their own dynamics (000: 5.45-5.46), so the wheels still carry the speed
/// when neither measurement is there. With `ax_valid = 0` and the `vx` row missing (not finite) the
/// model is the plain [`SingleTrackEstimationModel`] to the bit: the extra input column and row
/// only add exact zeros. The linear filters (LKF, Luenberger) are linearised once: at
/// `ax_valid = 1` they predict `vx` by the kinematics, taking `ax = 0` when none is measured
/// (see [`Self::estimator_settings`]); at `ax_valid = 0` they are seed 000's.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedAnchoredModel<T: TyreModel = HsriTyre> {
    inner: SingleTrackEstimationModel<T>,
    /// `R` of the `vx` row, (m/s)².
    speed_noise_variance: f64,
}

impl<T: TyreModel> SpeedAnchoredModel<T> {
    /// `inner` with a `vx` row of variance `speed_noise_variance`.
    pub fn new(
        inner: SingleTrackEstimationModel<T>,
        speed_noise_variance: f64,
    ) -> Result<Self, SettingsError> {
        if !(speed_noise_variance.is_finite() && speed_noise_variance > 0.0) {
            return Err(SettingsError(format!(
                "the speed measurement variance must be positive, got {speed_noise_variance}"
            )));
        }
        Ok(Self {
            inner,
            speed_noise_variance,
        })
    }

    /// Model A without the anchor.
    pub fn inner(&self) -> &SingleTrackEstimationModel<T> {
        &self.inner
    }

    /// The vehicle model.
    pub fn vehicle(&self) -> &SingleTrackModel<T> {
        self.inner.vehicle()
    }

    /// The registry's settings (see [`SingleTrackEstimationModel::estimator_settings`]), the
    /// operating point's input extended by no rear drive torque, `ax = 0` and `ax_valid = 1` if
    /// `kinematics` (the
    /// linear estimators then predict `vx` by the kinematics too, with `ax = 0` when no `ax` is
    /// measured), else `ax_valid = 0` (seed 000's linearisation).
    pub fn estimator_settings(
        &self,
        operating_point: OperatingPoint<STATE_DIM, INPUT_DIM>,
        kinematics: bool,
        scaled_sigma_points: SigmaPoints,
        particles: Result<ParticleFilterConfig, SettingsError>,
    ) -> EstimatorSettings<STATE_DIM, ANCHORED_INPUT_DIM> {
        let (state, input) = operating_point;
        let ax = kinematics.then_some(0.0);
        EstimatorSettings {
            operating_point: Ok((state, Self::extend_input(&input, 0.0, ax))),
            scaled_sigma_points,
            observer_design: Ok(self.inner.default_observer_design()),
            particles,
        }
    }

    /// The anchored input from the driver input, the rear axle's drive torque and the
    /// measured `ax`, if any.
    pub fn extend_input(
        driver: &SVector<f64, INPUT_DIM>,
        rear_drive_torque: f64,
        ax: Option<f64>,
    ) -> SVector<f64, ANCHORED_INPUT_DIM> {
        let (ax, valid) = match ax {
            Some(ax) if ax.is_finite() => (ax, 1.0),
            _ => (0.0, 0.0),
        };
        SVector::from([
            driver[0],
            driver[1],
            driver[2],
            rear_drive_torque,
            ax,
            valid,
        ])
    }

    fn driver(input: &SVector<f64, ANCHORED_INPUT_DIM>) -> SVector<f64, INPUT_DIM> {
        input.fixed_rows::<INPUT_DIM>(0).into_owned()
    }

    fn rear_drive(input: &SVector<f64, ANCHORED_INPUT_DIM>) -> Option<f64> {
        Some(input[REAR_DRIVE_INPUT])
    }

    fn ax(input: &SVector<f64, ANCHORED_INPUT_DIM>) -> Option<f64> {
        (input[AX_VALID_INPUT] == 1.0).then_some(input[AX_INPUT])
    }

    /// `vx + T (ax + r vy)` (the kinematics above), generic over the scalar; `state` starts
    /// with model A's states (the grip model's too).
    pub(super) fn kinematic_speed<S: Scalar, const K: usize>(&self, state: &[S; K], ax: S) -> S {
        let (vx, vy, r) = (
            state[state_index::VX],
            state[state_index::VY],
            state[state_index::YAW_RATE],
        );
        vx + (ax + r * vy) * self.inner.sample_time()
    }

    /// The `vx` row of `∂f/∂x` under the kinematics.
    fn kinematic_row(&self, state: &SVector<f64, STATE_DIM>) -> [f64; STATE_DIM] {
        let t = self.inner.sample_time();
        let mut row = [0.0; STATE_DIM];
        row[state_index::VX] = 1.0;
        row[state_index::VY] = t * state[state_index::YAW_RATE];
        row[state_index::YAW_RATE] = t * state[state_index::VY];
        row
    }
}

impl<T: TyreModel> StateSpaceModel<STATE_DIM, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>
    for SpeedAnchoredModel<T>
{
    fn state_names(&self) -> [&'static str; STATE_DIM] {
        self.inner.state_names()
    }

    fn measurement_names(&self) -> [&'static str; ANCHORED_MEASUREMENT_DIM] {
        let [r, ay, front, rear] = self.inner.measurement_names();
        [r, ay, front, rear, "longitudinal_velocity"]
    }

    fn transition(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SVector<f64, STATE_DIM> {
        let mut next = self.inner.transition_with_rear_drive(
            state,
            &Self::driver(input),
            Self::rear_drive(input),
        );
        if let Some(ax) = Self::ax(input) {
            next[state_index::VX] = self.kinematic_speed(&state.data.0[0], ax);
        }
        next
    }

    fn transition_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        self.transition_and_jacobian(state, input).1
    }

    fn transition_and_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> (SVector<f64, STATE_DIM>, SMatrix<f64, STATE_DIM, STATE_DIM>) {
        let (mut next, mut jacobian) = self.inner.transition_and_jacobian_with_rear_drive(
            state,
            &Self::driver(input),
            Self::rear_drive(input),
        );
        if let Some(ax) = Self::ax(input) {
            next[state_index::VX] = self.kinematic_speed(&state.data.0[0], ax);
            for (j, value) in self.kinematic_row(state).into_iter().enumerate() {
                jacobian[(state_index::VX, j)] = value;
            }
        }
        (next, jacobian)
    }

    /// `∂f/∂u`; the `ax_valid` switch has no derivative (column 0).
    fn transition_input_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, STATE_DIM, ANCHORED_INPUT_DIM> {
        let torques: SMatrix<f64, STATE_DIM, { INPUT_DIM + 1 }> = self
            .inner
            .input_jacobian_with_rear_drive(state, &Self::driver(input), Self::rear_drive(input));
        let mut jacobian = SMatrix::<f64, STATE_DIM, ANCHORED_INPUT_DIM>::zeros();
        jacobian
            .fixed_columns_mut::<{ INPUT_DIM + 1 }>(0)
            .copy_from(&torques);
        if Self::ax(input).is_some() {
            jacobian.row_mut(state_index::VX).fill(0.0);
            jacobian[(state_index::VX, AX_INPUT)] = self.inner.sample_time();
        }
        jacobian
    }

    fn measurement(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SVector<f64, ANCHORED_MEASUREMENT_DIM> {
        let y = self.inner.measurement(state, &Self::driver(input));
        SVector::from([y[0], y[1], y[2], y[3], state[state_index::VX]])
    }

    fn measurement_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, ANCHORED_MEASUREMENT_DIM, STATE_DIM> {
        self.measurement_and_jacobian(state, input).1
    }

    fn measurement_and_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> (
        SVector<f64, ANCHORED_MEASUREMENT_DIM>,
        SMatrix<f64, ANCHORED_MEASUREMENT_DIM, STATE_DIM>,
    ) {
        let (y, h) = self
            .inner
            .measurement_and_jacobian(state, &Self::driver(input));
        let mut jacobian = SMatrix::<f64, ANCHORED_MEASUREMENT_DIM, STATE_DIM>::zeros();
        jacobian.fixed_rows_mut::<MEASUREMENT_DIM>(0).copy_from(&h);
        jacobian[(VX_ROW, state_index::VX)] = 1.0;
        (
            SVector::from([y[0], y[1], y[2], y[3], state[state_index::VX]]),
            jacobian,
        )
    }

    fn measurement_input_jacobian(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, ANCHORED_INPUT_DIM>,
    ) -> SMatrix<f64, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM> {
        let driver = self
            .inner
            .measurement_input_jacobian(state, &Self::driver(input));
        let mut jacobian = SMatrix::<f64, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>::zeros();
        jacobian
            .fixed_view_mut::<MEASUREMENT_DIM, INPUT_DIM>(0, 0)
            .copy_from(&driver);
        jacobian
    }

    fn process_noise(&self) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        self.inner.process_noise()
    }

    fn measurement_noise(
        &self,
    ) -> SMatrix<f64, ANCHORED_MEASUREMENT_DIM, ANCHORED_MEASUREMENT_DIM> {
        let mut noise = SMatrix::<f64, ANCHORED_MEASUREMENT_DIM, ANCHORED_MEASUREMENT_DIM>::zeros();
        noise
            .fixed_view_mut::<MEASUREMENT_DIM, MEASUREMENT_DIM>(0, 0)
            .copy_from(&self.inner.measurement_noise());
        noise[(VX_ROW, VX_ROW)] = self.speed_noise_variance;
        noise
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_oracle::central_difference;

    #[test]
    fn jacobians_match_finite_differences_in_a_braked_turn() {
        let model = SingleTrackEstimationModel::seed_000(0.01).unwrap();
        let x = SVector::<f64, 5>::from([17.0, -0.4, 0.3, 55.5, 56.0]);
        let u = SVector::<f64, 3>::from([0.06, 50.0, 800.0]);
        let checks = [(
            model.transition_jacobian(&x, &u),
            central_difference(|x| model.transition(x, &u), &x),
        )];
        for (analytic, numeric) in checks {
            assert!(
                (analytic - numeric).amax() < 1e-5 * numeric.amax(),
                "{analytic} vs {numeric}"
            );
        }
        let numeric = central_difference(|u| model.transition(&x, u), &u);
        assert!((model.transition_input_jacobian(&x, &u) - numeric).amax() < 1e-5 * numeric.amax());
        let numeric = central_difference(|x| model.measurement(x, &u), &x);
        assert!((model.measurement_jacobian(&x, &u) - numeric).amax() < 1e-5 * numeric.amax());
        let numeric = central_difference(|u| model.measurement(&x, u), &u);
        assert!(
            (model.measurement_input_jacobian(&x, &u) - numeric).amax() < 1e-5 * numeric.amax()
        );
    }

    #[test]
    fn remembered_sine_and_cosine_give_the_plain_f64_results_bit_for_bit() {
        let model = SingleTrackEstimationModel::seed_000(0.01).unwrap();
        let vehicle = model.vehicle();
        let states = [
            SVector::<f64, 5>::from([17.0, -0.4, 0.3, 55.5, 56.0]),
            SVector::<f64, 5>::from([18.0, 0.0, 0.0, 60.0, 60.0]),
            SVector::<f64, 5>::from([9.0, 0.2, -0.5, 31.0, 29.0]),
        ];
        let inputs = [
            SVector::<f64, 3>::from([0.06, 50.0, 800.0]),
            SVector::<f64, 3>::from([0.0, 0.0, 0.0]),
            SVector::<f64, 3>::from([-0.0, 10.0, 0.0]),
            SVector::<f64, 3>::from([-0.11, 0.0, 200.0]),
        ];
        // Every state with every input, twice in a row (a remembered angle) and alternating
        // (a new one each call).
        for u in inputs.iter().chain(inputs.iter().rev()) {
            for x in &states {
                for _ in 0..2 {
                    let plain_next = vehicle.step(x, u, model.sample_time(), model.integrator());
                    assert_eq!(model.transition(x, u), plain_next);
                    assert_eq!(model.measurement(x, u), vehicle.measurement(x, u));
                    let (plain_fx, plain_fu) =
                        vehicle.step_jacobians(x, u, model.sample_time(), model.integrator());
                    assert_eq!(model.transition_jacobian(x, u), plain_fx);
                    assert_eq!(model.transition_input_jacobian(x, u), plain_fu);
                    let (plain_hx, plain_hu) = vehicle.measurement_jacobians(x, u);
                    assert_eq!(model.measurement_jacobian(x, u), plain_hx);
                    assert_eq!(model.measurement_input_jacobian(x, u), plain_hu);
                    // The EKF's one-pass value and Jacobian equal the separate calls.
                    assert_eq!(model.transition_and_jacobian(x, u), (plain_next, plain_fx));
                    assert_eq!(
                        model.measurement_and_jacobian(x, u),
                        (vehicle.measurement(x, u), plain_hx)
                    );
                }
            }
        }
    }

    #[test]
    fn the_anchor_without_measurements_is_model_a_and_its_jacobians_match() {
        let inner = SingleTrackEstimationModel::seed_000(0.01).unwrap();
        let anchored = SpeedAnchoredModel::new(inner.clone(), 0.01).unwrap();
        let x = SVector::<f64, 5>::from([17.0, -0.4, 0.3, 55.5, 56.0]);
        let driver = SVector::<f64, 3>::from([0.06, 50.0, 800.0]);
        let off = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 0.0, None);
        assert_eq!(anchored.transition(&x, &off), inner.transition(&x, &driver));
        let y = anchored.measurement(&x, &off);
        assert_eq!(y.fixed_rows::<4>(0), inner.measurement(&x, &driver));
        assert_eq!(y[VX_ROW], 17.0);
        let on = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 0.0, Some(-2.0));
        // vx(k+1) = vx + T (ax + r vy) = 17 + 0.01 (-2 + 0.3 * -0.4).
        assert_eq!(
            anchored.transition(&x, &on)[0],
            17.0 + 0.01 * (-2.0 + 0.3 * -0.4)
        );
        for u in [off, on] {
            let numeric = central_difference(|x| anchored.transition(x, &u), &x);
            let analytic = anchored.transition_jacobian(&x, &u);
            assert!((analytic - numeric).amax() < 1e-5 * numeric.amax());
            let numeric = central_difference(|x| anchored.measurement(x, &u), &x);
            assert!(
                (anchored.measurement_jacobian(&x, &u) - numeric).amax() < 1e-5 * numeric.amax()
            );
        }
        let numeric = central_difference(|u| anchored.transition(&x, u), &on);
        let analytic = anchored.transition_input_jacobian(&x, &on);
        // The ax_valid switch (last column) has no derivative.
        let difference = (analytic - numeric).columns(0, 5).amax();
        assert!(
            difference < 1e-5 * numeric.amax(),
            "{analytic} vs {numeric}"
        );
    }

    /// A rear drive torque acts on the rear wheels as the front's on the front wheels
    /// (000: 5.45-5.46): over one step from free rolling each driven wheel gains at most
    /// `T dt / I` of spin (less by the semi-implicit tyre damping, 000: 6.1-6.2), the other axle's
    /// wheel nothing, and the Jacobian's rear-torque column is exact.
    #[test]
    fn the_rear_drive_torque_spins_up_the_rear_wheels() {
        let inner = SingleTrackEstimationModel::seed_000(0.001).unwrap();
        let anchored = SpeedAnchoredModel::new(inner.clone(), 0.01).unwrap();
        let chassis = &inner.vehicle().vehicle.chassis;
        // Free rolling at 18 m/s: no tyre force, so the torque alone changes ω.
        let x = inner.vehicle().straight_rolling_state(18.0);
        let torque = 300.0;
        let idle = SVector::<f64, 3>::zeros();
        let rear = SpeedAnchoredModel::<HsriTyre>::extend_input(&idle, torque, None);
        let front = SpeedAnchoredModel::<HsriTyre>::extend_input(
            &SVector::from([0.0, torque, 0.0]),
            0.0,
            None,
        );
        let gain = |next: SVector<f64, 5>, wheel: usize| next[wheel] - x[wheel];
        let rear_next = anchored.transition(&x, &rear);
        let front_next = anchored.transition(&x, &front);
        let undamped_rear = torque * 0.001 / chassis.rear_wheel_inertia;
        let rear_gain = gain(rear_next, state_index::OMEGA_REAR);
        assert!(rear_gain > 0.5 * undamped_rear && rear_gain <= undamped_rear);
        assert_eq!(gain(rear_next, state_index::OMEGA_FRONT), 0.0);
        let undamped_front = torque * 0.001 / chassis.front_wheel_inertia;
        let front_gain = gain(front_next, state_index::OMEGA_FRONT);
        assert!(front_gain > 0.5 * undamped_front && front_gain <= undamped_front);
        assert_eq!(gain(front_next, state_index::OMEGA_REAR), 0.0);
        let u = SpeedAnchoredModel::<HsriTyre>::extend_input(
            &SVector::from([0.03, 40.0, 100.0]),
            250.0,
            None,
        );
        let x = SVector::<f64, 5>::from([17.0, -0.4, 0.3, 55.5, 58.0]);
        let numeric = central_difference(|u| anchored.transition(&x, u), &u);
        let analytic = anchored.transition_input_jacobian(&x, &u);
        let difference = (analytic - numeric).columns(0, 4).amax();
        assert!(
            difference < 1e-5 * numeric.amax(),
            "{analytic} vs {numeric}"
        );
        assert!(analytic[(state_index::OMEGA_REAR, REAR_DRIVE_INPUT)] > 0.0);
    }

    /// The seeds' runs stay bit-identical: every estimator on the anchored model, with the
    /// `vx` row masked out and no `ax`, gives the plain model A's estimate, covariance and NIS.
    #[test]
    fn every_estimator_on_the_unused_anchor_is_bit_identical_to_model_a() {
        use crate::kalman::InitialEstimate;
        use crate::registry::{self, EstimatorChoice};
        let inner = SingleTrackEstimationModel::seed_000(0.01).unwrap();
        let anchored = SpeedAnchoredModel::new(inner.clone(), 0.01).unwrap();
        let (state, input) = seed_operating_point();
        let plain_settings = inner.seed_settings();
        let anchored_settings = anchored.estimator_settings(
            (state, input),
            false,
            SigmaPoints::scaled(0.5, 2.0, 0.0),
            Ok(ParticleFilterConfig::default()),
        );
        let initial = InitialEstimate::diagonal(
            SVector::from([17.5, 0.1, 0.0, 59.0, 59.5]),
            SVector::from([0.5, 0.1, 0.01, 1.0, 1.0]),
        );
        for choice in EstimatorChoice::ALL.iter().copied() {
            let mut plain =
                registry::build(inner.clone(), choice, &plain_settings, &initial).unwrap();
            let mut extended =
                registry::build(anchored.clone(), choice, &anchored_settings, &initial).unwrap();
            for k in 0..50 {
                let steering = 0.002 * k as f64;
                let driver = SVector::<f64, 3>::from([steering, 20.0, 0.0]);
                let y = SVector::<f64, 4>::from([0.02 * k as f64, 0.3 * k as f64, 60.1, 60.0]);
                let [r, ay, front, rear] = y.data.0[0];
                let y5 = SVector::<f64, 5>::from([r, ay, front, rear, f64::NAN]);
                let u5 = SpeedAnchoredModel::<HsriTyre>::extend_input(&driver, 0.0, None);
                let a = plain.update(&y, &driver, &[true; 4]).map(|r| r.nis);
                let b = extended.update(&y5, &u5, &[true; 5]).map(|r| r.nis);
                assert_eq!(a, b, "{choice:?} k = {k}");
                assert_eq!(plain.predict(&driver), extended.predict(&u5));
                assert_eq!(plain.state(), extended.state(), "{choice:?} k = {k}");
                assert_eq!(
                    plain.covariance(),
                    extended.covariance(),
                    "{choice:?} k = {k}"
                );
            }
        }
    }

    #[test]
    fn bad_settings_are_named() {
        let err = SingleTrackEstimationModel::new(
            SingleTrackModel::<HsriTyre>::default(),
            0.0,
            Integrator::SemiImplicitEuler,
            [1.0; 5],
            [1.0; 4],
        )
        .unwrap_err();
        assert!(err.to_string().contains("sample time"));
        let err = SingleTrackEstimationModel::new(
            SingleTrackModel::<HsriTyre>::default(),
            0.01,
            Integrator::SemiImplicitEuler,
            [1.0, 1.0, -1.0, 1.0, 1.0],
            [1.0; 4],
        )
        .unwrap_err();
        assert!(err.to_string().contains("Q diagonal"));
        assert!(crate::registry::EstimatorChoice::from_name("kf")
            .unwrap_err()
            .to_string()
            .contains("unknown estimator"));
    }
}
