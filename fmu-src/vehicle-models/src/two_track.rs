//! Model B: two-track model with lateral load transfer and Magic Formula tyres (seed 001,
//! eqs 1-5), as a full reference vehicle driven by the same input as model A.
//!
//! - State `x = [vx, vy, r, ωFL, ωFR, ωRL, ωRR]` (m/s, m/s, rad/s, four wheel speeds in rad/s);
//!   indices in [`state_index`].
//! - Input `u = [steering_angle, drive_torque, brake_torque]`, exactly model A's
//!   ([`crate::driver_input`]): drive torque split equally left/right on the front axle (open
//!   differential), brake torque magnitude split `ν` front / `1 − ν` rear and equally left/right;
//!   the seed's signed `M_B = −brake_torque`.
//! - Truth quantities ([`VehicleTruth`]) as model A's; axle values (wheel speed, slip angle,
//!   slip) are the mean of the left and right wheel.
//!
//! Seed 001 writes the lateral equations only (eqs 1-2: `m ay = ΣFy`, `Jz ψ̈ = ΣM`); the
//! reference vehicle adds the longitudinal balance and the wheel spin equations exactly as model A
//! does (000: 5.43, 5.45-5.46), per wheel. Both front wheels steer by the same angle `δ`.
//!
//! **Load transfer.** Wheel loads are the static loads of model A plus the lateral transfer of
//! the roll moment `m ay h`, shared `ξ` front / `1 − ξ` rear (001: text before eq 1 — "Das
//! Wankmoment ... wird ... zu unterschiedlichen Anteilen über Vorder- und Hinterachse
//! abgestützt"): `ΔFz_axle = share · m ay h / s`, taken from the inner (left, for `ay > 0`) wheel
//! and added to the outer one. Longitudinal load transfer is not modelled (seed 001 has none).
//! Because `ay` depends on the tyre forces, which depend on the loads, the model solves this
//! algebraic loop `ay = g(ay)` with a fixed number of Steffensen rounds (two fixed-point
//! evaluations and a secant extrapolation each) starting from `ay ≈ vx r`; the default
//! `load_transfer_rounds = 2` (5 force evaluations) reaches rounding level (measured: relative
//! mismatch between the `ay` of the loads and the resulting `ay` < 1e-13 on the seed high ramp).
//! A fixed count keeps the step deterministic and allocation-free.
//!
//! **Parameters for the same car as model A** ([`TwoTrackParams::default`]): mass, axle
//! distances, yaw and wheel inertias, brake split, wheel radius and static wheel loads are model
//! A's (000: table 5.1, after table 5.2); the tyres are [`crate::tyre::MagicFormulaTyre`] whose
//! `B·C·D` at every load equals model A's HSRI cornering stiffness (000: 5.70) and whose peak
//! friction equals model A's `f0` (000: 5.67). Seed 001 gives no numbers; the values model A
//! lacks (track width 1.5 m, CoG height 0.55 m, front roll-moment share 0.6) are typical of a
//! 1400 kg compact car and are the project's choice.
//!
//! Low speed is guarded as in model A (`low_speed_guard`).

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::brake::{braked_spin, BrakedSpin};
use crate::driver_input::{index as input_index, DriverInputVector, INPUT_DIM};
use crate::integrator::{explicit_euler, runge_kutta4, semi_implicit_update, Integrator};
use crate::scalar::{Dual, Scalar};
use crate::single_track::{guarded_speed, Chassis};
use crate::truth::VehicleTruth;
use crate::tyre::{AxleTyreScaling, MagicFormulaTyre, TyreKinematics, TyreModel};

/// Number of states of the full model B.
pub const STATE_DIM: usize = 7;
/// Number of wheels.
pub const WHEELS: usize = 4;

/// Positions in model B's state vector.
pub mod state_index {
    /// Longitudinal CoG velocity, m/s.
    pub const VX: usize = 0;
    /// Lateral CoG velocity, m/s.
    pub const VY: usize = 1;
    /// Yaw rate, rad/s.
    pub const YAW_RATE: usize = 2;
    /// Front-left wheel speed, rad/s.
    pub const OMEGA_FRONT_LEFT: usize = 3;
    /// Front-right wheel speed, rad/s.
    pub const OMEGA_FRONT_RIGHT: usize = 4;
    /// Rear-left wheel speed, rad/s.
    pub const OMEGA_REAR_LEFT: usize = 5;
    /// Rear-right wheel speed, rad/s.
    pub const OMEGA_REAR_RIGHT: usize = 6;
}

/// Positions of the wheels in per-wheel arrays.
pub mod wheel_index {
    pub const FRONT_LEFT: usize = 0;
    pub const FRONT_RIGHT: usize = 1;
    pub const REAR_LEFT: usize = 2;
    pub const REAR_RIGHT: usize = 3;
}

/// First wheel speed in the state vector; wheel `i` is at `FIRST_WHEEL_STATE + i`.
const FIRST_WHEEL_STATE: usize = state_index::OMEGA_FRONT_LEFT;

/// Model B's state vector.
pub type TwoTrackState = SVector<f64, STATE_DIM>;

/// Changes of `ay` below this (m/s²) count as converged in the load-transfer loop.
const CONVERGED_ACCELERATION: f64 = 1e-12;

/// Share of a torque that goes to each wheel of an axle (equal left/right split).
const PER_WHEEL_OF_AXLE: f64 = 0.5;

/// Parameters of model B for the same car as model A (see the module documentation): the car
/// ([`Chassis`]) and what only the two-track model has.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TwoTrackParams {
    /// Model A's car (000: table 5.1, table 5.2, after table 5.2).
    pub chassis: Chassis,
    /// Track width `s`, m (001: eq 2; value chosen by the project).
    pub track_width: f64,
    /// CoG height `h`, m (001: text before eq 1; value chosen by the project).
    pub cog_height: f64,
    /// Share `ξ` of the roll moment carried by the front axle (value chosen by the project).
    pub front_roll_moment_share: f64,
    /// Steffensen rounds of the load-transfer loop, 3 fixed-point evaluations each after the
    /// first (see module docs).
    pub load_transfer_rounds: u32,
    /// Smallest longitudinal wheel-centre speed used as divisor in slip and slip angle, m/s.
    pub low_speed_guard: f64,
    /// Factor `λKyα` on the cornering stiffness of the front tyres
    /// ([`crate::tyre::AxleTyreScaling`]), as model A's
    /// [`crate::SingleTrackParams::cornering_stiffness_scale_front`]; 1 = the seed car's tyre.
    pub cornering_stiffness_scale_front: f64,
    /// The same for the rear tyres.
    pub cornering_stiffness_scale_rear: f64,
}

impl Default for TwoTrackParams {
    fn default() -> Self {
        Self {
            chassis: Chassis::default(),
            // the project's choice for what model A does not have
            track_width: 1.5,
            cog_height: 0.55,
            front_roll_moment_share: 0.6,
            load_transfer_rounds: 2,
            low_speed_guard: crate::single_track::DEFAULT_LOW_SPEED_GUARD,
            cornering_stiffness_scale_front: 1.0,
            cornering_stiffness_scale_rear: 1.0,
        }
    }
}

impl TwoTrackParams {
    /// Longitudinal and lateral position of wheel `i` relative to the CoG (x forward, y left).
    #[inline(always)]
    pub fn wheel_position(&self, wheel: usize) -> (f64, f64) {
        let half_track = 0.5 * self.track_width;
        match wheel {
            wheel_index::FRONT_LEFT => (self.chassis.cog_to_front_axle, half_track),
            wheel_index::FRONT_RIGHT => (self.chassis.cog_to_front_axle, -half_track),
            wheel_index::REAR_LEFT => (-self.chassis.cog_to_rear_axle, half_track),
            _ => (-self.chassis.cog_to_rear_axle, -half_track),
        }
    }

    /// Wheel loads `[FL, FR, RL, RR]` with the lateral load transfer of `ay` distributed by the
    /// roll-moment share (001: text before eq 1). A transfer larger than an axle's static wheel
    /// load would make the inner wheel's load negative (a light car at about 10 m/s²): the
    /// inner wheel has lifted, so the transfer is clamped at the static load (inner wheel 0, the
    /// outer carries the axle; [`Self::wheel_lifted`]). Below that the loads are seed 001's.
    #[inline(always)]
    pub fn wheel_loads<S: Scalar>(&self, lateral_acceleration: S) -> [S; WHEELS] {
        self.wheel_loads_accelerating(lateral_acceleration, S::constant(0.0))
    }

    /// Wheel loads as [`Self::wheel_loads`], on axle loads shifted by the longitudinal load
    /// transfer of `longitudinal_acceleration` (m/s², positive forward): the pitch moment
    /// `m ax h` over the wheelbase moves `m ax h / l` from the front axle to the rear one when
    /// accelerating, the other way when braking (Mitschke and Wallentowitz, "Dynamik der
    /// Kraftfahrzeuge", 5th ed., eq. 4.7; not in seed 001, whose manoeuvres run at constant
    /// speed). A transfer larger than an axle's load is clamped (the axle lifts at most to 0).
    /// At `longitudinal_acceleration = 0` this is [`Self::wheel_loads`] bit for bit.
    #[inline(always)]
    pub fn wheel_loads_accelerating<S: Scalar>(
        &self,
        lateral_acceleration: S,
        longitudinal_acceleration: S,
    ) -> [S; WHEELS] {
        let chassis = &self.chassis;
        let wheelbase = chassis.cog_to_front_axle + chassis.cog_to_rear_axle;
        // per wheel: half of the axle's m ax h / l
        let pitch_transfer = clamp_transfer_between(
            longitudinal_acceleration
                * (PER_WHEEL_OF_AXLE * chassis.mass * self.cog_height / wheelbase),
            chassis.rear_wheel_load,
            chassis.front_wheel_load,
        );
        let front_load = -pitch_transfer + chassis.front_wheel_load;
        let rear_load = pitch_transfer + chassis.rear_wheel_load;
        // roll moment m ay h, carried by the axles as ξ and 1 − ξ over the track width
        let transfer_per_share =
            lateral_acceleration * (chassis.mass * self.cog_height / self.track_width);
        let front = clamp_transfer(
            transfer_per_share * self.front_roll_moment_share,
            front_load,
        );
        let rear = clamp_transfer(
            transfer_per_share * (1.0 - self.front_roll_moment_share),
            rear_load,
        );
        // in a left turn (ay > 0) the right (outer) wheels gain load
        [
            -front + front_load,
            front + front_load,
            -rear + rear_load,
            rear + rear_load,
        ]
    }

    /// Whether the lateral load transfer of `ay` lifts an inner wheel (its load clamped at 0 in
    /// [`Self::wheel_loads`]).
    pub fn wheel_lifted(&self, lateral_acceleration: f64) -> bool {
        let transfer_per_share =
            (lateral_acceleration * self.chassis.mass * self.cog_height / self.track_width).abs();
        transfer_per_share * self.front_roll_moment_share > self.chassis.front_wheel_load
            || transfer_per_share * (1.0 - self.front_roll_moment_share)
                > self.chassis.rear_wheel_load
    }

    /// Whether wheel `i` is on the (steered) front axle.
    #[inline(always)]
    pub fn is_front(wheel: usize) -> bool {
        wheel == wheel_index::FRONT_LEFT || wheel == wheel_index::FRONT_RIGHT
    }

    /// The factors on the tyre law of wheel `i`'s axle: the cornering-stiffness scale of this
    /// struct, the friction and reference-load scales of the [`Chassis`].
    #[inline(always)]
    pub fn tyre_scaling(&self, wheel: usize) -> AxleTyreScaling {
        if Self::is_front(wheel) {
            self.chassis
                .tyre_scaling(true, self.cornering_stiffness_scale_front)
        } else {
            self.chassis
                .tyre_scaling(false, self.cornering_stiffness_scale_rear)
        }
    }

    /// Dynamic rolling radius of wheel `i` (its axle's, [`Chassis`]).
    #[inline(always)]
    pub fn wheel_radius(&self, wheel: usize) -> f64 {
        if Self::is_front(wheel) {
            self.chassis.front_wheel_radius
        } else {
            self.chassis.rear_wheel_radius
        }
    }
}

/// The tyre of wheel `i`'s axle: `front` on the front axle, `rear` (else `front`) on the rear.
#[inline(always)]
pub(crate) fn axle_tyre<'a, T>(front: &'a T, rear: &'a Option<T>, wheel: usize) -> &'a T {
    match rear {
        Some(rear) if !TwoTrackParams::is_front(wheel) => rear,
        _ => front,
    }
}

/// An axle's load transfer limited to its static wheel load (the inner wheel lifts at most to
/// zero load). Unchanged, with its derivatives, inside the limit.
#[inline(always)]
fn clamp_transfer<S: Scalar>(transfer: S, axle_wheel_load: S) -> S {
    let limit = axle_wheel_load.value();
    clamp_transfer_between(transfer, limit, limit)
}

/// A load transfer limited to `[-below, above]`, the loads of the wheels it is taken from.
/// Unchanged, with its derivatives, inside the limits.
#[inline(always)]
fn clamp_transfer_between<S: Scalar>(transfer: S, below: f64, above: f64) -> S {
    if transfer.value() > above {
        S::constant(above)
    } else if transfer.value() < -below {
        S::constant(-below)
    } else {
        transfer
    }
}

/// Per-wheel kinematics and forces at one `(x, u)`.
#[derive(Clone, Copy, Debug)]
struct WheelSet<S: Scalar> {
    slip: [S; WHEELS],
    tan_slip_angle: [S; WHEELS],
    /// Tyre force in the wheel frame.
    longitudinal_force: [S; WHEELS],
    lateral_force: [S; WHEELS],
}

/// Forces, moment and lateral acceleration of one evaluation.
#[derive(Clone, Copy, Debug)]
struct Evaluation<S: Scalar> {
    /// The `ay` whose load transfer the forces were computed with.
    load_transfer_acceleration: S,
    /// Wheel loads the forces were computed with.
    loads: [S; WHEELS],
    wheels: WheelSet<S>,
    /// Sum of the wheel forces in the body frame.
    force_x: S,
    force_y: S,
    yaw_moment: S,
    /// `ay = ΣFy / m` consistent with the loads used (000: 5.40 with 001: eq 1).
    lateral_acceleration: S,
}

/// Model B as a full reference vehicle, with tyre model `T` (Magic Formula by default).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwoTrackModel<T: TyreModel = MagicFormulaTyre> {
    pub vehicle: TwoTrackParams,
    /// The front tyres, and the rear ones unless `rear_tyre` is given.
    pub tyre: T,
    /// The rear tyres where they differ from the front ones (a car's front
    /// and rear tyres, e.g. another Magic Formula shape or curvature); `None` = `tyre`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rear_tyre: Option<T>,
}

/// Model B as in seed 001: two-track with Magic Formula tyres.
pub type TwoTrackMagicFormula = TwoTrackModel<MagicFormulaTyre>;

impl<T: TyreModel> TwoTrackModel<T> {
    /// The same tyre on all four wheels.
    pub fn new(vehicle: TwoTrackParams, tyre: T) -> Self {
        Self {
            vehicle,
            tyre,
            rear_tyre: None,
        }
    }

    /// Front and rear axles on their own tyres.
    pub fn with_axle_tyres(vehicle: TwoTrackParams, front: T, rear: T) -> Self {
        Self {
            rear_tyre: Some(rear),
            ..Self::new(vehicle, front)
        }
    }

    /// The tyre of wheel `i`'s axle.
    #[inline(always)]
    pub fn axle_tyre(&self, wheel: usize) -> &T {
        axle_tyre(&self.tyre, &self.rear_tyre, wheel)
    }

    /// Straight driving at `speed` with freely rolling wheels.
    pub fn straight_rolling_state(&self, speed: f64) -> TwoTrackState {
        let front = speed / self.vehicle.chassis.front_wheel_radius;
        let rear = speed / self.vehicle.chassis.rear_wheel_radius;
        TwoTrackState::from([speed, 0.0, 0.0, front, front, rear, rear])
    }

    /// Wheel kinematics and tyre forces for given loads (001: eqs 4-5 generalised to each wheel
    /// like 000: 5.16-5.22).
    #[inline(always)]
    fn wheels<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        cos_steer: S,
        sin_steer: S,
        loads: &[S; WHEELS],
    ) -> WheelSet<S> {
        use state_index::*;
        let p = &self.vehicle;
        let zero = S::constant(0.0);
        let mut set = WheelSet {
            slip: [zero; WHEELS],
            tan_slip_angle: [zero; WHEELS],
            longitudinal_force: [zero; WHEELS],
            lateral_force: [zero; WHEELS],
        };
        for wheel in 0..WHEELS {
            let (position_x, position_y) = p.wheel_position(wheel);
            // wheel-centre velocity in the body frame: v + ω × r
            let body_x = x[VX] - x[YAW_RATE] * position_y;
            let body_y = x[VY] + x[YAW_RATE] * position_x;
            // rotate into the wheel frame (000: 5.16) for the steered front wheels
            let (wheel_velocity, wheel_lateral_velocity) = if TwoTrackParams::is_front(wheel) {
                (
                    body_x * cos_steer + body_y * sin_steer,
                    -(body_x * sin_steer) + body_y * cos_steer,
                )
            } else {
                (body_x, body_y)
            };
            let divisor = guarded_speed(wheel_velocity, p.low_speed_guard);
            // (001: eqs 4-5), (000: 5.17, 5.22)
            let tan_slip_angle = -wheel_lateral_velocity / divisor;
            // (000: 5.65)
            let slip =
                (x[FIRST_WHEEL_STATE + wheel] * p.wheel_radius(wheel) - wheel_velocity) / divisor;
            let force = self.axle_tyre(wheel).force_scaled(
                &TyreKinematics {
                    slip,
                    tan_slip_angle,
                    wheel_velocity,
                    vertical_load: loads[wheel],
                },
                &p.tyre_scaling(wheel),
            );
            set.slip[wheel] = slip;
            set.tan_slip_angle[wheel] = tan_slip_angle;
            set.longitudinal_force[wheel] = force.longitudinal;
            set.lateral_force[wheel] = force.lateral;
        }
        set
    }

    /// Tyre forces, their sums and the resulting `ay` with the wheel loads of a given `ay`.
    #[inline(always)]
    fn evaluate_with_load_transfer<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        cos_steer: S,
        sin_steer: S,
        load_transfer_acceleration: S,
    ) -> Evaluation<S> {
        let p = &self.vehicle;
        let loads = p.wheel_loads(load_transfer_acceleration);
        let wheels = self.wheels(x, cos_steer, sin_steer, &loads);
        let zero = S::constant(0.0);
        let (mut force_x, mut force_y, mut yaw_moment) = (zero, zero, zero);
        for wheel in 0..WHEELS {
            let (position_x, position_y) = p.wheel_position(wheel);
            let (fx, fy) = (
                wheels.longitudinal_force[wheel],
                wheels.lateral_force[wheel],
            );
            // wheel frame -> body frame
            let (body_fx, body_fy) = if TwoTrackParams::is_front(wheel) {
                (
                    fx * cos_steer - fy * sin_steer,
                    fx * sin_steer + fy * cos_steer,
                )
            } else {
                (fx, fy)
            };
            force_x = force_x + body_fx;
            // (001: eq 1) extended by the longitudinal forces like (000: 5.42)
            force_y = force_y + body_fy;
            // (001: eq 2) moment r × F about the CoG
            yaw_moment = yaw_moment + body_fy * position_x - body_fx * position_y;
        }
        Evaluation {
            load_transfer_acceleration,
            loads,
            wheels,
            force_x,
            force_y,
            yaw_moment,
            lateral_acceleration: force_y / p.chassis.mass,
        }
    }

    /// Tyre forces with the load-transfer loop `ay = g(ay)` solved (module docs): Steffensen
    /// rounds (two fixed-point evaluations, then the secant extrapolation to the fixed point),
    /// because plain fixed-point iteration converges only linearly (factor ≈ −0.2 at 7.7 m/s²).
    #[inline(always)]
    fn evaluate<S: Scalar>(&self, x: &[S; STATE_DIM], u: &[S; INPUT_DIM]) -> Evaluation<S> {
        use state_index::*;
        let steer = u[input_index::STEERING_ANGLE];
        let (cos_steer, sin_steer) = (steer.cos(), steer.sin());
        // steady-state estimate ay ≈ vx r starts the iteration
        let mut guess = x[VX] * x[YAW_RATE];
        let mut evaluation = self.evaluate_with_load_transfer(x, cos_steer, sin_steer, guess);
        for _ in 0..self.vehicle.load_transfer_rounds {
            let first = evaluation.lateral_acceleration;
            let second = self
                .evaluate_with_load_transfer(x, cos_steer, sin_steer, first)
                .lateral_acceleration;
            let first_change = first - guess;
            let second_change = second - first;
            let curvature = first_change - second_change;
            guess = if curvature.value().abs() > CONVERGED_ACCELERATION {
                // secant through (guess, first), (first, second): the fixed point of g
                first + second_change * first_change / curvature
            } else {
                second
            };
            evaluation = self.evaluate_with_load_transfer(x, cos_steer, sin_steer, guess);
        }
        evaluation
    }

    /// Drive plus brake torque on wheel `i` with the signed total brake torque `brake` (the seed's
    /// `M_B`; front drive split equally; brake split `ν`).
    #[inline(always)]
    fn wheel_torque<S: Scalar>(&self, wheel: usize, u: &[S; INPUT_DIM], brake: S) -> S {
        let p = &self.vehicle;
        if TwoTrackParams::is_front(wheel) {
            // (000: 5.45) per wheel
            (u[input_index::DRIVE_TORQUE] + brake * p.chassis.brake_split_front) * PER_WHEEL_OF_AXLE
        } else {
            // (000: 5.46) per wheel
            brake * ((1.0 - p.chassis.brake_split_front) * PER_WHEEL_OF_AXLE)
        }
    }

    /// Spin acceleration of wheel `i` at speed `omega` under the tyre force `force`, with the
    /// brake as friction ([`crate::brake`]): the seed's `(T_i − Fx,i r) / I` (000: 5.45-5.46 per
    /// wheel) while the wheel turns, a held wheel where the brake can hold it.
    #[inline(always)]
    fn wheel_spin<S: Scalar>(
        &self,
        wheel: usize,
        u: &[S; INPUT_DIM],
        omega: S,
        force: S,
    ) -> BrakedSpin<S> {
        let p = &self.vehicle;
        let tyre_torque = force * p.wheel_radius(wheel);
        let inertia = self.single_wheel_inertia(wheel);
        let (other, share) = if TwoTrackParams::is_front(wheel) {
            (
                u[input_index::DRIVE_TORQUE] * PER_WHEEL_OF_AXLE - tyre_torque,
                p.chassis.brake_split_front * PER_WHEEL_OF_AXLE,
            )
        } else {
            (
                -tyre_torque,
                (1.0 - p.chassis.brake_split_front) * PER_WHEEL_OF_AXLE,
            )
        };
        braked_spin(
            omega,
            other,
            u[input_index::BRAKE_TORQUE],
            share,
            inertia,
            |brake| (self.wheel_torque(wheel, u, brake) - tyre_torque) / inertia,
        )
    }

    /// Spin inertia of one wheel.
    #[inline(always)]
    fn single_wheel_inertia(&self, wheel: usize) -> f64 {
        let p = &self.vehicle;
        if TwoTrackParams::is_front(wheel) {
            p.chassis.front_wheel_inertia * PER_WHEEL_OF_AXLE
        } else {
            p.chassis.rear_wheel_inertia * PER_WHEEL_OF_AXLE
        }
    }

    /// `[v̇x, v̇y, ṙ]` (000: 5.42-5.44 with the two-track sums of 001: eqs 1-2).
    #[inline(always)]
    fn body_derivatives<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        force_x: S,
        force_y: S,
        yaw_moment: S,
    ) -> [S; 3] {
        use state_index::*;
        let p = &self.vehicle;
        [
            force_x / p.chassis.mass + x[VY] * x[YAW_RATE],
            force_y / p.chassis.mass - x[VX] * x[YAW_RATE],
            yaw_moment / p.chassis.yaw_inertia,
        ]
    }

    /// Continuous-time right-hand side, generic over the scalar.
    #[inline(always)]
    pub fn derivatives_generic<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
    ) -> [S; STATE_DIM] {
        let e = self.evaluate(x, u);
        let body = self.body_derivatives(x, e.force_x, e.force_y, e.yaw_moment);
        let mut derivative = [S::constant(0.0); STATE_DIM];
        derivative[..3].copy_from_slice(&body);
        for wheel in 0..WHEELS {
            derivative[FIRST_WHEEL_STATE + wheel] = self
                .wheel_spin(
                    wheel,
                    u,
                    x[FIRST_WHEEL_STATE + wheel],
                    e.wheels.longitudinal_force[wheel],
                )
                .rate;
        }
        derivative
    }

    /// The seed-000 scheme per wheel (000: 6.1-6.5): explicit Euler for the body, semi-implicit
    /// wheel speeds with `∂ω̇ᵢ/∂ωᵢ` from a 4-direction dual number (one direction per wheel).
    #[inline(always)]
    fn step_seed_scheme<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        dt: f64,
    ) -> [S; STATE_DIM] {
        type W<S> = Dual<S, WHEELS>;
        let lifted: [W<S>; STATE_DIM] = core::array::from_fn(|i| {
            if i >= FIRST_WHEEL_STATE {
                W::<S>::variable(x[i], i - FIRST_WHEEL_STATE)
            } else {
                W::<S>::from_value(x[i])
            }
        });
        // Solve the load-transfer loop in the plain scalar, then evaluate the tyres once more in
        // the dual number at those loads: ∂ω̇ᵢ/∂ωᵢ is the wheel's own partial derivative at the
        // current loads (the seed's damping factor, 000: 6.1-6.2), at a fifth of the cost.
        let plain = self.evaluate(x, u);
        let steer = u[input_index::STEERING_ANGLE];
        let e = self.evaluate_with_load_transfer(
            &lifted,
            W::<S>::from_value(steer.cos()),
            W::<S>::from_value(steer.sin()),
            W::<S>::from_value(plain.load_transfer_acceleration),
        );
        let body = self.body_derivatives(x, plain.force_x, plain.force_y, plain.yaw_moment);
        let body_next = explicit_euler(&[x[0], x[1], x[2]], dt, &body);
        let mut next = [S::constant(0.0); STATE_DIM];
        next[..3].copy_from_slice(&body_next);
        let p = &self.vehicle;
        for wheel in 0..WHEELS {
            let inertia = self.single_wheel_inertia(wheel);
            let force = plain.wheels.longitudinal_force[wheel];
            let force_slope = e.wheels.longitudinal_force[wheel].gradient[wheel];
            // (000: 5.45-5.46) per wheel
            let radius = p.wheel_radius(wheel);
            let spin = self.wheel_spin(wheel, u, x[FIRST_WHEEL_STATE + wheel], force);
            let rate = spin.rate;
            let rate_derivative = spin.rate_derivative(-(force_slope * radius) / inertia);
            // (000: 6.1-6.2)
            next[FIRST_WHEEL_STATE + wheel] =
                semi_implicit_update(x[FIRST_WHEEL_STATE + wheel], rate, rate_derivative, dt);
        }
        next
    }

    /// One discrete step with the chosen integrator, generic over the scalar.
    #[inline(always)]
    pub fn step_generic<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        dt: f64,
        integrator: Integrator,
    ) -> [S; STATE_DIM] {
        match integrator {
            Integrator::SemiImplicitEuler => self.step_seed_scheme(x, u, dt),
            Integrator::RungeKutta4 => runge_kutta4(x, dt, |s| self.derivatives_generic(s, u)),
        }
    }

    /// `ẋ = f(x, u)`.
    pub fn derivatives(&self, x: &TwoTrackState, u: &DriverInputVector) -> TwoTrackState {
        TwoTrackState::from(self.derivatives_generic(&x.data.0[0], &u.data.0[0]))
    }

    /// One discrete step of length `dt` with the same input vector as model A.
    pub fn step(
        &self,
        x: &TwoTrackState,
        u: &DriverInputVector,
        dt: f64,
        integrator: Integrator,
    ) -> TwoTrackState {
        TwoTrackState::from(self.step_generic(&x.data.0[0], &u.data.0[0], dt, integrator))
    }

    /// Wheel loads `[FL, FR, RL, RR]` at `(x, u)`, N.
    pub fn wheel_loads(&self, x: &TwoTrackState, u: &DriverInputVector) -> [f64; WHEELS] {
        self.evaluate::<f64>(&x.data.0[0], &u.data.0[0]).loads
    }

    /// Truth quantities; axle values are the mean of left and right.
    pub fn truth(&self, x: &TwoTrackState, u: &DriverInputVector) -> VehicleTruth {
        use state_index::*;
        use wheel_index::*;
        let xs: &[f64; STATE_DIM] = &x.data.0[0];
        let e = self.evaluate(xs, &u.data.0[0]);
        let [vx_dot, vy_dot, _] = self.body_derivatives(xs, e.force_x, e.force_y, e.yaw_moment);
        let mean = |a: f64, b: f64| 0.5 * (a + b);
        let w = &e.wheels;
        VehicleTruth {
            longitudinal_velocity: xs[VX],
            lateral_velocity: xs[VY],
            yaw_rate: xs[YAW_RATE],
            omega_front: mean(xs[OMEGA_FRONT_LEFT], xs[OMEGA_FRONT_RIGHT]),
            omega_rear: mean(xs[OMEGA_REAR_LEFT], xs[OMEGA_REAR_RIGHT]),
            sideslip: xs[VY].atan2(xs[VX]),
            // (000: 5.40)
            lateral_acceleration: vy_dot + xs[VX] * xs[YAW_RATE],
            // (000: 5.41)
            longitudinal_acceleration: vx_dot - xs[VY] * xs[YAW_RATE],
            slip_angle_front: mean(
                w.tan_slip_angle[FRONT_LEFT].atan(),
                w.tan_slip_angle[FRONT_RIGHT].atan(),
            ),
            slip_angle_rear: mean(
                w.tan_slip_angle[REAR_LEFT].atan(),
                w.tan_slip_angle[REAR_RIGHT].atan(),
            ),
            slip_front: mean(w.slip[FRONT_LEFT], w.slip[FRONT_RIGHT]),
            slip_rear: mean(w.slip[REAR_LEFT], w.slip[REAR_RIGHT]),
        }
    }
}

#[cfg(test)]
mod wheel_load_tests {
    use super::*;

    /// A light car: 700 kg with the seed car's axle distances, static loads from its axle split,
    /// CoG height 0.7 m, track 1.3 m. At 10 m/s² the front transfer m ay h ξ / s = 2262 N
    /// exceeds the front static wheel load of 1745 N: the inner wheel would go negative.
    fn light_car() -> TwoTrackParams {
        let mut chassis = Chassis {
            mass: 700.0,
            ..Chassis::default()
        };
        (chassis.front_wheel_load, chassis.rear_wheel_load) =
            chassis.static_wheel_loads(crate::GRAVITY);
        TwoTrackParams {
            chassis,
            cog_height: 0.7,
            track_width: 1.3,
            ..TwoTrackParams::default()
        }
    }

    #[test]
    fn a_light_car_at_10_m_s2_lifts_its_inner_wheel_instead_of_a_negative_load() {
        let car = light_car();
        for ay in [10.0, -10.0] {
            let loads = car.wheel_loads(ay);
            assert!(loads.iter().all(|&load| load >= 0.0), "{loads:?}");
            // The axles keep their static load: the outer wheel carries what the inner lost.
            assert_eq!(loads[0] + loads[1], 2.0 * car.chassis.front_wheel_load);
            assert!(car.wheel_lifted(ay));
        }
        let unclamped = 10.0 * car.chassis.mass * car.cog_height / car.track_width
            * car.front_roll_moment_share;
        assert!(unclamped > car.chassis.front_wheel_load);
    }

    #[test]
    fn below_the_lift_the_loads_are_seed_001s() {
        let car = TwoTrackParams::default();
        let ay = 5.0;
        let transfer = ay * car.chassis.mass * car.cog_height / car.track_width;
        let front = transfer * car.front_roll_moment_share;
        let loads = car.wheel_loads(ay);
        assert_eq!(loads[0], -front + car.chassis.front_wheel_load);
        assert_eq!(loads[1], front + car.chassis.front_wheel_load);
        assert!(!car.wheel_lifted(ay));
    }
}
