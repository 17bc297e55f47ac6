//! Sensors as a car has them (issue 13, point 5), in front of the seeds' noise chain: gravity in
//! the accelerometers, bias and drifting bias, wheel speeds from counted tone-ring teeth; and
//! channel dropouts behind it. Every effect is off by default, and while off draws no random
//! number and changes no value, so the seeds' runs stay bit-identical.

use fmi_export::{StateError, StateReader, StateWriter};
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use vehicle_models::full_vehicle::GRAVITY;

use crate::model_description::Variables;

/// Number of sensor signals: `[yaw_rate, ay, omega_front, omega_rear, ax, vx]`.
pub(crate) const SENSORS: usize = 6;
/// Positions in the sensor arrays.
pub(crate) mod channel {
    pub const YAW_RATE: usize = 0;
    pub const AY: usize = 1;
    pub const OMEGA_FRONT: usize = 2;
    pub const OMEGA_REAR: usize = 3;
    pub const AX: usize = 4;
}
/// The channels with a bias (gyro and accelerometers), in this order in the bias arrays.
const BIASED: [usize; 3] = [channel::YAW_RATE, channel::AY, channel::AX];
/// The wheel-speed channels that tooth counting measures.
const WHEEL_CHANNELS: [usize; 2] = [channel::OMEGA_FRONT, channel::OMEGA_REAR];

/// The road and body attitude the accelerometers feel gravity through, rad.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Attitude {
    /// Body roll relative to the road, positive right side down.
    pub roll: f64,
    /// Road bank, positive when the right edge is lower.
    pub bank: f64,
    /// Road grade, positive uphill.
    pub grade: f64,
}

/// Wheel speed from counting the tone ring's teeth over a window, as an ABS sensor does: the
/// wheel's angle is integrated, the teeth that passed in the window divided by its length.
#[derive(Clone, Debug)]
struct ToothCounter {
    /// Angle between two teeth, rad.
    tooth_angle: f64,
    /// Counting window of each wheel: its channel's sample period (at least one step).
    window: [f64; 2],
    angle: [f64; 2],
    window_start_angle: [f64; 2],
    window_elapsed: [f64; 2],
    measured: [f64; 2],
}

impl ToothCounter {
    fn count(&mut self, true_speed: [f64; 2], dt: f64) -> [f64; 2] {
        for (i, speed) in true_speed.into_iter().enumerate() {
            self.window_elapsed[i] += dt;
            self.angle[i] += speed * dt;
            if self.window_elapsed[i] >= self.window[i] * (1.0 - 1e-9) {
                let teeth = (self.angle[i] / self.tooth_angle).floor()
                    - (self.window_start_angle[i] / self.tooth_angle).floor();
                self.measured[i] = teeth * self.tooth_angle / self.window_elapsed[i];
                self.window_start_angle[i] = self.angle[i];
                self.window_elapsed[i] = 0.0;
            }
        }
        self.measured
    }
}

/// The effects in front of the noise chain.
#[derive(Clone, Debug)]
pub(crate) struct SensorEffects {
    bias: [f64; 3],
    /// Random-walk intensity of each bias, per √s.
    drift_intensity: [f64; 3],
    /// The drifted part of each bias (evolves).
    drift: [f64; 3],
    gravity: bool,
    teeth: Option<ToothCounter>,
}

impl SensorEffects {
    /// `sample_period` is each channel's sample period (the wheels count over theirs).
    pub fn new(
        v: &Variables,
        sample_period: &[f64; SENSORS],
        integration_step: f64,
        true_wheel_speed: [f64; 2],
    ) -> Self {
        let teeth = u32::try_from(v.wheel_speed_teeth).unwrap_or(0);
        Self {
            bias: [v.bias_yaw_rate_meas, v.bias_ay_meas, v.bias_ax_meas],
            drift_intensity: [v.drift_yaw_rate_meas, v.drift_ay_meas, v.drift_ax_meas],
            drift: [0.0; 3],
            gravity: v.gravity_in_accelerometers,
            teeth: (teeth > 0).then(|| ToothCounter {
                tooth_angle: std::f64::consts::TAU / f64::from(teeth),
                window: WHEEL_CHANNELS.map(|i| sample_period[i].max(integration_step)),
                angle: [0.0; 2],
                window_start_angle: [0.0; 2],
                window_elapsed: [0.0; 2],
                measured: true_wheel_speed,
            }),
        }
    }

    /// What the sensors sense of the true values after a step of `dt` (the drift advances).
    pub fn apply(
        &mut self,
        values: &mut [f64; SENSORS],
        attitude: Attitude,
        dt: f64,
        rng: &mut ChaCha20Rng,
    ) {
        self.advance_drift(dt, rng);
        self.sense(values, attitude);
        if let Some(counter) = &mut self.teeth {
            let measured = counter.count(WHEEL_CHANNELS.map(|i| values[i]), dt);
            for (i, value) in WHEEL_CHANNELS.into_iter().zip(measured) {
                values[i] = value;
            }
        }
    }

    /// Bias random walk: `b += q √dt N(0, 1)` per step (a Wiener process of intensity `q`).
    fn advance_drift(&mut self, dt: f64, rng: &mut ChaCha20Rng) {
        for (drift, intensity) in self.drift.iter_mut().zip(self.drift_intensity) {
            if intensity > 0.0 {
                let draw: f64 = StandardNormal.sample(rng);
                *drift += intensity * dt.sqrt() * draw;
            }
        }
    }

    /// Gravity and bias, without advancing anything (also for the initial outputs).
    pub fn sense(&self, values: &mut [f64; SENSORS], attitude: Attitude) {
        if self.gravity {
            // A body-fixed accelerometer measures the specific force a − g (Groves, Principles of
            // GNSS, Inertial, and Multisensor Integrated Navigation Systems, 2nd ed., 2013,
            // ch. 4). In the road plane (where ax, ay are the accelerations) gravity
            // contributes g sin(grade) along x, g sin(bank) along y and g cos(bank) normal to the
            // road; the body's roll turns the sensor's y axis towards that normal.
            let (sin_roll, cos_roll) = attitude.roll.sin_cos();
            let (sin_bank, cos_bank) = attitude.bank.sin_cos();
            let lateral = values[channel::AY] + GRAVITY * sin_bank;
            values[channel::AY] = lateral * cos_roll + GRAVITY * cos_bank * sin_roll;
            values[channel::AX] += GRAVITY * attitude.grade.sin();
        }
        for (k, i) in BIASED.into_iter().enumerate() {
            if self.bias[k] != 0.0 || self.drift[k] != 0.0 {
                values[i] += self.bias[k] + self.drift[k];
            }
        }
    }

    /// What the sensors sense now without advancing anything: gravity and bias as in
    /// [`SensorEffects::sense`], and the wheel speeds the tooth counter counted last.
    pub fn sense_held(&self, values: &mut [f64; SENSORS], attitude: Attitude) {
        self.sense(values, attitude);
        if let Some(counter) = &self.teeth {
            for (i, value) in WHEEL_CHANNELS.into_iter().zip(counter.measured) {
                values[i] = value;
            }
        }
    }

    pub fn write_state(&self, writer: &mut StateWriter) {
        writer.f64s(&self.drift);
        if let Some(counter) = &self.teeth {
            writer.f64s(&counter.angle);
            writer.f64s(&counter.window_start_angle);
            writer.f64s(&counter.window_elapsed);
            writer.f64s(&counter.measured);
        }
    }

    pub fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        reader.f64s_into(&mut self.drift, "sensor drift")?;
        if let Some(counter) = &mut self.teeth {
            reader.f64s_into(&mut counter.angle, "wheel angle")?;
            reader.f64s_into(&mut counter.window_start_angle, "tooth window start")?;
            reader.f64s_into(&mut counter.window_elapsed, "tooth window length")?;
            reader.f64s_into(&mut counter.measured, "counted wheel speed")?;
        }
        Ok(())
    }
}

/// Channels that drop out for a time: NaN, or the last value before (stale).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dropout {
    channels: u32,
    start: f64,
    end: f64,
    hold_last: bool,
}

impl Dropout {
    pub fn new(v: &Variables) -> Result<Self, String> {
        let channels = u32::try_from(v.dropout_channels)
            .ok()
            .filter(|mask| *mask < 1 << SENSORS)
            .ok_or_else(|| {
                format!(
                    "parameter dropout_channels = {}; expected a sum of 1, 2, 4, 8, 16, 32",
                    v.dropout_channels
                )
            })?;
        Ok(Self {
            channels,
            start: v.dropout_start,
            end: v.dropout_start + v.dropout_duration,
            hold_last: v.dropout_hold_last,
        })
    }

    /// The value channel `index` shows at `time` with the `sensor_blanking` input `blanking`:
    /// the sensor's, NaN, or `last` (stale).
    pub fn shown(&self, index: usize, time: f64, blanking: i32, value: f64, last: f64) -> f64 {
        let bit = 1 << index;
        let out = (self.channels & bit != 0 && time >= self.start && time < self.end)
            || blanking & bit as i32 != 0;
        match (out, self.hold_last) {
            (false, _) => value,
            (true, true) => last,
            (true, false) => f64::NAN,
        }
    }
}
