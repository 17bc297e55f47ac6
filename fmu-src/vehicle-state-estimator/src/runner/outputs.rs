//! The runner's outputs: computed lazily from the samples processed since the last read, the
//! honest outputs of a held sample, and the consider terms of what the filter does not estimate.

use vehicle_models::single_track::{guarded_speed, longitudinal_slip, DEFAULT_LOW_SPEED_GUARD};

use super::EstimationModel;
use super::{Runner, PENDING_CAPACITY};
use crate::estimation_model::OutputSample;
use crate::model_description::{RealOutputs, Variables};
use crate::sensors::WheelRadii;
use crate::status;

/// The sideslip's standard deviation reported while the filter holds at low speed: about 6°, the
/// range the kinematic sideslip of a car manoeuvring slowly spans, so a user sees that the value
/// is a guess.
pub const LOW_SPEED_SIDESLIP_STD: f64 = 0.1;

/// The kinematic sideslip at the centre of gravity when the tyres do not slip, from the steering
/// geometry: `tan β = lR / (lF + lR) · tan δ` (the single-track model at vanishing speed,
/// Ackermann steering; Rajamani, Vehicle Dynamics and Control, 2nd ed., eq. 2.30).
pub fn kinematic_sideslip(steering_angle: f64, v: &Variables) -> f64 {
    let wheelbase = v.cog_to_front_axle + v.cog_to_rear_axle;
    (v.cog_to_rear_axle / wheelbase * steering_angle.tan()).atan()
}

impl<Model, const N: usize, const M: usize, const U: usize> Runner<Model, N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    /// Stores the outputs of the sample just processed, to be computed at the next read.
    pub fn defer_publish(&mut self, variables: &mut Variables, status_awaits_publish: bool) {
        if self.pending.len() == PENDING_CAPACITY {
            self.publish(variables, status_awaits_publish);
        }
        self.pending.push(OutputSample {
            state: *self.filter.state(),
            covariance: *self.filter.covariance(),
            input: self.input,
            extra: self.extra,
            nis: self.nis,
            rows_used: self.rows_used,
            holding: self.holding,
            measured: self.measured,
            covariance_scale: self.covariance_scale(),
            yaw_rate_offset: self.yaw_rate_offset.map_or(0.0, |offset| offset.offset),
            ay_calibration: self
                .lateral_accelerometer
                .map_or([0.0; 2], |accelerometer| accelerometer.estimate.into()),
        });
    }

    /// Writes the pending estimate into the outputs; keeps an output's previous value (and
    /// reports status bit 8 for the latest doStep) if it would not be finite.
    pub fn publish(&mut self, variables: &mut Variables, status_awaits_publish: bool) {
        let Some((newest, older)) = self.pending.split_last() else {
            return;
        };
        let mut values = self.outputs_of(newest);
        let mut finite = values.finite();
        let reset = finite.contains(&false);
        // Eager publishing would have kept the value of the newest older sample where it was
        // finite; walk back only while some output is still missing.
        for sample in older.iter().rev() {
            if !finite.contains(&false) {
                break;
            }
            values.fill_from(&self.outputs_of(sample), &mut finite);
        }
        if newest.holding {
            self.honest_held_outputs(newest, &mut values);
        }
        values.write_where(&finite, variables);
        variables.rows_used = newest.rows_used;
        if reset && status_awaits_publish {
            variables.status |= status::STATE_RESET;
        }
        self.pending.clear();
    }

    /// The model's outputs of `sample` with the rear stiffness's consider term, unless the
    /// filter estimates its tyres' scale ([`EstimationModel::estimates_tyre_scale`]); both the
    /// covariance and the consider term carry the sample's `covariance_scale`. Measured with
    /// the scale on the covariance alone, Luenberger_A's campaign rows with a NEES in 0.5-2 and
    /// 90 % inside stayed 1 of 15 (the consider terms dominate its reported sideslip std).
    fn outputs_of(&self, sample: &OutputSample<N, Model::Extra>) -> RealOutputs {
        let scale = sample.covariance_scale;
        let scaled = OutputSample {
            covariance: sample.covariance * scale,
            ..*sample
        };
        let mut outputs = self.model.outputs(&scaled, &self.parameters);
        outputs.yaw_rate_offset_est = sample.yaw_rate_offset;
        outputs.ay_offset_est = sample.ay_calibration[0];
        if !Model::ESTIMATES_AY_GAIN {
            outputs.ay_gain_est = sample.ay_calibration[1];
        }
        if self.estimates_tyre_scale() {
            outputs
        } else {
            with_stiffness_consider(
                outputs,
                &self.parameters,
                self.model.rear_slip_angle_rate(sample),
                scale,
            )
        }
    }

    /// A held sample's estimate is stale and its stds overconfident, so they are replaced:
    /// the car's motion as the sensors measure it, rolling without tyre slip. The sideslip of
    /// the steering geometry with a std that says it is a guess; the measured speed (0
    /// standing, negative reversing) with at least the measurement's std; the measured yaw rate
    /// and wheel speeds with theirs (a wheel not measured rolls at the speed); the wheels' slip
    /// from those; slip angles of 0 (the geometry's sideslip is that of tyres without slip
    /// angle) and the steady turn's `ay = vx r`. Where nothing is measured the value stays.
    fn honest_held_outputs(&self, held: &OutputSample<N, Model::Extra>, values: &mut RealOutputs) {
        let measured = held.measured;
        values.sideslip_est = kinematic_sideslip(held.input[0], &self.parameters);
        values.sideslip_std = LOW_SPEED_SIDESLIP_STD;
        values.slip_angle_front_est = 0.0;
        values.slip_angle_rear_est = 0.0;
        if let Some(speed) = measured.speed {
            values.vx_est = speed.speed;
            values.vx_std = values.vx_std.max(speed.std);
            values.vy_est = speed.speed * values.sideslip_est.tan();
        }
        if let Some((yaw_rate, std)) = measured.yaw_rate {
            values.yaw_rate_est = yaw_rate;
            values.yaw_rate_std = std;
        }
        // Every point of the body moves at vx along its axis; the front wheel, steered by δ and
        // without slip angle, rolls at vx / cos δ.
        let along_front = 1.0 / held.input[0].cos();
        let radii = WheelRadii::of(&self.parameters);
        let axles = [(along_front, radii.front), (1.0, radii.rear)];
        let [front, rear] = [0, 1].map(|axle| {
            let (along, radius) = axles[axle];
            let rolling = measured
                .speed
                .map(|speed| (speed.speed * along / radius, speed.std * along / radius));
            measured.wheel_speeds[axle].or(rolling)
        });
        if let Some((omega, std)) = front {
            values.omega_front_est = omega;
            values.omega_front_std = std;
        }
        if let Some((omega, std)) = rear {
            values.omega_rear_est = omega;
            values.omega_rear_std = std;
        }
        // model A's guard (its parameters take the default)
        let slip = |omega: f64, (along, radius): (f64, f64)| {
            let wheel_velocity = values.vx_est * along;
            let divisor = guarded_speed(wheel_velocity, DEFAULT_LOW_SPEED_GUARD);
            longitudinal_slip(omega, radius, wheel_velocity, 1.0 / divisor)
        };
        values.slip_front_est = slip(values.omega_front_est, axles[0]);
        values.slip_rear_est = slip(values.omega_rear_est, axles[1]);
        values.ay_est = values.vx_est * values.yaw_rate_est;
    }

    /// Forgets the outputs not yet computed (they were published before a state was taken).
    pub fn forget_pending(&mut self) {
        self.pending.clear();
    }
}

/// The rear stiffness's consider term of the sideslip, `σ |αR|` (see [`with_stiffness_consider`]),
/// rad; `rear_slip_angle` αR in rad.
pub(crate) fn stiffness_consider(v: &Variables, rear_slip_angle: f64) -> f64 {
    v.cornering_stiffness_uncertainty * rear_slip_angle.abs()
}

/// Model A's sideslip rests on its rear tyre law: in a steady corner the yaw rate and `ay` fix
/// the rear axle's force `Fyr`, and the sideslip follows from the rear slip angle
/// `αR = Fyr / CαR` (000: 5.16-5.22, 5.70), so a relative error `ε` of the rear cornering
/// stiffness moves the sideslip by `−ε αR` (and `vy` by `vx` times that), an error no sensor
/// reveals and the filter's covariance does not contain. `cornering_stiffness_uncertainty` = σ
/// is that error's standard deviation; its first-order effect `σ |αR|` is added in quadrature
/// to the reported standard deviations, the consider covariance of a parameter left
/// unestimated (Schmidt 1966; Tapley, Schutz and Born, Statistical Orbit Determination, 2004,
/// sect. 6.3). The estimate itself is unchanged, but for the speed filter both models report
/// `vx` from, which weighs the lateral estimate's reported uncertainty
/// ([`crate::speed_filter::SpeedSample::prediction_variance`]). Model B's sideslip rests on
/// its rear slip angle the same way (001: eq 5), so the runner adds the term to both models'
/// outputs ([`Runner::publish`]). The grip model's EKF and UKFs estimate the scale of its tyre law
/// and leave it out (measured: fmu-src/estimation/README.md, "Grip states").
///
/// A second term for what model A leaves out of the tyre, its lag, where the model gives the
/// slip angle's rate ([`EstimationModel::rear_slip_angle_rate`]): a car's tyre builds its side
/// force over its relaxation length `σr` (`tyre_relaxation_length`; Pacejka, Tyre and Vehicle
/// Dynamics, 3rd ed., 2012, sect. 7.2.1), so while the slip angle moves at `α̇` the force is
/// that of the slip angle about `(σr / |vx|) α̇` earlier, and model A, whose force is
/// instantaneous, puts the difference into its sideslip: `(σr / |vx|) |α̇R|`, added in
/// quadrature with the first, while σ > 0 (σ = 0 reports the filter's covariance alone, as
/// the seeds' scenarios set). Measured on the mismatch campaigns (harness robustness, model A's
/// 90 rows, σ 0.25): rows with a NEES in 0.5-2 and 90 % inside 43 → 50, rows above it 37 → 17
/// (fmu-src/vehicle-state-estimator/README.md, "Model A's tyre lag"). Model B leaves it out:
/// tried offline on its recorded estimates, its rows in the band went 29 → 11-24, its
/// `ay_model_error` already widening its covariance in the transients.
///
/// `covariance_scale` multiplies the term's variance as it does the covariance's
/// ([`OutputSample::covariance_scale`]).
pub(crate) fn with_stiffness_consider(
    mut values: RealOutputs,
    v: &Variables,
    rear_slip_angle_rate: Option<f64>,
    covariance_scale: f64,
) -> RealOutputs {
    let stiffness = stiffness_consider(v, values.slip_angle_rear_est);
    if !(stiffness > 0.0 && stiffness.is_finite()) {
        return values;
    }
    let lag = rear_slip_angle_rate
        .map(|rate| v.tyre_relaxation_length / values.vx_est.abs() * rate.abs())
        .filter(|lag| lag.is_finite())
        .unwrap_or(0.0);
    let sideslip_consider = stiffness.hypot(lag) * covariance_scale.sqrt();
    let lateral_velocity_consider = values.vx_est.abs() * sideslip_consider;
    values.sideslip_std = values.sideslip_std.hypot(sideslip_consider);
    values.vy_std = values.vy_std.hypot(lateral_velocity_consider);
    values
}
