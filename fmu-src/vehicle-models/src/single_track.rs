//! Model A: the 5-state nonlinear single-track model of seed 000 (000: 5.42-5.46, 5.63, 6.1-6.5)
//! with any [`TyreModel`] (HSRI by default, 000: 5.65-5.73).
//!
//! - State `x = [vx, vy, r, ωF, ωR]`: CoG velocities in the body frame (m/s), yaw rate (rad/s),
//!   front and rear wheel angular speeds (rad/s). Indices in [`state_index`].
//! - Input `u = [steering_angle, drive_torque, brake_torque]`, see [`crate::driver_input`]
//!   (brake torque is a magnitude ≥ 0; the seed's `M_B = −brake_torque`); `drive_torque` acts on
//!   the front axle. A rear drive torque (rear- and all-wheel drive) enters through
//!   [`SingleTrackModel::step_with_rear_drive`].
//! - Measurement `y = [r, ay, ωF, ωR]` (000: 5.63), `ay = v̇y + vx r` (000: 5.40): direct
//!   feed-through of the steering angle. Indices in [`measurement_index`].
//! - Axes ISO 8855 (x forward, y left, z up); sideslip `β = atan2(vy, vx)`.
//!
//! The tyre model gives the force of one wheel; axle forces are twice that (000: text before
//! table 5.2). Wheel loads are constant (no load transfer, 000: after table 5.2).
//!
//! **Low speed.** Slip and slip angle divide by the longitudinal wheel-centre velocity
//! (000: 5.17, 5.22, 5.65). Below `low_speed_guard` (default 1 m/s) that divisor is replaced by
//! the guard value, so the equations stay finite at standstill: the tyre forces then act like a
//! damper on the contact-patch velocities, bringing a standing car to rest instead of producing
//! NaN. The seed model is not meant for such speeds; nothing else changes. The brake is friction
//! ([`crate::brake`]): it opposes the rotation and holds a standing wheel, so a car braked to a
//! stop stands (the seed's torque kept acting at standstill and spun the wheels backwards); from
//! speed it is the seed's torque to the bit.
//!
//! Every equation is written once, generic over [`Scalar`]; the Jacobians of the discrete step
//! and of the measurement are obtained by forward-mode automatic differentiation of exactly that
//! code (exact to rounding), including the derivative `∂ω̇/∂ω` inside the semi-implicit step.

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::brake::{braked_spin, BrakedSpin};
use crate::driver_input::{index as input_index, DriverInputVector, INPUT_DIM};
use crate::integrator::{explicit_euler, runge_kutta4, semi_implicit_update, Integrator};
use crate::scalar::{seed_state_and_input, split_jacobians, Scalar};
use crate::truth::VehicleTruth;
use crate::tyre::{AxleTyreScaling, HsriTyre, TyreKinematics, TyreModel};

/// Number of states of model A.
pub const STATE_DIM: usize = 5;
/// Number of measurements of model A.
pub const MEASUREMENT_DIM: usize = 4;

/// Positions in model A's state vector.
pub mod state_index {
    /// Longitudinal CoG velocity `vx`, m/s.
    pub const VX: usize = 0;
    /// Lateral CoG velocity `vy`, m/s.
    pub const VY: usize = 1;
    /// Yaw rate `r`, rad/s.
    pub const YAW_RATE: usize = 2;
    /// Front wheel angular speed `ωF`, rad/s.
    pub const OMEGA_FRONT: usize = 3;
    /// Rear wheel angular speed `ωR`, rad/s.
    pub const OMEGA_REAR: usize = 4;
}

/// Positions in model A's measurement vector (000: 5.63).
pub mod measurement_index {
    /// Yaw rate, rad/s.
    pub const YAW_RATE: usize = 0;
    /// Lateral acceleration, m/s².
    pub const LATERAL_ACCELERATION: usize = 1;
    /// Front wheel angular speed, rad/s.
    pub const OMEGA_FRONT: usize = 2;
    /// Rear wheel angular speed, rad/s.
    pub const OMEGA_REAR: usize = 3;
}

/// Model A's state vector `[vx, vy, r, ωF, ωR]`.
pub type SingleTrackState = SVector<f64, STATE_DIM>;
/// Model A's measurement vector `[r, ay, ωF, ωR]`.
pub type SingleTrackMeasurement = SVector<f64, MEASUREMENT_DIM>;

/// Two wheels per axle: the single-track axle force is twice the force of one tyre
/// (000: text before table 5.2).
pub const WHEELS_PER_AXLE: f64 = 2.0;

/// Model A's state with names.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NamedSingleTrackState {
    pub longitudinal_velocity: f64,
    pub lateral_velocity: f64,
    pub yaw_rate: f64,
    pub omega_front: f64,
    pub omega_rear: f64,
}

impl NamedSingleTrackState {
    pub fn to_vector(&self) -> SingleTrackState {
        SingleTrackState::new(
            self.longitudinal_velocity,
            self.lateral_velocity,
            self.yaw_rate,
            self.omega_front,
            self.omega_rear,
        )
    }

    pub fn from_vector(x: &SingleTrackState) -> Self {
        Self {
            longitudinal_velocity: x[state_index::VX],
            lateral_velocity: x[state_index::VY],
            yaw_rate: x[state_index::YAW_RATE],
            omega_front: x[state_index::OMEGA_FRONT],
            omega_rear: x[state_index::OMEGA_REAR],
        }
    }
}

/// The car both vehicle models describe: seed 000's table 5.1, the tyre radius of table 5.2 and
/// the wheel loads quoted after it. Embedded in [`SingleTrackParams`] and
/// [`crate::TwoTrackParams`], so the seed car's values are written once.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Chassis {
    /// `m`, vehicle mass, kg.
    pub mass: f64,
    /// `lF` (`l1`), CoG to front axle, m.
    pub cog_to_front_axle: f64,
    /// `lR` (`l2`), CoG to rear axle, m.
    pub cog_to_rear_axle: f64,
    /// `Iz`, yaw moment of inertia, kg m².
    pub yaw_inertia: f64,
    /// `IF1`, spin inertia of **both** front wheels, kg m².
    pub front_wheel_inertia: f64,
    /// `IR2`, spin inertia of **both** rear wheels, kg m².
    pub rear_wheel_inertia: f64,
    /// `ν`, share of the brake torque on the front axle.
    pub brake_split_front: f64,
    /// `r`, dynamic rolling radius of the front tyres, m (000: table 5.2 gives one radius for
    /// all wheels; a car may carry other tyres on the rear axle).
    pub front_wheel_radius: f64,
    /// `r`, dynamic rolling radius of the rear tyres, m (000: table 5.2).
    pub rear_wheel_radius: f64,
    /// `FZF`, static vertical load of **one** front wheel, N.
    pub front_wheel_load: f64,
    /// `FZR`, static vertical load of **one** rear wheel, N.
    pub rear_wheel_load: f64,
    /// `iL`, steering ratio (steering-wheel angle / road-wheel angle); the manoeuvres' value.
    pub steering_ratio: f64,
    /// `λμy` of the front tyres: factor on the friction coefficient of the car's tyre law
    /// ([`AxleTyreScaling::friction`]), so a car whose front tyres grip more or less than its
    /// rear ones is described (not a seed parameter). 1 = the seed's tyre.
    pub front_tyre_friction_scale: f64,
    /// `λμy` of the rear tyres (see `front_tyre_friction_scale`).
    pub rear_tyre_friction_scale: f64,
    /// `λFz0` of the front tyres: factor on the tyre law's reference load `FZref`
    /// ([`AxleTyreScaling::reference_load`]), the load sensitivity of the front tyres' friction
    /// and stiffnesses (000: 5.67-5.71). 1 = the seed's tyre.
    pub front_tyre_reference_load_scale: f64,
    /// `λFz0` of the rear tyres (see `front_tyre_reference_load_scale`).
    pub rear_tyre_reference_load_scale: f64,
}

impl Default for Chassis {
    fn default() -> Self {
        // 000: table 5.1; wheel radius from table 5.2; wheel loads from the text after table 5.2.
        Self {
            mass: 1400.0,
            cog_to_front_axle: 1.4346,
            cog_to_rear_axle: 1.4831,
            yaw_inertia: 2978.7,
            front_wheel_inertia: 10.3,
            rear_wheel_inertia: 3.0,
            brake_split_front: 0.6,
            front_wheel_radius: 0.3,
            rear_wheel_radius: 0.3,
            front_wheel_load: 3492.0,
            rear_wheel_load: 3374.0,
            steering_ratio: manoeuvres::STEERING_RATIO,
            // the seed gives one tyre for all wheels (000: table 5.2)
            front_tyre_friction_scale: 1.0,
            rear_tyre_friction_scale: 1.0,
            front_tyre_reference_load_scale: 1.0,
            rear_tyre_reference_load_scale: 1.0,
        }
    }
}

impl Chassis {
    /// The static vertical load of one front and one rear wheel, N, from the mass and the axle
    /// distances on a level road: `m g lR / (2 l)` and `m g lF / (2 l)`.
    pub fn static_wheel_loads(&self, gravity: f64) -> (f64, f64) {
        let per_wheel =
            0.5 * self.mass * gravity / (self.cog_to_front_axle + self.cog_to_rear_axle);
        (
            per_wheel * self.cog_to_rear_axle,
            per_wheel * self.cog_to_front_axle,
        )
    }

    /// The factors on the tyre law of the front (`front`) or rear axle, with the given factor on
    /// the cornering stiffness (the model's own per-axle parameter).
    #[inline(always)]
    pub fn tyre_scaling(&self, front: bool, cornering_stiffness_scale: f64) -> AxleTyreScaling {
        if front {
            AxleTyreScaling {
                cornering_stiffness: cornering_stiffness_scale,
                friction: self.front_tyre_friction_scale,
                reference_load: self.front_tyre_reference_load_scale,
            }
        } else {
            AxleTyreScaling {
                cornering_stiffness: cornering_stiffness_scale,
                friction: self.rear_tyre_friction_scale,
                reference_load: self.rear_tyre_reference_load_scale,
            }
        }
    }
}

/// Model A's parameters: the car ([`Chassis`]) and what only the single-track model has.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SingleTrackParams {
    /// The car (seed 000, table 5.1).
    pub chassis: Chassis,
    /// Smallest longitudinal wheel-centre speed used as divisor in slip and slip angle, m/s
    /// (project's guard against division by zero near standstill, see module docs).
    pub low_speed_guard: f64,
    /// Factor on the cornering stiffness `Cα` (000: 5.70) of the front tyres (1 = the seed's
    /// tyre). Not a seed parameter: it lets model A absorb what its single track with constant
    /// wheel loads misses of a real axle (load transfer, another tyre), e.g. identified from
    /// measured data. At exactly 1 the model is bit-identical to the seed's.
    pub cornering_stiffness_scale_front: f64,
    /// The same for the rear tyres.
    pub cornering_stiffness_scale_rear: f64,
}

impl Default for SingleTrackParams {
    fn default() -> Self {
        Self {
            chassis: Chassis::default(),
            low_speed_guard: DEFAULT_LOW_SPEED_GUARD,
            cornering_stiffness_scale_front: 1.0,
            cornering_stiffness_scale_rear: 1.0,
        }
    }
}

/// Kinematics and force of one axle.
#[derive(Clone, Copy, Debug)]
struct AxleState<S: Scalar> {
    /// Longitudinal velocity of the wheel centre in the wheel frame.
    wheel_velocity: S,
    slip: S,
    tan_slip_angle: S,
    /// Axle force (both wheels), wheel frame.
    longitudinal_force: S,
    lateral_force: S,
    /// `∂F_x/∂ω` of the axle force, for the semi-implicit wheel-speed step (000: 6.1, 6.2);
    /// zero unless asked for.
    longitudinal_force_spin_derivative: S,
}

/// What the estimation crate's grip model estimates of each axle's lateral tyre force,
/// `[front, rear]`, on top of model A's tyre law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LateralTyreStates<S: Scalar> {
    /// Factor on the lateral force; 1 is the user's tyre.
    pub grip: [S; 2],
    /// The tyres' transient slip angles `tan α'`, used by the tyre law in place of the
    /// kinematic ones (the relaxation-length lag, see [`SingleTrackModel::kinematic_slip`]);
    /// `None`: no lag, the kinematic slip angles (000: 5.17, 5.22).
    pub transient_tan_slip_angle: Option<[S; 2]>,
}

impl<S: Scalar> LateralTyreStates<S> {
    /// Grip factors only, no lag.
    pub fn grip(grip: [S; 2]) -> Self {
        Self {
            grip,
            transient_tan_slip_angle: None,
        }
    }
}

/// An axle's kinematic slip angle and the speed its tyre rolls at: what the relaxation-length
/// lag of the tyre's slip angle follows (Pacejka, Tyre and Vehicle Dynamics, 3rd ed., §7.2.1:
/// `σ dα'/dt + |Vcx| α' = |Vcx| α`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxleSlipKinematics<S: Scalar> {
    /// `tan α` from the wheel centre's velocities (000: 5.17, 5.22).
    pub tan_slip_angle: S,
    /// The wheel centre's longitudinal velocity in the wheel frame `Vcx`, m/s.
    pub wheel_velocity: S,
}

/// What one axle's force law takes from the parameters.
#[derive(Clone, Copy, Debug)]
struct AxleConstants {
    /// Static load of one wheel, N.
    wheel_load: f64,
    /// Dynamic rolling radius, m.
    wheel_radius: f64,
    /// Factors on the tyre law: the cornering-stiffness scale of [`SingleTrackParams`], the
    /// friction and reference-load scales of [`Chassis`].
    tyre_scaling: AxleTyreScaling,
}

/// Axle forces (both wheels, wheel frame) and the steering angle they are rotated by.
#[derive(Clone, Copy, Debug)]
struct AxleForces<S: Scalar> {
    front_longitudinal: S,
    front_lateral: S,
    rear_longitudinal: S,
    rear_lateral: S,
    cos_steer: S,
    sin_steer: S,
}

/// All intermediate quantities at one `(x, u)`.
#[derive(Clone, Copy, Debug)]
struct Evaluation<S: Scalar> {
    front: AxleState<S>,
    rear: AxleState<S>,
    cos_steer: S,
    sin_steer: S,
}

impl<S: Scalar> Evaluation<S> {
    #[inline(always)]
    fn axle_forces(&self) -> AxleForces<S> {
        AxleForces {
            front_longitudinal: self.front.longitudinal_force,
            front_lateral: self.front.lateral_force,
            rear_longitudinal: self.rear.longitudinal_force,
            rear_lateral: self.rear.lateral_force,
            cos_steer: self.cos_steer,
            sin_steer: self.sin_steer,
        }
    }
}

/// Everything model A computes at one `(x, u)` besides the state derivative.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SingleTrackOutputs {
    /// `atan2(vy, vx)`, rad.
    pub sideslip: f64,
    /// `ay = v̇y + vx r` (000: 5.40), m/s².
    pub lateral_acceleration: f64,
    /// `ax = v̇x − vy r` (000: 5.41), m/s².
    pub longitudinal_acceleration: f64,
    /// Front slip angle `αF` (000: 5.17), rad.
    pub slip_angle_front: f64,
    /// Rear slip angle `αR` (000: 5.22), rad.
    pub slip_angle_rear: f64,
    /// Front slip `sF` (000: 5.65).
    pub slip_front: f64,
    /// Rear slip `sR` (000: 5.65).
    pub slip_rear: f64,
    /// Front axle longitudinal force `FxF` (wheel frame), N.
    pub longitudinal_force_front: f64,
    /// Front axle lateral force `FyF` (wheel frame), N.
    pub lateral_force_front: f64,
    /// Rear axle longitudinal force `FxR`, N.
    pub longitudinal_force_rear: f64,
    /// Rear axle lateral force `FyR`, N.
    pub lateral_force_rear: f64,
}

/// Model A with tyre model `T`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SingleTrackModel<T: TyreModel = HsriTyre> {
    pub vehicle: SingleTrackParams,
    pub tyre: T,
}

/// Model A as in seed 000: single-track with HSRI tyres.
pub type SingleTrackHsri = SingleTrackModel<HsriTyre>;

/// An axle's kinematic `tan α` from its wheel centre's lateral velocity and the reciprocal of its
/// guarded longitudinal one (000: 5.17, 5.22): one expression for the tyre forces
/// (`SingleTrackModel::axle`) and [`SingleTrackModel::kinematic_slip`], so both give the same
/// bits.
#[inline(always)]
fn kinematic_tan_slip_angle<S: Scalar>(lateral_velocity: S, inverse_divisor: S) -> S {
    -lateral_velocity * inverse_divisor
}

/// The default speed, m/s, below which the slip divisions use the guard instead (see the
/// module docs); the single-track, two-track and rear-axle models share it.
pub const DEFAULT_LOW_SPEED_GUARD: f64 = 1.0;

/// A wheel's longitudinal slip `(ω r − v) / v` (000: 5.65) from the reciprocal of its guarded
/// speed ([`guarded_speed`]), which the axle shares with its slip angle.
#[inline(always)]
pub fn longitudinal_slip<S: Scalar>(
    omega: S,
    wheel_radius: f64,
    wheel_velocity: S,
    inverse_divisor: S,
) -> S {
    (omega * wheel_radius - wheel_velocity) * inverse_divisor
}

/// `v` if `|v|` is at least `guard`, else the constant `guard` (see the module docs).
#[inline(always)]
pub fn guarded_speed<S: Scalar>(speed: S, guard: f64) -> S {
    if speed.value().abs() < guard {
        S::constant(guard)
    } else {
        speed
    }
}

impl<T: TyreModel> SingleTrackModel<T> {
    pub fn new(vehicle: SingleTrackParams, tyre: T) -> Self {
        Self { vehicle, tyre }
    }

    /// Straight driving at `speed` with freely rolling wheels (`ω r = vx` on each axle).
    pub fn straight_rolling_state(&self, speed: f64) -> SingleTrackState {
        let chassis = &self.vehicle.chassis;
        SingleTrackState::new(
            speed,
            0.0,
            0.0,
            speed / chassis.front_wheel_radius,
            speed / chassis.rear_wheel_radius,
        )
    }

    /// Kinematics and force of one axle from the longitudinal and lateral velocity of its wheel
    /// centre in the wheel frame.
    #[inline(always)]
    fn axle<S: Scalar>(
        &self,
        wheel_velocity: S,
        wheel_lateral_velocity: S,
        omega: S,
        axle: AxleConstants,
        transient_tan_slip_angle: Option<S>,
        with_spin_derivative: bool,
    ) -> AxleState<S> {
        let p = &self.vehicle;
        let AxleConstants {
            wheel_load,
            wheel_radius,
            tyre_scaling,
        } = axle;
        let divisor = guarded_speed(wheel_velocity, p.low_speed_guard);
        // Divisions and square roots share one unit of the core and bound a filter's model
        // evaluations: each quotient by the same number is a product with its reciprocal.
        let inverse_divisor = S::constant(1.0) / divisor;
        // the tyre's lagged slip angle where one is given, else the kinematic one
        let tan_slip_angle = transient_tan_slip_angle
            .unwrap_or_else(|| kinematic_tan_slip_angle(wheel_lateral_velocity, inverse_divisor));
        let slip = longitudinal_slip(omega, wheel_radius, wheel_velocity, inverse_divisor);
        let kinematics = TyreKinematics {
            slip,
            tan_slip_angle,
            wheel_velocity,
            vertical_load: S::constant(wheel_load),
        };
        let (force, spin_derivative) = if with_spin_derivative {
            let (force, slip_derivative) = self
                .tyre
                .force_and_slip_derivative(&kinematics, &tyre_scaling);
            // ∂Fx/∂ω = ∂Fx/∂s · ∂s/∂ω with ∂s/∂ω = r / divisor (000: 5.65), both wheels
            let spin_derivative =
                slip_derivative * (wheel_radius * WHEELS_PER_AXLE) * inverse_divisor;
            (force, spin_derivative)
        } else {
            let force = self.tyre.force_scaled(&kinematics, &tyre_scaling);
            (force, S::constant(0.0))
        };
        AxleState {
            wheel_velocity,
            slip,
            tan_slip_angle,
            longitudinal_force: force.longitudinal * WHEELS_PER_AXLE,
            lateral_force: force.lateral * WHEELS_PER_AXLE,
            longitudinal_force_spin_derivative: spin_derivative,
        }
    }

    /// The front wheel centre's longitudinal and lateral velocity in the wheel frame
    /// (000: 5.16).
    #[inline(always)]
    fn front_wheel_velocities<S: Scalar>(
        &self,
        vx: S,
        vy: S,
        yaw_rate: S,
        cos_steer: S,
        sin_steer: S,
    ) -> (S, S) {
        let lateral_at_axle = vy + yaw_rate * self.vehicle.chassis.cog_to_front_axle;
        (
            vx * cos_steer + lateral_at_axle * sin_steer,
            -(vx * sin_steer) + lateral_at_axle * cos_steer,
        )
    }

    /// The rear wheel centre's lateral velocity (000: 5.21); its longitudinal one is `vx`.
    #[inline(always)]
    fn rear_wheel_lateral_velocity<S: Scalar>(&self, vy: S, yaw_rate: S) -> S {
        vy - yaw_rate * self.vehicle.chassis.cog_to_rear_axle
    }

    /// Each axle's kinematic slip angle and wheel-centre speed at `(x, u)`, `[front, rear]`
    /// (000: 5.16, 5.17, 5.21, 5.22), with the low-speed guard of the tyre forces.
    #[inline(always)]
    pub fn kinematic_slip<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
    ) -> [AxleSlipKinematics<S>; 2] {
        use state_index::*;
        let steer = u[input_index::STEERING_ANGLE];
        let guard = self.vehicle.low_speed_guard;
        let (front_velocity, front_lateral) =
            self.front_wheel_velocities(x[VX], x[VY], x[YAW_RATE], steer.cos(), steer.sin());
        let rear_lateral = self.rear_wheel_lateral_velocity(x[VY], x[YAW_RATE]);
        [
            AxleSlipKinematics {
                tan_slip_angle: kinematic_tan_slip_angle(
                    front_lateral,
                    S::constant(1.0) / guarded_speed(front_velocity, guard),
                ),
                wheel_velocity: front_velocity,
            },
            AxleSlipKinematics {
                tan_slip_angle: kinematic_tan_slip_angle(
                    rear_lateral,
                    S::constant(1.0) / guarded_speed(x[VX], guard),
                ),
                wheel_velocity: x[VX],
            },
        ]
    }

    /// Front axle (000: 5.16, 5.17).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn front_axle<S: Scalar>(
        &self,
        vx: S,
        vy: S,
        yaw_rate: S,
        omega: S,
        cos_steer: S,
        sin_steer: S,
        transient_tan_slip_angle: Option<S>,
        with_spin_derivative: bool,
    ) -> AxleState<S> {
        let (wheel_velocity, wheel_lateral_velocity) =
            self.front_wheel_velocities(vx, vy, yaw_rate, cos_steer, sin_steer);
        self.axle(
            wheel_velocity,
            wheel_lateral_velocity,
            omega,
            AxleConstants {
                wheel_load: self.vehicle.chassis.front_wheel_load,
                wheel_radius: self.vehicle.chassis.front_wheel_radius,
                tyre_scaling: self
                    .vehicle
                    .chassis
                    .tyre_scaling(true, self.vehicle.cornering_stiffness_scale_front),
            },
            transient_tan_slip_angle,
            with_spin_derivative,
        )
    }

    /// Rear axle (000: 5.21, 5.22).
    #[inline(always)]
    fn rear_axle<S: Scalar>(
        &self,
        vx: S,
        vy: S,
        yaw_rate: S,
        omega: S,
        transient_tan_slip_angle: Option<S>,
        with_spin_derivative: bool,
    ) -> AxleState<S> {
        let wheel_lateral_velocity = self.rear_wheel_lateral_velocity(vy, yaw_rate);
        self.axle(
            vx,
            wheel_lateral_velocity,
            omega,
            AxleConstants {
                wheel_load: self.vehicle.chassis.rear_wheel_load,
                wheel_radius: self.vehicle.chassis.rear_wheel_radius,
                tyre_scaling: self
                    .vehicle
                    .chassis
                    .tyre_scaling(false, self.vehicle.cornering_stiffness_scale_rear),
            },
            transient_tan_slip_angle,
            with_spin_derivative,
        )
    }

    /// The axles at `(x, u)`; with `lateral = Some(..)` each axle's tyre works at its transient
    /// slip angle where one is given, and its lateral force is multiplied by its grip factor
    /// (states estimated online, see [`Self::step_with_lateral_states`]); `None` is model A as
    /// the seed writes it.
    #[inline(always)]
    fn evaluate<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        with_spin_derivative: bool,
        lateral: Option<LateralTyreStates<S>>,
    ) -> Evaluation<S> {
        use state_index::*;
        let steer = u[input_index::STEERING_ANGLE];
        let (cos_steer, sin_steer) = (steer.cos(), steer.sin());
        let transient = lateral.and_then(|states| states.transient_tan_slip_angle);
        let mut e = Evaluation {
            front: self.front_axle(
                x[VX],
                x[VY],
                x[YAW_RATE],
                x[OMEGA_FRONT],
                cos_steer,
                sin_steer,
                transient.map(|[front, _]| front),
                with_spin_derivative,
            ),
            rear: self.rear_axle(
                x[VX],
                x[VY],
                x[YAW_RATE],
                x[OMEGA_REAR],
                transient.map(|[_, rear]| rear),
                with_spin_derivative,
            ),
            cos_steer,
            sin_steer,
        };
        if let Some(LateralTyreStates {
            grip: [front, rear],
            ..
        }) = lateral
        {
            e.front.lateral_force = e.front.lateral_force * front;
            e.rear.lateral_force = e.rear.lateral_force * rear;
        }
        e
    }

    /// `[v̇x, v̇y, ṙ]` from the axle forces (000: 5.43, 5.42, 5.44).
    #[inline(always)]
    fn body_derivatives<S: Scalar>(&self, x: &[S; STATE_DIM], forces: &AxleForces<S>) -> [S; 3] {
        use state_index::*;
        let p = &self.vehicle;
        let AxleForces {
            front_longitudinal,
            front_lateral,
            rear_longitudinal,
            rear_lateral,
            cos_steer,
            sin_steer,
        } = *forces;
        let (vx, vy, yaw_rate) = (x[VX], x[VY], x[YAW_RATE]);
        // Products with f64 reciprocals: one division each, also for dual numbers (which would
        // divide every component).
        let inverse_mass = 1.0 / p.chassis.mass;
        // (000: 5.43)
        let vx_dot = (rear_longitudinal - front_lateral * sin_steer
            + front_longitudinal * cos_steer)
            * inverse_mass
            + vy * yaw_rate;
        // (000: 5.42)
        let vy_dot = (rear_lateral + front_lateral * cos_steer + front_longitudinal * sin_steer)
            * inverse_mass
            - vx * yaw_rate;
        // (000: 5.44)
        let yaw_acceleration = (-(rear_lateral * p.chassis.cog_to_rear_axle)
            + (front_lateral * cos_steer + front_longitudinal * sin_steer)
                * p.chassis.cog_to_front_axle)
            * (1.0 / p.chassis.yaw_inertia);
        [vx_dot, vy_dot, yaw_acceleration]
    }

    /// Front wheel spin acceleration `ω̇F` (000: 5.45) with `M_B = −brake_torque` and the brake
    /// as friction ([`crate::brake`]): it holds a standing wheel instead of turning it backwards.
    #[inline(always)]
    fn front_spin_acceleration<S: Scalar>(
        &self,
        u: &[S; INPUT_DIM],
        omega: S,
        longitudinal_force: S,
    ) -> BrakedSpin<S> {
        let p = &self.vehicle;
        let drive = u[input_index::DRIVE_TORQUE];
        let tyre_torque = longitudinal_force * p.chassis.front_wheel_radius;
        braked_spin(
            omega,
            drive - tyre_torque,
            u[input_index::BRAKE_TORQUE],
            p.chassis.brake_split_front,
            p.chassis.front_wheel_inertia,
            // (000: 5.45)
            |brake| {
                (drive + brake * p.chassis.brake_split_front - tyre_torque)
                    * (1.0 / p.chassis.front_wheel_inertia)
            },
        )
    }

    /// Rear wheel spin acceleration `ω̇R` (000: 5.46) with `M_B = −brake_torque`, the brake as
    /// friction as at the front. Seed 000's car is front-driven: its rear wheels carry no drive
    /// torque (`rear_drive_torque = None`, the seed's expression to the bit). A rear drive torque
    /// `M_AR` enters as `M_A` does at the front (000: 5.45): `IR ω̇R = M_AR + (1 − ν) M_B − FxR r_R`.
    #[inline(always)]
    fn rear_spin_acceleration<S: Scalar>(
        &self,
        u: &[S; INPUT_DIM],
        omega: S,
        rear_drive_torque: Option<S>,
        longitudinal_force: S,
    ) -> BrakedSpin<S> {
        let p = &self.vehicle;
        let tyre_torque = longitudinal_force * p.chassis.rear_wheel_radius;
        let rear_share = 1.0 - p.chassis.brake_split_front;
        let other = match rear_drive_torque {
            Some(drive) => drive - tyre_torque,
            None => -tyre_torque,
        };
        braked_spin(
            omega,
            other,
            u[input_index::BRAKE_TORQUE],
            rear_share,
            p.chassis.rear_wheel_inertia,
            |brake| {
                let brake_rear = brake * rear_share;
                let wheel_torque = match rear_drive_torque {
                    Some(drive) => drive + brake_rear,
                    None => brake_rear,
                };
                // (000: 5.46)
                (wheel_torque - tyre_torque) * (1.0 / p.chassis.rear_wheel_inertia)
            },
        )
    }

    /// Continuous-time right-hand side `ẋ = f(x, u)` (000: 5.42-5.46), generic over the scalar.
    #[inline(always)]
    pub fn derivatives_generic<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
    ) -> [S; STATE_DIM] {
        self.derivatives_with_rear_drive(x, u, None, None)
    }

    /// [`Self::derivatives_generic`] with a drive torque on the rear axle too (rear- and
    /// all-wheel drive cars; see [`Self::rear_spin_acceleration`]).
    #[inline(always)]
    fn derivatives_with_rear_drive<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        rear_drive_torque: Option<S>,
        lateral: Option<LateralTyreStates<S>>,
    ) -> [S; STATE_DIM] {
        let e = self.evaluate(x, u, false, lateral);
        let [vx_dot, vy_dot, yaw_acceleration] = self.body_derivatives(x, &e.axle_forces());
        [
            vx_dot,
            vy_dot,
            yaw_acceleration,
            self.front_spin_acceleration(
                u,
                x[state_index::OMEGA_FRONT],
                e.front.longitudinal_force,
            )
            .rate,
            self.rear_spin_acceleration(
                u,
                x[state_index::OMEGA_REAR],
                rear_drive_torque,
                e.rear.longitudinal_force,
            )
            .rate,
        ]
    }

    /// The seed-000 discrete step (000: 6.1-6.5): explicit Euler for `vx, vy, r`, semi-implicit
    /// Euler for `ωF, ωR` with the exact `∂ω̇/∂ω` (from the tyre's `∂Fx/∂s`,
    /// [`TyreModel::force_and_slip_derivative`]; each axle's force depends on its own wheel speed
    /// only).
    #[inline(always)]
    fn step_seed_scheme<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        rear_drive_torque: Option<S>,
        lateral: Option<LateralTyreStates<S>>,
        dt: f64,
    ) -> [S; STATE_DIM] {
        use state_index::*;
        let e = self.evaluate(x, u, true, lateral);
        let (front, rear) = (e.front, e.rear);
        let [vx_dot, vy_dot, yaw_acceleration] = self.body_derivatives(x, &e.axle_forces());
        let p = &self.vehicle;
        let front_spin = self.front_spin_acceleration(u, x[OMEGA_FRONT], front.longitudinal_force);
        let rear_spin = self.rear_spin_acceleration(
            u,
            x[OMEGA_REAR],
            rear_drive_torque,
            rear.longitudinal_force,
        );
        // ∂ω̇/∂ω = −r_w/I · ∂Fx/∂ω, from (000: 5.45), (000: 5.46); −1/τ where the brake holds
        let front_spin_derivative = front_spin.rate_derivative(
            -(front.longitudinal_force_spin_derivative * p.chassis.front_wheel_radius)
                * (1.0 / p.chassis.front_wheel_inertia),
        );
        let rear_spin_derivative = rear_spin.rate_derivative(
            -(rear.longitudinal_force_spin_derivative * p.chassis.rear_wheel_radius)
                * (1.0 / p.chassis.rear_wheel_inertia),
        );
        let (front_spin, rear_spin) = (front_spin.rate, rear_spin.rate);
        // (000: 6.3), (000: 6.4), (000: 6.5)
        let body = explicit_euler(
            &[x[VX], x[VY], x[YAW_RATE]],
            dt,
            &[vx_dot, vy_dot, yaw_acceleration],
        );
        [
            body[0],
            body[1],
            body[2],
            // (000: 6.1)
            semi_implicit_update(x[OMEGA_FRONT], front_spin, front_spin_derivative, dt),
            // (000: 6.2)
            semi_implicit_update(x[OMEGA_REAR], rear_spin, rear_spin_derivative, dt),
        ]
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
        self.step_with_rear_drive(x, u, None, dt, integrator)
    }

    /// [`Self::step_generic`] with a drive torque `rear_drive_torque` (N·m, both rear wheels
    /// together) on the rear axle: the estimator's model A for rear- and all-wheel drive cars
    /// `None` is seed 000's front-driven car to the bit.
    #[inline(always)]
    pub fn step_with_rear_drive<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        rear_drive_torque: Option<S>,
        dt: f64,
        integrator: Integrator,
    ) -> [S; STATE_DIM] {
        self.step_with_lateral_states(x, u, rear_drive_torque, None, dt, integrator)
    }

    /// [`Self::step_with_rear_drive`] with each axle's tyre at its transient slip angle and its
    /// lateral force multiplied by its grip factor (`lateral`, [`LateralTyreStates`]: states of
    /// the estimation crate's grip model), the same equations and
    /// integrators; both are held over the step. `None` is [`Self::step_with_rear_drive`];
    /// factors of exactly 1 and the kinematic slip angles give the same numbers.
    #[inline(always)]
    pub fn step_with_lateral_states<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        rear_drive_torque: Option<S>,
        lateral: Option<LateralTyreStates<S>>,
        dt: f64,
        integrator: Integrator,
    ) -> [S; STATE_DIM] {
        match integrator {
            Integrator::SemiImplicitEuler => {
                self.step_seed_scheme(x, u, rear_drive_torque, lateral, dt)
            }
            Integrator::RungeKutta4 => runge_kutta4(x, dt, |state| {
                self.derivatives_with_rear_drive(state, u, rear_drive_torque, lateral)
            }),
        }
    }

    /// Measurement `y = [r, ay, ωF, ωR]` (000: 5.63), generic over the scalar.
    #[inline(always)]
    pub fn measurement_generic<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
    ) -> [S; MEASUREMENT_DIM] {
        self.measurement_with_lateral_states(x, u, None)
    }

    /// [`Self::measurement_generic`] with per-axle factors on the lateral tyre forces (see
    /// [`Self::step_with_lateral_states`]).
    #[inline(always)]
    pub fn measurement_with_lateral_states<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        lateral: Option<LateralTyreStates<S>>,
    ) -> [S; MEASUREMENT_DIM] {
        use state_index::*;
        let e = self.evaluate(x, u, false, lateral);
        // (000: 5.40) with (000: 5.42): ay = v̇y + vx r = (FyR + FyF cos δ + FxF sin δ) / m
        let lateral_acceleration = (e.rear.lateral_force
            + e.front.lateral_force * e.cos_steer
            + e.front.longitudinal_force * e.sin_steer)
            * (1.0 / self.vehicle.chassis.mass);
        [
            x[YAW_RATE],
            lateral_acceleration,
            x[OMEGA_FRONT],
            x[OMEGA_REAR],
        ]
    }

    /// Continuous-time state derivative `ẋ = f(x, u)` (000: 5.42-5.46).
    pub fn derivatives(&self, x: &SingleTrackState, u: &DriverInputVector) -> SingleTrackState {
        SingleTrackState::from(self.derivatives_generic(&x.data.0[0], &u.data.0[0]))
    }

    /// One discrete step `x(k+1) = f_d(x(k), u(k))` of length `dt`.
    pub fn step(
        &self,
        x: &SingleTrackState,
        u: &DriverInputVector,
        dt: f64,
        integrator: Integrator,
    ) -> SingleTrackState {
        SingleTrackState::from(self.step_generic(&x.data.0[0], &u.data.0[0], dt, integrator))
    }

    /// Exact Jacobians `(∂f_d/∂x, ∂f_d/∂u)` of the discrete step (5×5, 5×3).
    pub fn step_jacobians(
        &self,
        x: &SingleTrackState,
        u: &DriverInputVector,
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

    /// Measurement `y = h(x, u)` (000: 5.63).
    pub fn measurement(
        &self,
        x: &SingleTrackState,
        u: &DriverInputVector,
    ) -> SingleTrackMeasurement {
        SingleTrackMeasurement::from(self.measurement_generic(&x.data.0[0], &u.data.0[0]))
    }

    /// Exact Jacobians `(∂h/∂x, ∂h/∂u)` of the measurement (4×5, 4×3).
    pub fn measurement_jacobians(
        &self,
        x: &SingleTrackState,
        u: &DriverInputVector,
    ) -> (
        SMatrix<f64, MEASUREMENT_DIM, STATE_DIM>,
        SMatrix<f64, MEASUREMENT_DIM, INPUT_DIM>,
    ) {
        let (xs, us) = seed_state_and_input::<STATE_DIM, INPUT_DIM, { STATE_DIM + INPUT_DIM }>(
            &x.data.0[0],
            &u.data.0[0],
        );
        split_jacobians(&self.measurement_generic(&xs, &us))
    }

    /// Derived quantities at `(x, u)`: sideslip, accelerations, slip angles, slips, axle forces.
    pub fn outputs(&self, x: &SingleTrackState, u: &DriverInputVector) -> SingleTrackOutputs {
        self.outputs_with_lateral_states(x, u, None)
    }

    /// [`Self::outputs`] with per-axle factors on the lateral tyre forces (see
    /// [`Self::step_with_lateral_states`]).
    pub fn outputs_with_lateral_states(
        &self,
        x: &SingleTrackState,
        u: &DriverInputVector,
        lateral: Option<LateralTyreStates<f64>>,
    ) -> SingleTrackOutputs {
        use state_index::*;
        let xs: &[f64; STATE_DIM] = &x.data.0[0];
        let us: &[f64; INPUT_DIM] = &u.data.0[0];
        let e = self.evaluate(xs, us, false, lateral);
        let [vx_dot, vy_dot, _] = self.body_derivatives(xs, &e.axle_forces());
        let (vx, vy, yaw_rate) = (xs[VX], xs[VY], xs[YAW_RATE]);
        SingleTrackOutputs {
            sideslip: vy.atan2(vx),
            // (000: 5.40)
            lateral_acceleration: vy_dot + vx * yaw_rate,
            // (000: 5.41)
            longitudinal_acceleration: vx_dot - vy * yaw_rate,
            slip_angle_front: e.front.tan_slip_angle.atan(),
            slip_angle_rear: e.rear.tan_slip_angle.atan(),
            slip_front: e.front.slip,
            slip_rear: e.rear.slip,
            longitudinal_force_front: e.front.longitudinal_force,
            lateral_force_front: e.front.lateral_force,
            longitudinal_force_rear: e.rear.longitudinal_force,
            lateral_force_rear: e.rear.lateral_force,
        }
    }

    /// The reference-vehicle truth quantities at `(x, u)`.
    pub fn truth(&self, x: &SingleTrackState, u: &DriverInputVector) -> VehicleTruth {
        use state_index::*;
        let o = self.outputs(x, u);
        VehicleTruth {
            longitudinal_velocity: x[VX],
            lateral_velocity: x[VY],
            yaw_rate: x[YAW_RATE],
            omega_front: x[OMEGA_FRONT],
            omega_rear: x[OMEGA_REAR],
            sideslip: o.sideslip,
            lateral_acceleration: o.lateral_acceleration,
            longitudinal_acceleration: o.longitudinal_acceleration,
            slip_angle_front: o.slip_angle_front,
            slip_angle_rear: o.slip_angle_rear,
            slip_front: o.slip_front,
            slip_rear: o.slip_rear,
        }
    }

    /// Longitudinal velocity of the front wheel centre (000: 5.16); exposed for tests.
    pub fn front_wheel_velocity(&self, x: &SingleTrackState, u: &DriverInputVector) -> f64 {
        let e = self.evaluate::<f64>(&x.data.0[0], &u.data.0[0], false, None);
        e.front.wheel_velocity
    }

    /// The linearisation of the discrete model about `(x0, u0)` (000: 5.58-5.62 take it about
    /// straight driving, see [`SingleTrackModel::seed_operating_point`]), with the exact
    /// Jacobians.
    pub fn linearise(
        &self,
        state: &SingleTrackState,
        input: &DriverInputVector,
        dt: f64,
        integrator: Integrator,
    ) -> SingleTrackLinearisation {
        let (transition, input_matrix) = self.step_jacobians(state, input, dt, integrator);
        let (output, feedthrough) = self.measurement_jacobians(state, input);
        SingleTrackLinearisation {
            state: *state,
            input: *input,
            next_state: self.step(state, input, dt, integrator),
            measurement: self.measurement(state, input),
            transition,
            input_matrix,
            output,
            feedthrough,
        }
    }

    /// The LKF operating point of seed 000: straight driving at `vx0 = 18 m/s`, `vy0 = 0`,
    /// `r0 = 0`, `ωF0 = ωR0 = 60 rad/s`, no steering, drive or brake torque (000: ch. 7 intro).
    pub fn seed_operating_point() -> (SingleTrackState, DriverInputVector) {
        (
            SingleTrackState::new(
                crate::manoeuvre::SEED_INITIAL_SPEED,
                0.0,
                0.0,
                crate::manoeuvre::SEED_INITIAL_WHEEL_SPEED,
                crate::manoeuvre::SEED_INITIAL_WHEEL_SPEED,
            ),
            DriverInputVector::zeros(),
        )
    }
}

/// Model A linearised about `(x0, u0)`:
/// `x(k+1) ≈ f(x0, u0) + A (x − x0) + B (u − u0)`, `y ≈ h(x0, u0) + C (x − x0) + D (u − u0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SingleTrackLinearisation {
    /// Operating state `x0`.
    pub state: SingleTrackState,
    /// Operating input `u0`.
    pub input: DriverInputVector,
    /// `f(x0, u0)`.
    pub next_state: SingleTrackState,
    /// `h(x0, u0)`.
    pub measurement: SingleTrackMeasurement,
    /// `A = ∂f/∂x`.
    pub transition: SMatrix<f64, STATE_DIM, STATE_DIM>,
    /// `B = ∂f/∂u`.
    pub input_matrix: SMatrix<f64, STATE_DIM, INPUT_DIM>,
    /// `C = ∂h/∂x`.
    pub output: SMatrix<f64, MEASUREMENT_DIM, STATE_DIM>,
    /// `D = ∂h/∂u`.
    pub feedthrough: SMatrix<f64, MEASUREMENT_DIM, INPUT_DIM>,
}

impl SingleTrackLinearisation {
    /// The linear one-step prediction.
    pub fn step(&self, x: &SingleTrackState, u: &DriverInputVector) -> SingleTrackState {
        self.next_state + self.transition * (x - self.state) + self.input_matrix * (u - self.input)
    }

    /// The linear measurement.
    pub fn measurement(
        &self,
        x: &SingleTrackState,
        u: &DriverInputVector,
    ) -> SingleTrackMeasurement {
        self.measurement + self.output * (x - self.state) + self.feedthrough * (u - self.input)
    }
}

#[cfg(test)]
mod cornering_stiffness_scale_tests {
    use super::*;

    fn cornering_state() -> (SingleTrackState, DriverInputVector) {
        // 18 m/s with some sideslip and yaw, 1.5° steer: both axles in the linear tyre range.
        (
            SingleTrackState::new(18.0, 0.3, 0.2, 60.2, 60.0),
            DriverInputVector::new(0.026, 0.0, 0.0),
        )
    }

    fn with_scales(front: f64, rear: f64) -> SingleTrackHsri {
        SingleTrackModel::new(
            SingleTrackParams {
                cornering_stiffness_scale_front: front,
                cornering_stiffness_scale_rear: rear,
                ..SingleTrackParams::default()
            },
            HsriTyre::default(),
        )
    }

    /// Scale 1 is the seed's model: the axle forces are exactly twice the unscaled tyre force.
    #[test]
    fn unit_scales_give_the_unscaled_tyre_forces_bit_for_bit() {
        let model = SingleTrackHsri::default();
        let (x, u) = cornering_state();
        let e = model.evaluate::<f64>(&x.data.0[0], &u.data.0[0], false, None);
        let kinematics = TyreKinematics {
            slip: e.rear.slip,
            tan_slip_angle: e.rear.tan_slip_angle,
            wheel_velocity: e.rear.wheel_velocity,
            vertical_load: model.vehicle.chassis.rear_wheel_load,
        };
        let force = model.tyre.force(&kinematics);
        assert_eq!(
            e.rear.lateral_force.to_bits(),
            (force.lateral * WHEELS_PER_AXLE).to_bits()
        );
        assert_eq!(
            e.rear.longitudinal_force.to_bits(),
            (force.longitudinal * WHEELS_PER_AXLE).to_bits()
        );
    }

    /// In the linear range the lateral axle force is `2 s Cα tan α` (000: 5.70 times the scale):
    /// each scale acts on its own axle only, the longitudinal forces do not change.
    #[test]
    fn each_scale_multiplies_its_axles_cornering_stiffness() {
        let (x, u) = cornering_state();
        let seed = with_scales(1.0, 1.0).outputs(&x, &u);
        let front = with_scales(0.8, 1.0).outputs(&x, &u);
        let rear = with_scales(1.0, 1.25).outputs(&x, &u);
        let relative = |a: f64, b: f64| (a / b - 1.0).abs();
        // Adhesion branch: Fy = Cα tan α / (1 + s), linear in Cα up to the slip's rounding.
        assert!(relative(front.lateral_force_front, 0.8 * seed.lateral_force_front) < 1e-12);
        assert_eq!(front.lateral_force_rear, seed.lateral_force_rear);
        assert!(relative(rear.lateral_force_rear, 1.25 * seed.lateral_force_rear) < 1e-12);
        assert_eq!(rear.lateral_force_front, seed.lateral_force_front);
        assert_eq!(
            front.longitudinal_force_front,
            seed.longitudinal_force_front
        );
        // The force law is HSRI's: 2 Cα tan α / (1 + s) with the scaled Cα.
        let hsri = HsriTyre::default();
        let expected = WHEELS_PER_AXLE
            * 0.8
            * hsri.cornering_stiffness(SingleTrackParams::default().chassis.front_wheel_load)
            * front.slip_angle_front.tan()
            / (1.0 + front.slip_front);
        assert!(relative(front.lateral_force_front, expected) < 1e-12);
    }

    /// Lateral-force factors of exactly 1 are model A to the bit, with both integrators, in
    /// the step, the measurement and the outputs, also with the kinematic slip angles given as
    /// transient ones; a factor acts on its axle's lateral force only.
    #[test]
    fn unit_lateral_factors_are_model_a_bit_for_bit() {
        let model = with_scales(0.9, 1.1);
        let (x, u) = cornering_state();
        let (xs, us) = (&x.data.0[0], &u.data.0[0]);
        let unit_grip = LateralTyreStates::grip([1.0, 1.0]);
        let kinematic = model.kinematic_slip(xs, us).map(|axle| axle.tan_slip_angle);
        let unlagged = LateralTyreStates {
            transient_tan_slip_angle: Some(kinematic),
            ..unit_grip
        };
        for integrator in [Integrator::SemiImplicitEuler, Integrator::RungeKutta4] {
            for rear in [None, Some(120.0)] {
                let plain = model.step_with_rear_drive(xs, us, rear, 0.01, integrator);
                let unit =
                    model.step_with_lateral_states(xs, us, rear, Some(unit_grip), 0.01, integrator);
                assert_eq!(plain.map(f64::to_bits), unit.map(f64::to_bits));
                // Euler evaluates the forces at x only, where the slip angles are the kinematic
                // ones; Runge-Kutta's inner stages hold them, so only Euler is the same to the bit.
                if integrator == Integrator::SemiImplicitEuler {
                    let same = model.step_with_lateral_states(
                        xs,
                        us,
                        rear,
                        Some(unlagged),
                        0.01,
                        integrator,
                    );
                    assert_eq!(plain.map(f64::to_bits), same.map(f64::to_bits));
                }
            }
        }
        let same = model.measurement_with_lateral_states(xs, us, Some(unlagged));
        assert_eq!(
            model.measurement_generic(xs, us).map(f64::to_bits),
            same.map(f64::to_bits)
        );
        let unit = model.measurement_with_lateral_states(xs, us, Some(unit_grip));
        assert_eq!(
            model.measurement_generic(xs, us).map(f64::to_bits),
            unit.map(f64::to_bits)
        );
        let plain = model.outputs(&x, &u);
        assert_eq!(
            plain,
            model.outputs_with_lateral_states(&x, &u, Some(unit_grip))
        );
        let gripped =
            model.outputs_with_lateral_states(&x, &u, Some(LateralTyreStates::grip([0.8, 1.3])));
        assert_eq!(gripped.lateral_force_front, 0.8 * plain.lateral_force_front);
        assert_eq!(gripped.lateral_force_rear, 1.3 * plain.lateral_force_rear);
        assert_eq!(
            gripped.longitudinal_force_front,
            plain.longitudinal_force_front
        );
    }

    /// A softer front axle makes the car understeer more: less steady-state yaw rate for the
    /// same steering angle; a softer rear axle, more.
    #[test]
    fn softer_front_understeers_softer_rear_oversteers() {
        let steady_yaw_rate = |model: &SingleTrackHsri| {
            let mut x = model.straight_rolling_state(18.0);
            let u = DriverInputVector::new(0.02, 0.0, 0.0);
            for _ in 0..5000 {
                x = model.step(&x, &u, 1e-3, Integrator::SemiImplicitEuler);
            }
            x[state_index::YAW_RATE]
        };
        let seed = steady_yaw_rate(&with_scales(1.0, 1.0));
        assert!(steady_yaw_rate(&with_scales(0.8, 1.0)) < 0.97 * seed);
        assert!(steady_yaw_rate(&with_scales(1.0, 0.8)) > 1.03 * seed);
    }
}
