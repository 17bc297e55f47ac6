//! Model C: single-track model referenced to the rear-axle centre, with longitudinal load
//! transfer (seed 003, §2.1, eqs 2.18-2.23), the test bed of the particle filter/smoother and of
//! the EM identification.
//!
//! - State `x = [Vy_ref, ω, φ]`: lateral velocity of the rear-axle centre (m/s), yaw rate
//!   (rad/s), yaw angle (rad). Indices in [`state_index`].
//! - Input `u = [dVx_ref/dt, δ, Vx_ref]`: longitudinal acceleration of the rear-axle centre
//!   (m/s²), road-wheel steering angle (rad, positive left), longitudinal velocity of the
//!   rear-axle centre (m/s). Indices in [`input_index`].
//! - Uncertain parameters `p = [Csf, Csr, m/J, lf]` (003: 3.18), settable with
//!   [`RearAxleModel::set_parameter_vector`] because the EM identification varies them.
//!   `Csf`, `Csr` are normalised cornering stiffnesses: axle force `Fy = Fz · α · Cs`.
//! - Measurement `y = x` (003: 2.22-2.23).
//!
//! Vertical axle loads follow the longitudinal acceleration `a_x` (003: 2.11-2.12), slip angles
//! are the small-angle forms (003: 2.8-2.9). Like model A, `Vx_ref` is replaced by
//! `low_speed_guard` in the slip-angle divisions when it is smaller (finite at standstill).

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::integrator::{explicit_euler, runge_kutta4, Integrator};
use crate::scalar::{seed_state_and_input, split_jacobians, Scalar};
use crate::single_track::guarded_speed;

/// Number of states of model C.
pub const STATE_DIM: usize = 3;
/// Number of inputs of model C.
pub const INPUT_DIM: usize = 3;
/// Number of measurements of model C.
pub const MEASUREMENT_DIM: usize = 3;
/// Number of identified parameters of model C.
pub const PARAMETER_DIM: usize = 4;

/// Positions in model C's state (and measurement) vector.
pub mod state_index {
    /// Lateral velocity of the rear-axle centre `Vy_ref`, m/s.
    pub const LATERAL_VELOCITY: usize = 0;
    /// Yaw rate `ω`, rad/s.
    pub const YAW_RATE: usize = 1;
    /// Yaw angle `φ`, rad.
    pub const YAW_ANGLE: usize = 2;
}

/// Positions in model C's input vector.
pub mod input_index {
    /// Longitudinal acceleration of the rear-axle centre `dVx_ref/dt`, m/s².
    pub const LONGITUDINAL_ACCELERATION: usize = 0;
    /// Road-wheel steering angle `δ`, rad.
    pub const STEERING_ANGLE: usize = 1;
    /// Longitudinal velocity of the rear-axle centre `Vx_ref`, m/s.
    pub const LONGITUDINAL_VELOCITY: usize = 2;
}

/// Positions in model C's parameter vector `p` (003: 3.18).
pub mod parameter_index {
    /// `Csf`, normalised front cornering stiffness, 1/rad.
    pub const FRONT_CORNERING: usize = 0;
    /// `Csr`, normalised rear cornering stiffness, 1/rad.
    pub const REAR_CORNERING: usize = 1;
    /// `m/J`, mass over yaw inertia, 1/m².
    pub const MASS_OVER_INERTIA: usize = 2;
    /// `lf`, CoG to front axle, m.
    pub const COG_TO_FRONT_AXLE: usize = 3;
}

/// Model C's state `[Vy_ref, ω, φ]`.
pub type RearAxleState = SVector<f64, STATE_DIM>;
/// Model C's input `[dVx_ref/dt, δ, Vx_ref]`.
pub type RearAxleInput = SVector<f64, INPUT_DIM>;
/// Model C's parameter vector `[Csf, Csr, m/J, lf]`.
pub type RearAxleParameterVector = SVector<f64, PARAMETER_DIM>;

/// Parameters of model C; `Default` holds the simulation values of seed 003, §3.2.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RearAxleParams {
    /// `Csf`, normalised front cornering stiffness, 1/rad.
    pub front_cornering: f64,
    /// `Csr`, normalised rear cornering stiffness, 1/rad.
    pub rear_cornering: f64,
    /// `m/J`, 1/m².
    pub mass_over_inertia: f64,
    /// `lf`, CoG to front axle, m.
    pub cog_to_front_axle: f64,
    /// `L`, wheelbase, m.
    pub wheelbase: f64,
    /// `h`, CoG height, m.
    pub cog_height: f64,
    /// `g`, gravitational acceleration, m/s².
    pub gravity: f64,
    /// Smallest `Vx_ref` used as divisor in the slip angles, m/s (project's standstill guard).
    pub low_speed_guard: f64,
}

impl Default for RearAxleParams {
    /// `p = [8.36, 7.78, 0.62, 1.014]` (003: 3.18), `L = 2.69 m`, `h = 0.5 m`, `g = 9.81 m/s²`
    /// (003: §3.2). The seed derives `p` from `m = 1707 kg`, `J = 2741.9 kg m²`,
    /// `Cf = 70000 N/rad`, `Cr = 65100 N/rad` (003: 3.14-3.17, see
    /// [`RearAxleParams::from_vehicle_data`]) and rounds it in 3.18; the rounded vector is what
    /// the seed simulates with, so it is the default.
    fn default() -> Self {
        Self {
            front_cornering: 8.36,
            rear_cornering: 7.78,
            mass_over_inertia: 0.62,
            cog_to_front_axle: 1.014,
            wheelbase: 2.69,
            cog_height: 0.5,
            gravity: crate::GRAVITY,
            low_speed_guard: crate::single_track::DEFAULT_LOW_SPEED_GUARD,
        }
    }
}

/// Vehicle mass of the seed-003 test vehicle, kg (003: §3.2).
pub const SEED_MASS: f64 = 1707.0;
/// Yaw inertia of the seed-003 test vehicle, kg m² (003: §3.2).
pub const SEED_YAW_INERTIA: f64 = 2741.9;
/// Cornering stiffness of one front tyre of the seed-003 test vehicle, N/rad (003: §3.2).
pub const SEED_FRONT_TYRE_STIFFNESS: f64 = 70000.0;
/// Cornering stiffness of one rear tyre of the seed-003 test vehicle, N/rad (003: §3.2).
pub const SEED_REAR_TYRE_STIFFNESS: f64 = 65100.0;

impl RearAxleParams {
    /// Parameters from physical vehicle data by 003: 3.14-3.17:
    /// `Csf = 2 Cf/(m g)`, `Csr = 2 Cr/(m g)`, `m/J`.
    #[allow(clippy::too_many_arguments)]
    pub fn from_vehicle_data(
        mass: f64,
        yaw_inertia: f64,
        front_tyre_stiffness: f64,
        rear_tyre_stiffness: f64,
        cog_to_front_axle: f64,
        wheelbase: f64,
        cog_height: f64,
        gravity: f64,
    ) -> Self {
        // two tyres per axle
        let front_axle_stiffness = 2.0 * front_tyre_stiffness;
        let rear_axle_stiffness = 2.0 * rear_tyre_stiffness;
        Self {
            // (003: 3.14)
            front_cornering: front_axle_stiffness / (mass * gravity),
            // (003: 3.15)
            rear_cornering: rear_axle_stiffness / (mass * gravity),
            // (003: 3.16)
            mass_over_inertia: mass / yaw_inertia,
            // (003: 3.17)
            cog_to_front_axle,
            wheelbase,
            cog_height,
            gravity,
            ..Self::default()
        }
    }

    /// `p = [Csf, Csr, m/J, lf]` (003: 3.18).
    pub fn parameter_vector(&self) -> RearAxleParameterVector {
        RearAxleParameterVector::new(
            self.front_cornering,
            self.rear_cornering,
            self.mass_over_inertia,
            self.cog_to_front_axle,
        )
    }

    /// Sets `p = [Csf, Csr, m/J, lf]`.
    pub fn set_parameter_vector(&mut self, p: &RearAxleParameterVector) {
        self.front_cornering = p[parameter_index::FRONT_CORNERING];
        self.rear_cornering = p[parameter_index::REAR_CORNERING];
        self.mass_over_inertia = p[parameter_index::MASS_OVER_INERTIA];
        self.cog_to_front_axle = p[parameter_index::COG_TO_FRONT_AXLE];
    }
}

/// Model C (003: 2.18-2.23).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct RearAxleModel {
    pub params: RearAxleParams,
}

impl RearAxleModel {
    pub fn new(params: RearAxleParams) -> Self {
        Self { params }
    }

    /// The identified parameter vector `p` (003: 3.18).
    pub fn parameter_vector(&self) -> RearAxleParameterVector {
        self.params.parameter_vector()
    }

    /// Replaces `p` (the EM identification varies it, 003: 3.3-3.12).
    pub fn set_parameter_vector(&mut self, p: &RearAxleParameterVector) {
        self.params.set_parameter_vector(p);
    }

    /// A copy with parameter vector `p`.
    pub fn with_parameter_vector(&self, p: &RearAxleParameterVector) -> Self {
        let mut model = self.clone();
        model.set_parameter_vector(p);
        model
    }

    /// Longitudinal CoG acceleration `a_x = dVx_ref/dt − ω Vy_ref − ω² lr` (003: 2.18).
    #[inline(always)]
    fn longitudinal_acceleration<S: Scalar>(&self, x: &[S; STATE_DIM], u: &[S; INPUT_DIM]) -> S {
        let p = &self.params;
        let cog_to_rear_axle = p.wheelbase - p.cog_to_front_axle;
        let yaw_rate = x[state_index::YAW_RATE];
        // (003: 2.18)
        u[input_index::LONGITUDINAL_ACCELERATION]
            - yaw_rate * x[state_index::LATERAL_VELOCITY]
            - yaw_rate.square() * cog_to_rear_axle
    }

    /// Continuous-time right-hand side (003: 2.18-2.21), generic over the scalar.
    #[inline(always)]
    pub fn derivatives_generic<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
    ) -> [S; STATE_DIM] {
        let p = &self.params;
        let cog_to_rear_axle = p.wheelbase - p.cog_to_front_axle;
        let lateral_velocity = x[state_index::LATERAL_VELOCITY];
        let yaw_rate = x[state_index::YAW_RATE];
        let steer = u[input_index::STEERING_ANGLE];
        let longitudinal_velocity = u[input_index::LONGITUDINAL_VELOCITY];
        let divisor = guarded_speed(longitudinal_velocity, p.low_speed_guard);
        let ax = self.longitudinal_acceleration(x, u);
        // (003: 2.8) front slip angle
        let front_slip_angle = steer - (lateral_velocity + yaw_rate * p.wheelbase) / divisor;
        // (003: 2.9) rear slip angle is −Vy/Vx; the seed writes its negative
        let rear_drift = lateral_velocity / divisor;
        // normalised axle loads Fz/m (003: 2.11-2.12)
        let front_load = (-(ax * p.cog_height) + cog_to_rear_axle * p.gravity) / p.wheelbase;
        let rear_load = (ax * p.cog_height + p.cog_to_front_axle * p.gravity) / p.wheelbase;
        // (003: 2.19)
        let yaw_acceleration =
            (front_load * front_slip_angle * (p.front_cornering * p.cog_to_front_axle)
                + rear_load * rear_drift * (p.rear_cornering * cog_to_rear_axle))
                * p.mass_over_inertia;
        // (003: 2.20)
        let lateral_velocity_rate = front_load * front_slip_angle * p.front_cornering
            - rear_load * rear_drift * p.rear_cornering
            - yaw_rate * longitudinal_velocity
            - yaw_acceleration * cog_to_rear_axle;
        // (003: 2.21)
        let yaw_angle_rate = yaw_rate;
        [lateral_velocity_rate, yaw_acceleration, yaw_angle_rate]
    }

    /// One discrete step, generic over the scalar; inputs held over the step.
    #[inline(always)]
    pub fn step_generic<S: Scalar>(
        &self,
        x: &[S; STATE_DIM],
        u: &[S; INPUT_DIM],
        dt: f64,
        integrator: Integrator,
    ) -> [S; STATE_DIM] {
        match integrator {
            Integrator::RungeKutta4 => runge_kutta4(x, dt, |s| self.derivatives_generic(s, u)),
            Integrator::SemiImplicitEuler => explicit_euler(x, dt, &self.derivatives_generic(x, u)),
        }
    }

    /// `ẋ = f(x, u)` (003: 2.18-2.21).
    pub fn derivatives(&self, x: &RearAxleState, u: &RearAxleInput) -> RearAxleState {
        RearAxleState::from(self.derivatives_generic(&x.data.0[0], &u.data.0[0]))
    }

    /// One discrete step of length `dt`. The seed integrates with RK4 (003: §3.1, A.5), so
    /// [`Integrator::RungeKutta4`] reproduces it; `SemiImplicitEuler` is plain explicit Euler
    /// here (model C has no wheel speeds).
    pub fn step(
        &self,
        x: &RearAxleState,
        u: &RearAxleInput,
        dt: f64,
        integrator: Integrator,
    ) -> RearAxleState {
        RearAxleState::from(self.step_generic(&x.data.0[0], &u.data.0[0], dt, integrator))
    }

    /// Exact Jacobians `(∂f_d/∂x, ∂f_d/∂u)` of the discrete step (3×3, 3×3).
    pub fn step_jacobians(
        &self,
        x: &RearAxleState,
        u: &RearAxleInput,
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

    /// `y = x`: all states measured (003: 2.22-2.23).
    pub fn measurement(&self, x: &RearAxleState, _u: &RearAxleInput) -> RearAxleState {
        *x
    }

    /// `∂h/∂x = I` (003: 2.23).
    pub fn measurement_jacobian(&self) -> SMatrix<f64, MEASUREMENT_DIM, STATE_DIM> {
        SMatrix::identity()
    }

    /// Rear sideslip `β_r = atan(Vy_ref / Vx_ref)` (003: 2.6).
    pub fn rear_sideslip(&self, x: &RearAxleState, u: &RearAxleInput) -> f64 {
        x[state_index::LATERAL_VELOCITY].atan2(u[input_index::LONGITUDINAL_VELOCITY])
    }
}
