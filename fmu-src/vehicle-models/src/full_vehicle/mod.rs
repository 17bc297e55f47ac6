//! The full reference vehicle: a two-track car with roll, lateral and longitudinal load
//! transfer, four wheels with their own spin, combined-slip MF 5.2 tyres with relaxation, front-,
//! rear- or all-wheel drive, braking with optional ABS, and a standstill that works. A truth model
//! in `f64` only (no Jacobians are needed of it, so it is not generic over [`crate::Scalar`]);
//! no heap allocation in [`FullVehicle::step`].
//!
//! **State** ([`state_index`], 18 entries): `vx, vy, r` (body frame, ISO 8855), roll angle `φ`
//! and rate `φ̇` of the sprung mass, the actual road-wheel angle `δ`, four wheel speeds `Ω_i`, four
//! longitudinal and four lateral tyre deflections `u_i, v_i` (the relaxation states).
//!
//! **Input** ([`FullVehicleInput`]): road-wheel angle, total drive torque at the wheels (signed;
//! negative reverses), total brake torque (magnitude ≥ 0), road friction `λ_μ` (1 = dry), road
//! bank `θ` and grade `γ`.
//!
//! **Equations** (wheel `i` at `(x_i, y_i)` from the CoG, steered by `δ_i`, tyre force
//! `(F_x,i, F_y,i)` in its wheel frame rotated into the body frame):
//! - planar motion in the road plane: `m (v̇x − vy r) = ΣF_x − m g sin γ`,
//!   `m (v̇y + vx r) = ΣF_y − m g sin θ`, `I_z ṙ = Σ(x_i F_y,i − y_i F_x,i)` (the truth's
//!   accelerations are these kinematic ones; the load transfer and the roll take the tyres'
//!   specific force `ΣF/m`); the sprung mass's roll does not feed back into the
//!   lateral balance (the `m_s h' φ̈` term, small for small roll);
//! - roll of the sprung mass about the roll axis:
//!   `I_x,s φ̈ = m_s h' (a_y cos φ + g sin φ) − K_φ φ − D_φ φ̇`, `K_φ = K_φf + K_φr`,
//!   `D_φ = D_φf + D_φr`, `h' = h_s − h_ra` (the steady state gives the roll gradient
//!   `φ/a_y = m_s h'/(K_φ − m_s g h')`, [`FullVehicleParams::roll_gradient`]);
//! - wheel loads: static `m g l_r/(2L)` front, `m g l_f/(2L)` rear; longitudinal transfer
//!   `m a_x h/(2L)` per wheel from front to rear; lateral transfer per axle, from the left to the
//!   right wheel for `a_y > 0`: `ΔF_z = (K_φ,axle φ + D_φ,axle φ̇ + m_s l_other/L · h_ra a_y +
//!   m_u,axle r_e a_y)/T_axle` (elastic part through the springs, geometric part through the
//!   roll centre, unsprung part). Each load is clamped at zero: a lifted wheel carries no force.
//!   The accelerations `a_x, a_y` are those of the previous internal step: this breaks the
//!   algebraic loop loads → forces → accelerations without iterating, a 1 ms delay against roll
//!   and pitch modes of about 1-2 Hz;
//! - wheel spin: `I_w Ω̇_i = T_drive,i − r_e F_x,i − T_brake,i` with the brake as Coulomb friction
//!   on the wheel (`corner::braked_wheel_speed`);
//! - tyres: [`CombinedSlipTyre`] at the transient slips `κ' = u/σκ`, `tan α' = v/σα` of the
//!   relaxation states (`corner::relaxed_deflection`, Pacejka 2012, Sect. 7.2);
//! - steering: `δ = δ_cmd − c_s F_y,front` (compliance), optionally lagged by
//!   `τ δ̇ = δ_target − δ`; both front wheels at the same angle (no Ackermann geometry).
//!
//! **Low speed and standstill** (the regularisation, all in the private module `corner`):
//! - no slip is ever formed by dividing by a speed: the relaxation equations
//!   `u̇ + |V_x| u/σκ = Ω r_e − V_x`, `v̇ + |V_x| v/σα = −V_y` are regular at `V_x = 0`, where the
//!   deflections become springs of stiffness `K_xκ/σκ` and `K_yα/σα` that hold a parked car;
//! - below `V_low` a slip-velocity damping `c (Ω r_e − V_x)`, `−c V_y` fades in smoothly
//!   (`½(1 + cos(π|V_x|/V_low))`, the shape of MF-Tyre's low-speed damping): it damps these
//!   springs, so the car settles instead of oscillating; the sum stays within the tyre's peaks;
//! - deflections are limited to `|κ'| ≤ κ_lim`, `|tan α'| ≤ tan α_lim` (the tyre slides beyond),
//!   so a wheel spinning at standstill does not wind up a deflection without bound;
//! - the brake torque opposes the wheel's rotation and cannot reverse it: if it can stop the wheel
//!   within a step, the wheel stands still (no sign function, no chatter; a wheel under a brake
//!   stronger than the drive torque never spins up); reversing works as driving forwards (the
//!   equations hold for either sign of `V_x` and `Ω`).
//!
//! **Numerics**: semi-implicit (symplectic) Euler with a fixed internal step (1 ms by default):
//! accelerations from the state, then velocities, then roll angle and deflections from the new
//! velocities, the deflections' decay implicit. The stiffest modes are the tyre springs against
//! the wheel spin (`√(K_xκ r_e²/(σκ I_w))`, about 200-260 rad/s for the cars here), well inside
//! the method's limit `ω dt < 2` at 1 ms.

mod corner;
mod params;
mod truth;

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

pub use params::{
    AbsParams, BodyParams, CarData, DrivetrainParams, FullVehicleParams, LowSpeedParams,
    SteeringParams, SuspensionParams, WheelParams,
};
pub use truth::{wheel_index, FullVehicleTruth, TRUTH_VALUES};

use crate::tyre::combined_slip::CombinedSlipTyre;
use crate::tyre::TyreForce;
use corner::{braked_wheel_speed, relaxed_deflection, tyre_force, wheel_velocity, TyreContact};

pub use crate::GRAVITY;
/// Number of wheels.
pub const WHEELS: usize = 4;
/// Number of states.
pub const STATE_DIM: usize = 18;
/// Number of values of [`FullVehicle::saved_values`]: the state, the step memory, the truth.
pub const SAVED_VALUES: usize = STATE_DIM + 3 + TRUTH_VALUES;

/// Positions in the state vector.
pub mod state_index {
    /// Longitudinal CoG velocity, m/s.
    pub const VX: usize = 0;
    /// Lateral CoG velocity, m/s.
    pub const VY: usize = 1;
    /// Yaw rate, rad/s.
    pub const YAW_RATE: usize = 2;
    /// Roll angle of the sprung mass, rad.
    pub const ROLL: usize = 3;
    /// Roll rate, rad/s.
    pub const ROLL_RATE: usize = 4;
    /// Actual road-wheel angle of the front wheels, rad.
    pub const ROAD_WHEEL_ANGLE: usize = 5;
    /// Wheel speed of wheel `i` (order of [`super::wheel_index`]) is at `WHEEL_SPEED + i`, rad/s.
    pub const WHEEL_SPEED: usize = 6;
    /// Longitudinal tyre deflection of wheel `i` at `LONGITUDINAL_DEFLECTION + i`, m.
    pub const LONGITUDINAL_DEFLECTION: usize = 10;
    /// Lateral tyre deflection of wheel `i` at `LATERAL_DEFLECTION + i`, m.
    pub const LATERAL_DEFLECTION: usize = 14;
}

/// The full vehicle's state vector.
pub type FullVehicleState = SVector<f64, STATE_DIM>;

/// The driver's and the road's input.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FullVehicleInput {
    /// Commanded road-wheel angle at the front axle, rad, positive left.
    pub steering_angle: f64,
    /// Total drive torque at the wheels, N m (negative: reverse).
    pub drive_torque: f64,
    /// Total brake torque, N m, a magnitude ≥ 0.
    pub brake_torque: f64,
    /// Road friction `λ_μ`, the scale of the tyres' peak friction (1 dry, ~0.5 wet, ~0.1 ice).
    pub road_friction: f64,
    /// Bank (cross slope) of the road, rad, positive when its right edge is lower (the sense of
    /// a positive ISO 8855 roll).
    pub road_bank_angle: f64,
    /// Grade of the road, rad, positive uphill.
    pub road_grade_angle: f64,
}

impl Default for FullVehicleInput {
    fn default() -> Self {
        Self {
            steering_angle: 0.0,
            drive_torque: 0.0,
            brake_torque: 0.0,
            road_friction: 1.0,
            road_bank_angle: 0.0,
            road_grade_angle: 0.0,
        }
    }
}

/// Gravity's component in the road plane, per unit mass, `(−g sin γ, −g sin θ)` for grade `γ`
/// and bank `θ` (the body moves in the road plane; a car on a right-lower bank is pulled to the
/// right). The wheel loads keep their level-road values (`cos θ cos γ ≈ 1` for the slopes of
/// roads, under 1 % at 8°).
fn road_gravity(input: &FullVehicleInput) -> (f64, f64) {
    (
        -GRAVITY * input.road_grade_angle.sin(),
        -GRAVITY * input.road_bank_angle.sin(),
    )
}

/// What one internal step leaves for the next: the accelerations of the load transfer and the
/// front-axle lateral force of the compliance steer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct StepMemory {
    longitudinal_acceleration: f64,
    lateral_acceleration: f64,
    front_lateral_force: f64,
}

/// The full vehicle: parameters, state and what the last step produced.
#[derive(Clone, Debug)]
pub struct FullVehicle {
    params: FullVehicleParams,
    tyre_front: CombinedSlipTyre,
    tyre_rear: CombinedSlipTyre,
    state: FullVehicleState,
    memory: StepMemory,
    truth: FullVehicleTruth,
}

/// Forces of one internal step, per wheel and summed in the body frame.
struct StepForces {
    loads: [f64; WHEELS],
    tyre: [TyreForce<f64>; WHEELS],
    slips: [(f64, f64); WHEELS],
    force_x: f64,
    force_y: f64,
    yaw_moment: f64,
    front_lateral_force: f64,
}

impl FullVehicle {
    /// The car at rest, wheels straight, tyres undeflected.
    pub fn new(params: FullVehicleParams) -> Self {
        Self::rolling(params, 0.0)
    }

    /// The car rolling straight ahead at `speed` (m/s), every wheel free-rolling.
    pub fn rolling(params: FullVehicleParams, speed: f64) -> Self {
        let mut state = FullVehicleState::zeros();
        state[state_index::VX] = speed;
        for wheel in 0..WHEELS {
            state[state_index::WHEEL_SPEED + wheel] = speed / params.wheels.radius;
        }
        let mut vehicle = Self {
            tyre_front: CombinedSlipTyre::new(params.tyre_front.clone()),
            tyre_rear: CombinedSlipTyre::new(params.tyre_rear.clone()),
            params,
            state,
            memory: StepMemory::default(),
            truth: FullVehicleTruth::default(),
        };
        let forces = vehicle.forces(&FullVehicleInput::default());
        vehicle.record_truth(&forces, 0.0, 0.0);
        vehicle
    }

    pub fn params(&self) -> &FullVehicleParams {
        &self.params
    }

    pub fn state(&self) -> &FullVehicleState {
        &self.state
    }

    /// Truth quantities after the last step.
    pub fn truth(&self) -> &FullVehicleTruth {
        &self.truth
    }

    /// Everything that evolves (state, what the last step left for the next, truth), so that a
    /// restored vehicle ([`FullVehicle::restore_saved_values`]) continues bit-identically.
    pub fn saved_values(&self) -> [f64; SAVED_VALUES] {
        let memory = [
            self.memory.longitudinal_acceleration,
            self.memory.lateral_acceleration,
            self.memory.front_lateral_force,
        ];
        let truth = self.truth.to_values();
        let mut values = [0.0; SAVED_VALUES];
        let sources = self.state.iter().chain(memory.iter()).chain(truth.iter());
        for (value, source) in values.iter_mut().zip(sources) {
            *value = *source;
        }
        values
    }

    /// Restores what [`FullVehicle::saved_values`] returned (the parameters stay).
    pub fn restore_saved_values(&mut self, values: &[f64; SAVED_VALUES]) {
        self.state.copy_from_slice(&values[..STATE_DIM]);
        self.memory = StepMemory {
            longitudinal_acceleration: values[STATE_DIM],
            lateral_acceleration: values[STATE_DIM + 1],
            front_lateral_force: values[STATE_DIM + 2],
        };
        let truth: &[f64; TRUTH_VALUES] = values[STATE_DIM + 3..]
            .try_into()
            .expect("SAVED_VALUES - STATE_DIM - 3 = TRUTH_VALUES by definition");
        self.truth = FullVehicleTruth::from_values(truth);
    }

    /// Advances by `dt` (s) with the input held, in internal steps of at most
    /// `params.internal_step`.
    pub fn step(&mut self, input: &FullVehicleInput, dt: f64) {
        // the tolerance keeps e.g. 0.003/0.001 = 3.0000000000000004 at three steps
        let steps = (dt / self.params.internal_step - 1e-9).ceil().max(1.0);
        let internal_dt = dt / steps;
        for _ in 0..steps as usize {
            self.internal_step(input, internal_dt);
        }
    }

    /// Position `(x, y)` of wheel `i` relative to the CoG.
    fn wheel_position(&self, wheel: usize) -> (f64, f64) {
        let body = &self.params.body;
        match wheel {
            wheel_index::FRONT_LEFT => (body.cog_to_front_axle, 0.5 * body.track_front),
            wheel_index::FRONT_RIGHT => (body.cog_to_front_axle, -0.5 * body.track_front),
            wheel_index::REAR_LEFT => (-body.cog_to_rear_axle, 0.5 * body.track_rear),
            _ => (-body.cog_to_rear_axle, -0.5 * body.track_rear),
        }
    }

    fn is_front(wheel: usize) -> bool {
        wheel < wheel_index::REAR_LEFT
    }

    fn tyre(&self, wheel: usize) -> &CombinedSlipTyre {
        if Self::is_front(wheel) {
            &self.tyre_front
        } else {
            &self.tyre_rear
        }
    }

    /// `(sin δ_i, cos δ_i)` of wheel `i`'s steering angle.
    fn steering_sin_cos(&self, wheel: usize) -> (f64, f64) {
        if Self::is_front(wheel) {
            self.state[state_index::ROAD_WHEEL_ANGLE].sin_cos()
        } else {
            (0.0, 1.0)
        }
    }

    /// Velocity of wheel `i`'s centre in its wheel frame, from the current state.
    fn wheel_centre_velocity(&self, wheel: usize) -> (f64, f64) {
        let x = &self.state;
        wheel_velocity(
            (x[state_index::VX], x[state_index::VY]),
            x[state_index::YAW_RATE],
            self.wheel_position(wheel),
            self.steering_sin_cos(wheel),
        )
    }

    /// Vertical wheel loads `[FL, FR, RL, RR]` (module docs), clamped at zero.
    fn wheel_loads(&self) -> [f64; WHEELS] {
        let p = &self.params;
        let (static_front, static_rear) = p.static_wheel_loads();
        let ax = self.memory.longitudinal_acceleration;
        let ay = self.memory.lateral_acceleration;
        let roll = self.state[state_index::ROLL];
        let roll_rate = self.state[state_index::ROLL_RATE];
        let pitch_transfer = 0.5 * p.body.mass * ax * p.body.cog_height / p.wheelbase();
        let sprung_roll_centre = p.sprung_mass() * p.suspension.roll_axis_height * ay;
        let s = &p.suspension;
        let front_transfer = (s.roll_stiffness_front * roll
            + s.roll_damping_front * roll_rate
            + sprung_roll_centre * p.body.cog_to_rear_axle / p.wheelbase()
            + s.unsprung_mass_front * p.wheels.radius * ay)
            / p.body.track_front;
        let rear_transfer = (s.roll_stiffness_rear * roll
            + s.roll_damping_rear * roll_rate
            + sprung_roll_centre * p.body.cog_to_front_axle / p.wheelbase()
            + s.unsprung_mass_rear * p.wheels.radius * ay)
            / p.body.track_rear;
        [
            (static_front - pitch_transfer - front_transfer).max(0.0),
            (static_front - pitch_transfer + front_transfer).max(0.0),
            (static_rear + pitch_transfer - rear_transfer).max(0.0),
            (static_rear + pitch_transfer + rear_transfer).max(0.0),
        ]
    }

    /// Tyre forces of the current state and their sums in the body frame.
    fn forces(&self, input: &FullVehicleInput) -> StepForces {
        let loads = self.wheel_loads();
        let mut forces = StepForces {
            loads,
            tyre: [TyreForce::zero(); WHEELS],
            slips: [(0.0, 0.0); WHEELS],
            force_x: 0.0,
            force_y: 0.0,
            yaw_moment: 0.0,
            front_lateral_force: 0.0,
        };
        for (wheel, &vertical_load) in loads.iter().enumerate() {
            let contact = TyreContact {
                deflection: (
                    self.state[state_index::LONGITUDINAL_DEFLECTION + wheel],
                    self.state[state_index::LATERAL_DEFLECTION + wheel],
                ),
                wheel_velocity: self.wheel_centre_velocity(wheel),
                rolling_speed: self.state[state_index::WHEEL_SPEED + wheel]
                    * self.params.wheels.radius,
                vertical_load,
                road_friction: input.road_friction,
            };
            let (tyre, slips) = tyre_force(self.tyre(wheel), &self.params.low_speed, &contact);
            let (sin, cos) = self.steering_sin_cos(wheel);
            let body_x = tyre.longitudinal * cos - tyre.lateral * sin;
            let body_y = tyre.longitudinal * sin + tyre.lateral * cos;
            let (x, y) = self.wheel_position(wheel);
            forces.tyre[wheel] = tyre;
            forces.slips[wheel] = slips;
            forces.force_x += body_x;
            forces.force_y += body_y;
            forces.yaw_moment += x * body_y - y * body_x;
            if Self::is_front(wheel) {
                forces.front_lateral_force += body_y;
            }
        }
        forces
    }

    /// Drive and brake torque of wheel `i` (open differential per axle: half each).
    fn wheel_torques(&self, input: &FullVehicleInput, wheel: usize, slip: f64) -> (f64, f64) {
        let d = &self.params.drivetrain;
        let (drive_share, brake_share) = if Self::is_front(wheel) {
            (d.drive_split_front, d.brake_split_front)
        } else {
            (1.0 - d.drive_split_front, 1.0 - d.brake_split_front)
        };
        let abs_releases = d.abs.enabled
            && self.state[state_index::VX].abs() > d.abs.min_speed
            && slip < -d.abs.slip_threshold;
        let brake = if abs_releases {
            0.0
        } else {
            0.5 * brake_share * input.brake_torque.max(0.0)
        };
        (0.5 * drive_share * input.drive_torque, brake)
    }

    /// The road-wheel angle for this step: compliance, then the optional lag (implicit Euler).
    fn update_steering(&mut self, input: &FullVehicleInput, dt: f64) {
        let s = &self.params.steering;
        let target = input.steering_angle - s.compliance * self.memory.front_lateral_force;
        let angle = &mut self.state[state_index::ROAD_WHEEL_ANGLE];
        *angle = if s.lag_time_constant > 0.0 {
            *angle + dt / (s.lag_time_constant + dt) * (target - *angle)
        } else {
            target
        };
    }

    /// One semi-implicit Euler step (module docs).
    fn internal_step(&mut self, input: &FullVehicleInput, dt: f64) {
        use state_index::*;
        self.update_steering(input, dt);
        let forces = self.forces(input);
        let p = &self.params;
        // the tyres' specific force: what loads the suspension and what an accelerometer reads
        let ax = forces.force_x / p.body.mass;
        let ay = forces.force_y / p.body.mass;
        let (gravity_x, gravity_y) = road_gravity(input);
        let (vx, vy, yaw_rate) = (self.state[VX], self.state[VY], self.state[YAW_RATE]);
        let roll = self.state[ROLL];
        let roll_moment =
            p.sprung_mass() * p.roll_lever() * (ay * roll.cos() + GRAVITY * roll.sin())
                - p.roll_stiffness() * roll
                - (p.suspension.roll_damping_front + p.suspension.roll_damping_rear)
                    * self.state[ROLL_RATE];
        self.state[VX] = vx + dt * (ax + gravity_x + vy * yaw_rate);
        self.state[VY] = vy + dt * (ay + gravity_y - vx * yaw_rate);
        self.state[YAW_RATE] = yaw_rate + dt * forces.yaw_moment / p.body.yaw_inertia;
        self.state[ROLL_RATE] += dt * roll_moment / p.suspension.roll_inertia;
        self.state[ROLL] += dt * self.state[ROLL_RATE];
        self.update_wheels(input, &forces, dt);
        self.update_deflections(dt);
        self.memory = StepMemory {
            longitudinal_acceleration: ax,
            lateral_acceleration: ay,
            front_lateral_force: forces.front_lateral_force,
        };
        self.record_truth(&forces, ax + gravity_x, ay + gravity_y);
    }

    /// Wheel spin: drive and tyre torque, then the brake as Coulomb friction.
    fn update_wheels(&mut self, input: &FullVehicleInput, forces: &StepForces, dt: f64) {
        for wheel in 0..WHEELS {
            let inertia = if Self::is_front(wheel) {
                self.params.wheels.inertia_front
            } else {
                self.params.wheels.inertia_rear
            };
            let (drive, brake) = self.wheel_torques(input, wheel, forces.slips[wheel].0);
            let torque = drive - self.params.wheels.radius * forces.tyre[wheel].longitudinal;
            let speed = &mut self.state[state_index::WHEEL_SPEED + wheel];
            *speed = braked_wheel_speed(*speed + dt * torque / inertia, dt * brake / inertia);
        }
    }

    /// Relaxation of the tyre deflections with the new velocities.
    fn update_deflections(&mut self, dt: f64) {
        let limits = (
            self.params.low_speed.slip_limit,
            self.params.low_speed.tan_slip_angle_limit,
        );
        for wheel in 0..WHEELS {
            let (speed_x, speed_y) = self.wheel_centre_velocity(wheel);
            let rolling_speed =
                self.state[state_index::WHEEL_SPEED + wheel] * self.params.wheels.radius;
            let tyre = &self.tyre(wheel).params;
            let (sigma_x, sigma_y) = (
                tyre.relaxation_length_longitudinal,
                tyre.relaxation_length_lateral,
            );
            let u = state_index::LONGITUDINAL_DEFLECTION + wheel;
            let v = state_index::LATERAL_DEFLECTION + wheel;
            self.state[u] = relaxed_deflection(
                self.state[u],
                rolling_speed - speed_x,
                speed_x,
                sigma_x,
                dt,
                limits.0,
            );
            self.state[v] =
                relaxed_deflection(self.state[v], -speed_y, speed_x, sigma_y, dt, limits.1);
        }
    }

    fn record_truth(&mut self, forces: &StepForces, ax: f64, ay: f64) {
        use state_index::*;
        let x = &self.state;
        let (vx, vy) = (x[VX], x[VY]);
        let mut truth = FullVehicleTruth {
            longitudinal_velocity: vx,
            lateral_velocity: vy,
            yaw_rate: x[YAW_RATE],
            sideslip: if vx == 0.0 && vy == 0.0 {
                0.0
            } else {
                vy.atan2(vx)
            },
            longitudinal_acceleration: ax,
            lateral_acceleration: ay,
            roll_angle: x[ROLL],
            roll_rate: x[ROLL_RATE],
            road_wheel_angle: x[ROAD_WHEEL_ANGLE],
            wheel_load: forces.loads,
            ..FullVehicleTruth::default()
        };
        for wheel in 0..WHEELS {
            truth.wheel_speed[wheel] = x[WHEEL_SPEED + wheel];
            truth.slip[wheel] = forces.slips[wheel].0;
            truth.slip_angle[wheel] = forces.slips[wheel].1.atan();
            truth.tyre_force_longitudinal[wheel] = forces.tyre[wheel].longitudinal;
            truth.tyre_force_lateral[wheel] = forces.tyre[wheel].lateral;
        }
        self.truth = truth;
    }
}
