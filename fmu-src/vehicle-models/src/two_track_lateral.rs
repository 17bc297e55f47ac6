//! Model B in the 3-state form of the seed-001 estimator (001: eqs 6-11).
//!
//! - State `x = [β, r, ay]`: sideslip (rad), yaw rate (rad/s), lateral acceleration (m/s²)
//!   (001: eq 8); indices in [`state_index`].
//! - Input `u = [steering_angle, vx, ax]`: road-wheel angle (rad), the **measured** longitudinal
//!   speed (m/s), which the seed passes to the estimator (001: §4), and the measured
//!   longitudinal acceleration (m/s², the project's extension; 0 = the seed's model); indices in
//!   [`input_index`].
//! - Measurement `y = [ay, r]` (001: eq 9); indices in [`measurement_index`].
//!
//! Lateral dynamics only, as in the seed: tyre lateral forces from the Magic Formula
//! (001: eq 3) at the slip angles of 001: eqs 4-5 (both wheels of an axle share the axle's slip
//! angle, as there), wheel loads with the roll-moment-distributed lateral load transfer of the
//! full model B ([`crate::two_track::TwoTrackParams::wheel_loads`]), force and moment sums
//! 001: eqs 1-2.
//!
//! **Braking and accelerating** (not in seed 001, whose manoeuvres run at constant speed): the
//! measured `ax` shifts the axle loads by the pitch moment
//! ([`TwoTrackParams::wheel_loads_accelerating`]), as it does on the car. Without it the model
//! meets a braked turn with the loads of a free-rolling car: against the ReferenceVehicle's Ford
//! Escort braking in a turn, model B's EKF sideslip ran to −7.6° against a true −1.5°
//! (`harness robustness`; RMSE 2.63° → 0.52°). The braking force's combined slip (the axles'
//! share of `m ax` as longitudinal slip in the tyre law) was measured too and not kept: the
//! campaigns' sum of sideslip RMSEs 117.9° with it, 118.0° without. With `ax = 0` the model is
//! the seed's bit for bit.
//!
//! Sign conventions (ISO 8855, `β = atan(vy/vx)`): the seed's eq 5 and eq 11 are printed with
//! signs that contradict its own eq 4 under this convention (garbled or a different sideslip
//! sign). Implemented are the kinematically consistent forms
//! `αF = δ − atan(tan β + lF r / vx)` (eq 4), `αR = −atan(tan β − lR r / vx)` (eq 5) and
//! `β̇ = ay / v − r` with `v = vx / cos β` (eq 11).
//!
//! **Why `ay` is a state.** The load transfer depends on `ay` and `ay` on the tyre forces; the
//! seed carries `ay` in the state to avoid solving that loop ("verringert ... den numerischen
//! Aufwand", after eq 11). Discretely: `β` and `r` advance with the step's integrator while the
//! load transfer is held at `ay(k)`; then `ay(k+1) = ΣFy(β(k+1), r(k+1), δ(k); ay(k)) / m`
//! (001: eq 1). The Euler variant is 001: eq 14, the RK4 variant 001: eq 12 solved by
//! Runge-Kutta (003: A.5).

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::integrator::{explicit_euler, runge_kutta4, Integrator};
use crate::scalar::{seed_state_and_input, split_jacobians, Scalar};
use crate::single_track::guarded_speed;
use crate::two_track::{axle_tyre, wheel_index, TwoTrackModel, TwoTrackParams, WHEELS};
use crate::tyre::{MagicFormulaTyre, TyreKinematics, TyreModel};

/// Number of states of the 3-state form.
pub const STATE_DIM: usize = 3;
/// Number of inputs of the 3-state form.
pub const INPUT_DIM: usize = 3;
/// Number of measurements of the 3-state form.
pub const MEASUREMENT_DIM: usize = 2;

/// Positions in the state vector `[β, r, ay]` (001: eq 8).
pub mod state_index {
    /// Sideslip angle `β`, rad.
    pub const SIDESLIP: usize = 0;
    /// Yaw rate `r`, rad/s.
    pub const YAW_RATE: usize = 1;
    /// Lateral acceleration `ay`, m/s².
    pub const LATERAL_ACCELERATION: usize = 2;
}

/// Positions in the input vector `[δ, vx, ax]`.
pub mod input_index {
    /// Road-wheel steering angle, rad (001: eq 10).
    pub const STEERING_ANGLE: usize = 0;
    /// Measured longitudinal speed, m/s.
    pub const LONGITUDINAL_VELOCITY: usize = 1;
    /// Measured longitudinal acceleration, m/s², positive forward (see the module docs).
    pub const LONGITUDINAL_ACCELERATION: usize = 2;
}

/// Positions in the measurement vector `[ay, r]` (001: eq 9).
pub mod measurement_index {
    /// Lateral acceleration, m/s².
    pub const LATERAL_ACCELERATION: usize = 0;
    /// Yaw rate, rad/s.
    pub const YAW_RATE: usize = 1;
}

/// State `[β, r, ay]`.
pub type TwoTrackLateralState = SVector<f64, STATE_DIM>;
/// Input `[δ, vx, ax]`.
pub type TwoTrackLateralInput = SVector<f64, INPUT_DIM>;
/// Measurement `[ay, r]`.
pub type TwoTrackLateralMeasurement = SVector<f64, MEASUREMENT_DIM>;

/// Quantities derived from the 3-state form.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwoTrackLateralOutputs {
    /// Sideslip `β`, rad.
    pub sideslip: f64,
    /// Lateral CoG velocity `vx tan β`, m/s.
    pub lateral_velocity: f64,
    /// Front axle slip angle (001: eq 4), rad.
    pub slip_angle_front: f64,
    /// Rear axle slip angle (001: eq 5), rad.
    pub slip_angle_rear: f64,
}

/// Lateral force sum and yaw moment.
#[derive(Clone, Copy, Debug)]
struct LateralForces<S: Scalar> {
    force_y: S,
    yaw_moment: S,
    /// The lateral force of each tyre, `[FL, FR, RL, RR]`.
    wheels: [S; WHEELS],
}

/// Model B, 3-state form of seed 001, with tyre model `T` (Magic Formula by default).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwoTrackLateralModel<T: TyreModel = MagicFormulaTyre> {
    pub vehicle: TwoTrackParams,
    /// The front tyres, and the rear ones unless `rear_tyre` is given.
    pub tyre: T,
    /// The rear tyres where they differ from the front ones; `None` = `tyre`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rear_tyre: Option<T>,
}

/// The seed-001 estimator model: 3-state two-track with Magic Formula tyres.
pub type TwoTrackLateralMagicFormula = TwoTrackLateralModel<MagicFormulaTyre>;

impl<T: TyreModel> From<&TwoTrackModel<T>> for TwoTrackLateralModel<T> {
    /// The 3-state form of a full model B (same car, same tyres).
    fn from(full: &TwoTrackModel<T>) -> Self {
        Self {
            vehicle: full.vehicle.clone(),
            tyre: full.tyre.clone(),
            rear_tyre: full.rear_tyre.clone(),
        }
    }
}

impl<T: TyreModel> TwoTrackLateralModel<T> {
    /// The same tyre on all four wheels.
    pub fn new(vehicle: TwoTrackParams, tyre: T) -> Self {
        Self::from(&TwoTrackModel::new(vehicle, tyre))
    }

    /// Front and rear axles on their own tyres.
    pub fn with_axle_tyres(vehicle: TwoTrackParams, front: T, rear: T) -> Self {
        Self::from(&TwoTrackModel::with_axle_tyres(vehicle, front, rear))
    }

    /// The lateral force of one tyre of each axle, `(front, rear)`, N, at the axles' slip
    /// angles for `(β, r, δ, vx)` with the loads of `load_acceleration` (001: eqs 3-5): the left
    /// wheels', as the seed's axle force is the sum of left and right (001: eq 1).
    pub fn axle_lateral_forces(
        &self,
        x: &TwoTrackLateralState,
        u: &TwoTrackLateralInput,
        load_acceleration: f64,
    ) -> (f64, f64) {
        let [sideslip, yaw_rate, steer, speed, longitudinal_acceleration] = Self::arguments(x, u);
        let lateral = self
            .lateral_forces(
                sideslip,
                yaw_rate,
                steer,
                speed,
                [load_acceleration, longitudinal_acceleration],
            )
            .wheels;
        (
            lateral[wheel_index::FRONT_LEFT],
            lateral[wheel_index::REAR_LEFT],
        )
    }

    /// `[β, r, δ, vx, ax]` of a state and input.
    fn arguments(x: &TwoTrackLateralState, u: &TwoTrackLateralInput) -> [f64; 5] {
        [
            x[state_index::SIDESLIP],
            x[state_index::YAW_RATE],
            u[input_index::STEERING_ANGLE],
            u[input_index::LONGITUDINAL_VELOCITY],
            u[input_index::LONGITUDINAL_ACCELERATION],
        ]
    }

    /// Tangents of the axle slip angles `(tan αF, tan αR)` (001: eqs 4-5, ISO signs).
    #[inline(always)]
    fn tan_slip_angles<S: Scalar>(&self, sideslip: S, yaw_rate: S, steer: S, speed: S) -> (S, S) {
        let p = &self.vehicle;
        let divisor = guarded_speed(speed, p.low_speed_guard);
        let tan_sideslip = sideslip.sin() / sideslip.cos();
        // (001: eq 4): αF = δ − atan(q), tan(δ − atan q) = (tan δ − q)/(1 + q tan δ)
        let front_direction = tan_sideslip + yaw_rate * p.chassis.cog_to_front_axle / divisor;
        let tan_steer = steer.sin() / steer.cos();
        let tan_front = (tan_steer - front_direction) / (front_direction * tan_steer + 1.0);
        // (001: eq 5)
        let tan_rear = -(tan_sideslip - yaw_rate * p.chassis.cog_to_rear_axle / divisor);
        (tan_front, tan_rear)
    }

    /// `ΣFy` (001: eq 1) and the yaw moment (001: eq 2) with the loads of the accelerations
    /// `[ay, ax]` (`loading`: the held `ay` of the load transfer and the measured `ax`).
    #[inline(always)]
    fn lateral_forces<S: Scalar>(
        &self,
        sideslip: S,
        yaw_rate: S,
        steer: S,
        speed: S,
        loading: [S; 2],
    ) -> LateralForces<S> {
        use wheel_index::*;
        let p = &self.vehicle;
        let [load_acceleration, longitudinal_acceleration] = loading;
        let (tan_front, tan_rear) = self.tan_slip_angles(sideslip, yaw_rate, steer, speed);
        let loads = p.wheel_loads_accelerating(load_acceleration, longitudinal_acceleration);
        let mut lateral = [S::constant(0.0); WHEELS];
        for (wheel, force) in lateral.iter_mut().enumerate() {
            let tan_slip_angle = if TwoTrackParams::is_front(wheel) {
                tan_front
            } else {
                tan_rear
            };
            // (001: eq 3), pure lateral slip, with the axle's tyre and its factors
            *force = axle_tyre(&self.tyre, &self.rear_tyre, wheel)
                .force_scaled(
                    &TyreKinematics {
                        slip: S::constant(0.0),
                        tan_slip_angle,
                        wheel_velocity: speed,
                        vertical_load: loads[wheel],
                    },
                    &p.tyre_scaling(wheel),
                )
                .lateral;
        }
        let (cos_steer, sin_steer) = (steer.cos(), steer.sin());
        let front_sum = lateral[FRONT_LEFT] + lateral[FRONT_RIGHT];
        let rear_sum = lateral[REAR_LEFT] + lateral[REAR_RIGHT];
        let half_track = 0.5 * p.track_width;
        LateralForces {
            // (001: eq 1)
            force_y: rear_sum + front_sum * cos_steer,
            // (001: eq 2)
            yaw_moment: front_sum * cos_steer * p.chassis.cog_to_front_axle
                + (lateral[FRONT_LEFT] - lateral[FRONT_RIGHT]) * sin_steer * half_track
                - rear_sum * p.chassis.cog_to_rear_axle,
            wheels: lateral,
        }
    }

    /// `[β̇, ṙ]` with the load transfer held at `loading` = `[ay, ax]` (001: eqs 2, 11).
    #[inline(always)]
    fn sideslip_and_yaw_rates<S: Scalar>(
        &self,
        sideslip: S,
        yaw_rate: S,
        steer: S,
        speed: S,
        loading: [S; 2],
    ) -> [S; 2] {
        let p = &self.vehicle;
        let forces = self.lateral_forces(sideslip, yaw_rate, steer, speed, loading);
        let lateral_acceleration = forces.force_y / p.chassis.mass;
        let divisor = guarded_speed(speed, p.low_speed_guard);
        // (001: eq 11) β̇ = ay/v − r with v = vx / cos β
        let sideslip_rate = lateral_acceleration * sideslip.cos() / divisor - yaw_rate;
        // (001: eq 2)
        let yaw_acceleration = forces.yaw_moment / p.chassis.yaw_inertia;
        [sideslip_rate, yaw_acceleration]
    }

    /// One discrete step (see module docs), generic over the scalar.
    #[inline(always)]
    pub fn step_generic<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        dt: f64,
        integrator: Integrator,
    ) -> [S; STATE_DIM] {
        use state_index::*;
        let steer = u[input_index::STEERING_ANGLE];
        let speed = u[input_index::LONGITUDINAL_VELOCITY];
        let loading = [
            x[LATERAL_ACCELERATION],
            u[input_index::LONGITUDINAL_ACCELERATION],
        ];
        let rates = |z: &[S; 2]| self.sideslip_and_yaw_rates(z[0], z[1], steer, speed, loading);
        let current = [x[SIDESLIP], x[YAW_RATE]];
        let [sideslip, yaw_rate] = match integrator {
            // (001: eq 14)
            Integrator::SemiImplicitEuler => explicit_euler(&current, dt, &rates(&current)),
            // (001: eq 12) by (003: A.28-A.32)
            Integrator::RungeKutta4 => runge_kutta4(&current, dt, rates),
        };
        // (001: eq 1) at the new state
        let lateral_acceleration = self
            .lateral_forces(sideslip, yaw_rate, steer, speed, loading)
            .force_y
            / self.vehicle.chassis.mass;
        [sideslip, yaw_rate, lateral_acceleration]
    }

    /// One discrete step of length `dt`.
    pub fn step(
        &self,
        x: &TwoTrackLateralState,
        u: &TwoTrackLateralInput,
        dt: f64,
        integrator: Integrator,
    ) -> TwoTrackLateralState {
        TwoTrackLateralState::from(self.step_generic(&x.data.0[0], &u.data.0[0], dt, integrator))
    }

    /// Exact Jacobians `(∂f_d/∂x, ∂f_d/∂u)` of the discrete step (3×3, 3×2).
    pub fn step_jacobians(
        &self,
        x: &TwoTrackLateralState,
        u: &TwoTrackLateralInput,
        dt: f64,
        integrator: Integrator,
    ) -> (
        SMatrix<f64, STATE_DIM, STATE_DIM>,
        SMatrix<f64, STATE_DIM, INPUT_DIM>,
    ) {
        let (xs, us) = seed_state_and_input::<STATE_DIM, INPUT_DIM, { STATE_DIM + INPUT_DIM }>(
            &x.data.0[0],
            &u.data.0[0],
        );
        split_jacobians(&self.step_generic(&xs, &us, dt, integrator))
    }

    /// `y = [ay, r]` (001: eq 9).
    pub fn measurement(
        &self,
        x: &TwoTrackLateralState,
        _u: &TwoTrackLateralInput,
    ) -> TwoTrackLateralMeasurement {
        TwoTrackLateralMeasurement::new(
            x[state_index::LATERAL_ACCELERATION],
            x[state_index::YAW_RATE],
        )
    }

    /// `(∂h/∂x, ∂h/∂u)`: the measurement picks states, so these are constant.
    pub fn measurement_jacobians(
        &self,
    ) -> (
        SMatrix<f64, MEASUREMENT_DIM, STATE_DIM>,
        SMatrix<f64, MEASUREMENT_DIM, INPUT_DIM>,
    ) {
        let mut c = SMatrix::<f64, MEASUREMENT_DIM, STATE_DIM>::zeros();
        c[(
            measurement_index::LATERAL_ACCELERATION,
            state_index::LATERAL_ACCELERATION,
        )] = 1.0;
        c[(measurement_index::YAW_RATE, state_index::YAW_RATE)] = 1.0;
        (c, SMatrix::zeros())
    }

    /// `ΣFy / m` at `(β, r, δ, vx)` with the loads of `load_acceleration` (001: eq 1); exposes the
    /// load-transfer degression.
    pub fn lateral_acceleration_with_loads(
        &self,
        x: &TwoTrackLateralState,
        u: &TwoTrackLateralInput,
        load_acceleration: f64,
    ) -> f64 {
        let [sideslip, yaw_rate, steer, speed, longitudinal_acceleration] = Self::arguments(x, u);
        self.lateral_forces(
            sideslip,
            yaw_rate,
            steer,
            speed,
            [load_acceleration, longitudinal_acceleration],
        )
        .force_y
            / self.vehicle.chassis.mass
    }

    /// Sideslip, lateral velocity and axle slip angles.
    pub fn outputs(
        &self,
        x: &TwoTrackLateralState,
        u: &TwoTrackLateralInput,
    ) -> TwoTrackLateralOutputs {
        let sideslip = x[state_index::SIDESLIP];
        let speed = u[input_index::LONGITUDINAL_VELOCITY];
        let (tan_front, tan_rear) = self.tan_slip_angles(
            sideslip,
            x[state_index::YAW_RATE],
            u[input_index::STEERING_ANGLE],
            speed,
        );
        TwoTrackLateralOutputs {
            sideslip,
            lateral_velocity: speed * sideslip.tan(),
            slip_angle_front: tan_front.atan(),
            slip_angle_rear: tan_rear.atan(),
        }
    }
}
