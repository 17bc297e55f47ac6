//! One corner of the car: wheel-centre velocity, tyre force with the low-speed regularisation,
//! the braked wheel spin and the tyre's transient deflections (see the module docs of [`super`]).

use std::f64::consts::PI;

use super::params::LowSpeedParams;
use crate::tyre::combined_slip::CombinedSlipTyre;
use crate::tyre::TyreForce;

/// Velocity `(v_x,w, v_y,w)` of a wheel centre in its own frame, for the body velocity
/// `(vx, vy)`, yaw rate `r`, the wheel's position `(x, y)` from the CoG and its steering angle:
/// rigid-body kinematics `v + r × p`, rotated by `−δ`.
#[inline(always)]
pub(super) fn wheel_velocity(
    body_velocity: (f64, f64),
    yaw_rate: f64,
    position: (f64, f64),
    (sin_angle, cos_angle): (f64, f64),
) -> (f64, f64) {
    let vx = body_velocity.0 - yaw_rate * position.1;
    let vy = body_velocity.1 + yaw_rate * position.0;
    (
        vx * cos_angle + vy * sin_angle,
        -vx * sin_angle + vy * cos_angle,
    )
}

/// Weight of the low-speed damping, `½(1 + cos(π |v|/V_low))` below `V_low`, 0 above: the
/// smooth fade of MF-Tyre's low-speed damping (Pacejka 2012, Sect. 7.2 / 8.4 discuss the need).
#[inline(always)]
pub(super) fn low_speed_weight(speed: f64, damping_speed: f64) -> f64 {
    let ratio = speed.abs() / damping_speed;
    if ratio < 1.0 {
        0.5 * (1.0 + (PI * ratio).cos())
    } else {
        0.0
    }
}

/// What a tyre sees in one step.
pub(super) struct TyreContact {
    /// Longitudinal and lateral deflection states `(u, v)`, m.
    pub deflection: (f64, f64),
    /// Wheel-centre velocity in the wheel frame, m/s.
    pub wheel_velocity: (f64, f64),
    /// Circumferential speed `Ω r_e`, m/s.
    pub rolling_speed: f64,
    /// Vertical load, N.
    pub vertical_load: f64,
    /// Road friction `λ_μ`.
    pub road_friction: f64,
}

/// The tyre's force: the combined-slip Magic Formula at the transient slips `κ' = u/σκ`,
/// `tan α' = v/σα` plus the slip-velocity damping that fades in below `V_low`, limited to the
/// tyre's peaks (the damping is a model of static friction, never more than the road gives).
pub(super) fn tyre_force(
    tyre: &CombinedSlipTyre,
    low_speed: &LowSpeedParams,
    contact: &TyreContact,
) -> (TyreForce<f64>, (f64, f64)) {
    let p = &tyre.params;
    let slip = contact.deflection.0 / p.relaxation_length_longitudinal;
    let tan_slip_angle = contact.deflection.1 / p.relaxation_length_lateral;
    let magic = tyre.force(
        slip,
        tan_slip_angle,
        contact.vertical_load,
        contact.road_friction,
    );
    let weight = low_speed_weight(contact.wheel_velocity.0, low_speed.damping_speed);
    let longitudinal_slip_velocity = contact.rolling_speed - contact.wheel_velocity.0;
    let longitudinal = magic.force.longitudinal
        + weight * low_speed.longitudinal_damping * longitudinal_slip_velocity;
    let lateral =
        magic.force.lateral - weight * low_speed.lateral_damping * contact.wheel_velocity.1;
    (
        TyreForce {
            longitudinal: longitudinal.clamp(-magic.peak_longitudinal, magic.peak_longitudinal),
            lateral: lateral.clamp(-magic.peak_lateral, magic.peak_lateral),
        },
        (slip, tan_slip_angle),
    )
}

/// Wheel speed after a step under a brake: `free_speed` is the speed the other torques give,
/// `brake_change = dt T_b / I_w ≥ 0` the most the brake can change it. The brake torque opposes
/// the rotation and cannot reverse it; if it can stop the wheel within the step, the wheel stands
/// (static friction of the brake). This is the time-stepping treatment of Coulomb friction
/// (Moreau; Stewart, SIAM Review 42, 2000): no sign function, no chatter, no division.
#[inline(always)]
pub(super) fn braked_wheel_speed(free_speed: f64, brake_change: f64) -> f64 {
    if free_speed.abs() <= brake_change {
        0.0
    } else {
        free_speed - brake_change.copysign(free_speed)
    }
}

/// One step of the tyre's first-order transient slip (Pacejka 2012, Sect. 7.2, the "single
/// contact point" model): `du/dt + |V_x| u/σ = V_s` with the slip velocity `V_s`
/// (`Ω r_e − V_x` longitudinally, `−V_y` laterally), so that `u/σ` relaxes to the steady slip
/// `V_s/|V_x|` over the distance `σ`. The decay is taken implicitly (stable at any speed), the
/// slip velocity at the step's end (semi-implicit Euler). At standstill (`V_x = 0`) `u` is a
/// spring deflection: a parked car is held by its tyres' stiffness `K/σ`. The deflection is
/// limited to `limit · σ` (beyond that the tyre slides fully).
#[inline(always)]
pub(super) fn relaxed_deflection(
    deflection: f64,
    slip_velocity: f64,
    speed: f64,
    relaxation_length: f64,
    dt: f64,
    limit: f64,
) -> f64 {
    let largest = limit * relaxation_length;
    ((deflection + dt * slip_velocity) / (1.0 + dt * speed.abs() / relaxation_length))
        .clamp(-largest, largest)
}
