//! The low-speed regime (`low_speed_kinematics`): at walking and manoeuvring pace the sideslip
//! is held to the steady turn that the measured yaw rate and speed give, within its
//! uncertainty, and that hold fades out as the speed rises, so the filter hands over to its
//! dynamic model without a jump.
//!
//! **Why.** Below a few m/s the tyres' side forces are small (`m vx r`), so the slip angles
//! that carry them are small and the sideslip is the steering geometry's: the rear axle rolls
//! along itself, `tan β = lR r / vx` (Rajamani, Vehicle Dynamics and Control, 2nd ed., 2012,
//! eq. 2.30, with the yaw rate of the kinematic model). The filter's own dynamic model says the
//! same only through `ay`, whose signal at those speeds is mostly the body's vibration, and
//! through tyre forces that change with `Δvy / vx`, steep at low speed. On the campaigns'
//! low-speed course with a vibrating accelerometer (full vehicle, three cars) 95 % of the grip
//! EKF's squared sideslip error came from speeds below 5 m/s.
//!
//! **The pseudo-measurement.** `β(x̂) = β_ref` with `β_ref = atan(lR r / vx − αR)` and
//! `αR = m lF vx r / (L C_R)` the rear slip angle of that steady turn (the steady-state
//! reference of `runner::guard`), `r` the gyro (offset removed) and `vx` the measured speed.
//! Its standard deviation, in quadrature: half of `αR` (a car's stiffness is not the
//! parameters'), the gyro's noise through `lR / vx`, and [`KINEMATIC_FLOOR`] for what a rigid
//! single track leaves out. The reference's error is correlated over [`CORRELATION_TIME`], so
//! each sample takes it with its variance times the samples in that time (it tells the filter
//! once per correlation time, not once per sample), and the weight falls linearly from 1 at
//! [`FULL_SPEED`] to 0 at [`FADED_SPEED`]. Estimators without a Gaussian of their own (the
//! particle filter, the Luenberger observer) decline it.

use super::guard::GuardCar;
use super::EstimationModel;
use super::Runner;
use crate::sensors::{MeasuredSpeed, Sensors};

/// Up to this speed the pseudo-measurement has its full weight, m/s.
const FULL_SPEED: f64 = 4.0;

/// From this speed on it is off, m/s: at 8 m/s in a 30 m corner (0.22 g) a passenger car's rear
/// slip angle is about 0.7°, its half (the reference's std) the size of the filter's own
/// sideslip error there. Measured on the noisy low-speed course (grip EKF, Escort / BMW /
/// Vanagon): full to 3 m/s and off from 6 m/s 0.226 / 0.216 / 0.269°, 4 and 8 m/s 0.221 /
/// 0.212 / 0.262° (the yardstick 0.244 / 0.200 / 0.248°); no run of the other manoeuvres
/// changed with either.
const FADED_SPEED: f64 = 8.0;

/// The std of what the rigid single-track kinematics leave out at walking pace (the tyres'
/// scrub, the steering's compliance), rad (0.2°).
const KINEMATIC_FLOOR: f64 = 0.0035;

/// How long the reference's error stays the same, s: the rear slip angle's lag behind the yaw
/// rate at these speeds, `m vx / (C_F + C_R)`, a few hundredths of a second. Measured on the
/// noisy low-speed course (grip EKF's sideslip RMSE, Escort / BMW / Vanagon): 0.2 s 0.32 /
/// 0.30 / 0.35°, 0.05 s 0.22 / 0.21 / 0.26°, the yardstick 0.24 / 0.20 / 0.25°.
const CORRELATION_TIME: f64 = 0.05;

/// The pseudo-measurement's weight at `speed` (1 full, 0 off).
fn weight(speed: f64) -> f64 {
    ((FADED_SPEED - speed.abs()) / (FADED_SPEED - FULL_SPEED)).clamp(0.0, 1.0)
}

/// The reference sideslip of the steady turn and its std, rad, at a measured `speed` (> 0) and
/// yaw rate.
pub(super) fn steady_turn(car: &GuardCar, speed: f64, yaw_rate: f64, rear_grip: f64) -> (f64, f64) {
    let wheelbase = car.cog_to_front_axle + car.cog_to_rear_axle;
    let stiffness = car.rear_cornering_stiffness * rear_grip.max(0.1);
    let rear_slip = car.mass * car.cog_to_front_axle * speed * yaw_rate / (wheelbase * stiffness);
    // The rear axle's lateral velocity `vy − lR r = −vx tan αR` (000: 5.22), αR small.
    let sideslip = (car.cog_to_rear_axle * yaw_rate / speed - rear_slip).atan();
    let std = [
        0.5 * rear_slip,
        car.yaw_rate_std * car.cog_to_rear_axle / speed,
        KINEMATIC_FLOOR,
    ]
    .into_iter()
    .fold(0.0, f64::hypot);
    (sideslip, std)
}

/// The relative step of the numerical sideslip gradient.
const GRADIENT_STEP: f64 = 1e-7;

impl<Model, const N: usize, const M: usize, const U: usize> Runner<Model, N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    /// Conditions the updated estimate on the steady turn's sideslip below [`FADED_SPEED`]
    /// (no status bit: a regime, not an event).
    pub(super) fn hold_to_kinematics(&mut self, sensors: &Sensors) {
        let Some(car) = self.kinematic_car else {
            return;
        };
        let Some(speed) = MeasuredSpeed::of(sensors, &self.parameters) else {
            return;
        };
        let weight = weight(speed.speed);
        if weight == 0.0 || speed.speed < self.min_speed || !sensors.yaw_rate.is_finite() {
            return;
        }
        let state = *self.filter.state();
        let (reference, std) = steady_turn(
            &car,
            speed.speed,
            sensors.yaw_rate,
            self.model.rear_grip(&state),
        );
        let (sideslip, gradient) = self.sideslip_gradient(&state);
        let samples = (CORRELATION_TIME / self.sample_time).max(1.0);
        let variance = std * std * samples / weight;
        self.filter
            .condition_on(&gradient, reference - sideslip, variance);
    }

    /// The model's sideslip at `state` and its gradient by forward differences (the sideslip
    /// is a smooth function of a few states: `atan(vy / vx)`, or a state itself).
    fn sideslip_gradient(
        &self,
        state: &nalgebra::SVector<f64, N>,
    ) -> (f64, nalgebra::SVector<f64, N>) {
        let covariance = nalgebra::SMatrix::<f64, N, N>::zeros();
        let (sideslip, _) = self.model.sideslip_of(state, &covariance);
        let gradient = nalgebra::SVector::<f64, N>::from_fn(|i, _| {
            let step = GRADIENT_STEP * state[i].abs().max(1.0);
            let mut moved = *state;
            moved[i] += step;
            (self.model.sideslip_of(&moved, &covariance).0 - sideslip) / step
        });
        (sideslip, gradient)
    }
}

/// The car of the low-speed regime from the parameters, or `None` when it is off.
pub(super) fn kinematic_car(
    v: &crate::model_description::Variables,
) -> Result<Option<GuardCar>, String> {
    v.low_speed_kinematics
        .then(|| super::guard::guard_car(v))
        .transpose()
}
