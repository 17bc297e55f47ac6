//! Model A's wheels while the torques are unknown: every
//! torque input reads exactly 0 (most cars report none). `vx` then follows the speed anchor's
//! kinematics where `ax` is measured ([`super::single_track::SpeedAnchoredModel`]), else the
//! body's force balance with the freely rolling wheels' forces below (the car coasting), and
//! in both cases `vx_meas` or the wheel speeds correct it. The case once also required `ax`;
//! without it the seed's wheels returned, and on the Ford Escort's drive to the limit without an
//! `ax` column (harness/logs, `ax_meas` NaN) the grip model's EKF was 4.56° off in sideslip RMSE
//! (NEES 931); with the wheels of this module 1.33° (NEES 277; the sideslip then rests on the
//! tyre law alone, README "Which model"), and the campaigns, which measure `ax`, unchanged.
//!
//! **What the seed's wheels do then.** Each wheel's spin balance `J ω̇ = T − r Fx` (000:
//! 5.45-5.46) sees the tyre's braking or driving force without the torque that balances it, and
//! the seed scheme's damped step returns the wheel to the slip where its tyre force vanishes,
//! free rolling. How far that step gets depends on the slip angle through the combined slip
//! (000: 5.67): near the tyre's limit it falls short. A filter that also estimates the tyres'
//! lateral grip then lowers its wheel-speed innovations by raising both slip angles while both
//! grip factors fall, `ay` and `r` unchanged, a direction no sensor sees (braking in a turn with
//! ABS on the campaign cars: sideslip 4.4-4.8° off against 1.2-1.9° of true sideslip; with the
//! brake torque given, 0.3-0.5°). And the longitudinal force it evaluates (from the measured
//! wheel's slip against zero torque) is not the car's either: with one inner rear wheel locked
//! the axle-mean wheel speed halves, and the tyre law's combined slip takes the rear axle's side
//! force away.
//!
//! **What they do here.** With the torques unknown the longitudinal tyre forces are unknown, so:
//!
//! - the tyre forces (the body's dynamics and `ay`) are evaluated with both wheels at free
//!   rolling ([`free_rolling`]): pure side slip; what braking or traction takes from the side
//!   force is one more force error for the grip states;
//! - each wheel keeps its slip velocity `r ω − Vx,wheel` over a sample ([`keeping_slip`]): its
//!   speed changes with the car's (`ax` kinematics), its slip only through the process noise the
//!   FMU adds while the torques are unknown (`unknown_torque_slip_std`), so the wheel state
//!   follows its own measurement and carries no force into the model.
//!
//! The wheels then no longer tie `vx` to their measurements through the tyre law; the speed rests
//! on `vx_meas` and the `ax` kinematics. The tie was worth little under an unknown torque: with
//! `vx_meas` missing (NaN) and the torques told 0, the grip model's EKF on the Escort was up to
//! 2.5 % off in `vx` on the slow ramp to the limit and 31 % braking in a turn with the spin
//! balance, 0.9 % and 1.8 % without it (`harness robustness` with those two cases added).

use vehicle_models::driver_input::{index as input_index, INPUT_DIM};
use vehicle_models::single_track::{state_index, STATE_DIM};
use vehicle_models::{Scalar, SingleTrackModel, TyreModel};

use super::single_track::REAR_DRIVE_INPUT;

/// Every torque input (front drive, brake, rear drive) reads exactly 0: the FMU's convention for
/// "torques unknown" (`unknown_torque_slip_std`). `u` is any input that begins with the
/// driver input and the rear drive torque (the anchored model's, the FMU runner's).
pub fn torques_read_zero<S: Scalar, const K: usize>(u: &[S; K]) -> bool {
    [
        input_index::DRIVE_TORQUE,
        input_index::BRAKE_TORQUE,
        REAR_DRIVE_INPUT,
    ]
    .into_iter()
    .all(|i| u[i].value() == 0.0)
}

/// `body` with both wheels at free rolling: `ω = Vx,wheel / r`, the wheel centre's speed along
/// the wheel (000: 5.16 at the front, `vx` at the rear).
pub fn free_rolling<S: Scalar, T: TyreModel>(
    vehicle: &SingleTrackModel<T>,
    body: &[S; STATE_DIM],
    driver: &[S; INPUT_DIM],
) -> [S; STATE_DIM] {
    let [front, rear] = vehicle.kinematic_slip(body, driver);
    let chassis = &vehicle.vehicle.chassis;
    let mut rolling = *body;
    rolling[state_index::OMEGA_FRONT] = front.wheel_velocity * (1.0 / chassis.front_wheel_radius);
    rolling[state_index::OMEGA_REAR] = rear.wheel_velocity * (1.0 / chassis.rear_wheel_radius);
    rolling
}

/// The wheel speeds `[ωF, ωR]` one sample on when each keeps its slip velocity while the body
/// goes from `body` to the speed `next_vx` (the body's `vy` and `r` of the sample's start);
/// `rolling` is `body` at free rolling ([`free_rolling`], which the forces used already).
pub fn keeping_slip<S: Scalar, T: TyreModel>(
    vehicle: &SingleTrackModel<T>,
    body: &[S; STATE_DIM],
    rolling: &[S; STATE_DIM],
    next_vx: S,
    driver: &[S; INPUT_DIM],
) -> [S; 2] {
    let mut then = *rolling;
    then[state_index::VX] = next_vx;
    let then = free_rolling(vehicle, &then, driver);
    [state_index::OMEGA_FRONT, state_index::OMEGA_REAR].map(|i| body[i] + (then[i] - rolling[i]))
}
