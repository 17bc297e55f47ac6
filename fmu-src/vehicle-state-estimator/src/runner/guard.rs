//! The integrity guard: the FMU's own parameters give a sideslip the estimate must stay near,
//! and a filter that leaves it is re-seeded there with an honest standard deviation (status bit
//! 16384), so that no sensor, speed, steering angle or data gap drives the estimate far off
//! while its reported std stays small.
//!
//! **The reference.** From the steering geometry and the sensors, without the filter:
//! - at walking pace the kinematic sideslip `β_kin = atan(lR/L tan δ)` of tyres without slip
//!   angle (Rajamani, Vehicle Dynamics and Control, 2nd ed., eq. 2.30);
//! - driving, the steady-state single-track sideslip from the measured yaw rate,
//!   `β_ss = lR r / vx − αR`, with the rear axle's slip angle `αR = m lF vx r / (L C_R)` of a
//!   steady turn (`ay = vx r`, `F_yR = m lF ay / L`; Mitschke and Wallentowitz, Dynamik der
//!   Kraftfahrzeuge, 5th ed., 2014, ch. 25), `C_R` the rear axle's cornering stiffness of the
//!   FMU's own tyre parameters at the static load, times the learned rear grip where the model
//!   has one;
//! - between 3 and 6 m/s the two blended linearly.
//!
//! **Its uncertainty**, added in quadrature: half the rear slip angle (a car's stiffness is not
//! the parameters'), the gyro's noise through `lR / vx`, how far the car is from steady state
//! (`β̇ = ay / vx − r` over half a second, the sideslip's lag behind the yaw rate), and 1.5°
//! for what the single-track model leaves out (roll, load transfer, a road's bank).
//!
//! **The test.** The estimate leaves the reference when `|β − β_ref| > 5 sqrt(σ² + σ_ref²)`;
//! after [`GUARD_TIME`] in a row the filter is re-seeded with `β_ref` and the variance
//! `σ_ref² + (β − β_ref)² / 4`: it says where the car is, and that the filter was lost.

use vehicle_models::single_track::WHEELS_PER_AXLE;
use vehicle_models::HsriTyre;

use super::EstimationModel;
use super::Runner;
use crate::model_description::Variables;
use crate::parameters::{self, positive};
use crate::sensors::{MeasuredSpeed, Sensors};
use crate::status;

/// The guard's car from the parameters: the rear axle's cornering stiffness is model A's HSRI
/// tyre (000: 5.70) at the static rear wheel load, with `cornering_stiffness_scale_rear`, for
/// every model (model B's Magic Formula tyres are matched to it).
pub(super) fn guard_car(v: &Variables) -> Result<GuardCar, String> {
    let source = parameters::source(v);
    let chassis = source.chassis()?;
    let tyre = HsriTyre::new(source.hsri()?);
    let scale = positive(
        "cornering_stiffness_scale_rear",
        v.cornering_stiffness_scale_rear,
    )?;
    let rear = tyre.params.cornering_stiffness(chassis.rear_wheel_load) * WHEELS_PER_AXLE * scale;
    Ok(GuardCar {
        mass: chassis.mass,
        cog_to_front_axle: chassis.cog_to_front_axle,
        cog_to_rear_axle: chassis.cog_to_rear_axle,
        rear_cornering_stiffness: positive("rear cornering stiffness", rear)?,
        yaw_rate_std: v.measurement_noise_std_yaw_rate,
    })
}

/// How many standard deviations of the difference the estimate may be off the reference.
const GUARD_SIGMAS: f64 = 5.0;

/// How long the estimate must stay outside before the guard re-seeds it, s: a transient the
/// steady-state reference does not follow (a steering step) passes within it.
const GUARD_TIME: f64 = 0.2;

/// The speeds between which the reference goes from the kinematic to the steady-state
/// sideslip, m/s.
const KINEMATIC_SPEED: f64 = 3.0;
const STEADY_SPEED: f64 = 6.0;

/// The std of what the single-track reference leaves out, rad (1.5°).
const REFERENCE_FLOOR: f64 = 0.026;

/// The time over which a sideslip rate makes the steady state a poor reference, s.
const SIDESLIP_LAG: f64 = 0.5;

/// The car data the reference needs, from the FMU's parameters.
#[derive(Clone, Copy, Debug)]
pub(super) struct GuardCar {
    pub(super) mass: f64,
    pub(super) cog_to_front_axle: f64,
    pub(super) cog_to_rear_axle: f64,
    /// The rear axle's cornering stiffness, both tyres, at grip 1, N/rad.
    pub(super) rear_cornering_stiffness: f64,
    /// The gyro's noise std, rad/s.
    pub(super) yaw_rate_std: f64,
}

/// The reference sideslip and its standard deviation, rad.
pub(super) fn reference(
    car: &GuardCar,
    steering: f64,
    speed: f64,
    yaw_rate: f64,
    ay: f64,
    rear_grip: f64,
) -> (f64, f64) {
    let wheelbase = car.cog_to_front_axle + car.cog_to_rear_axle;
    let kinematic = (car.cog_to_rear_axle / wheelbase * steering.tan()).atan();
    let v = speed.abs();
    let weight = ((v - KINEMATIC_SPEED) / (STEADY_SPEED - KINEMATIC_SPEED)).clamp(0.0, 1.0);
    if weight == 0.0 || !yaw_rate.is_finite() {
        return (kinematic, REFERENCE_FLOOR.hypot(0.5 * kinematic));
    }
    let stiffness = car.rear_cornering_stiffness * rear_grip.max(0.1);
    let rear_slip = car.mass * car.cog_to_front_axle * v * yaw_rate / (wheelbase * stiffness);
    let steady = car.cog_to_rear_axle * yaw_rate / v - rear_slip;
    let rate = if ay.is_finite() {
        ay / v - yaw_rate
    } else {
        0.0
    };
    let std = [
        0.5 * rear_slip,
        car.yaw_rate_std * car.cog_to_rear_axle / v,
        SIDESLIP_LAG * rate,
        REFERENCE_FLOOR,
    ]
    .into_iter()
    .fold(0.0, f64::hypot);
    let blended = weight * steady + (1.0 - weight) * kinematic;
    let kinematic_std = REFERENCE_FLOOR.hypot(0.5 * kinematic);
    (blended, weight * std + (1.0 - weight) * kinematic_std)
}

impl<Model, const N: usize, const M: usize, const U: usize> Runner<Model, N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    /// Checks the updated estimate against the reference; re-seeds the filter after
    /// [`GUARD_TIME`] outside it and returns status bit 16384 then.
    pub(super) fn guard(&mut self, sensors: &Sensors) -> i32 {
        let Some(car) = self.guard_car else {
            return 0;
        };
        let Some(speed) = MeasuredSpeed::of(sensors, &self.parameters) else {
            self.guard_samples = 0;
            return 0;
        };
        let state = *self.filter.state();
        let covariance = *self.filter.covariance();
        let (reference, reference_std) = reference(
            &car,
            self.input[0],
            speed.speed,
            sensors.yaw_rate,
            sensors.ay,
            self.model.rear_grip(&state),
        );
        let (sideslip, variance) = self.model.sideslip_of(&state, &covariance);
        let reach = GUARD_SIGMAS * (variance + reference_std * reference_std).sqrt();
        let off = sideslip - reference;
        if !(reach.is_finite() && off.is_finite()) || off.abs() <= reach {
            self.guard_samples = 0;
            return 0;
        }
        self.guard_samples += 1;
        if f64::from(self.guard_samples) * self.sample_time < GUARD_TIME {
            return 0;
        }
        self.guard_samples = 0;
        let mut estimate = estimation::kalman::InitialEstimate { state, covariance };
        let reseeded_variance = reference_std * reference_std + 0.25 * off * off;
        self.model
            .reseed_sideslip(&mut estimate, reference, reseeded_variance);
        if self.reseed(&estimate) {
            status::GUARDED
        } else {
            0
        }
    }
}
