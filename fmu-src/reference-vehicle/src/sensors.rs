//! Sensors as a car has them, in front of the seeds' noise chain: gravity in the accelerometers,
//! bias and drifting bias, the body's vibration on the accelerometers, wheel speeds from counted
//! tone-ring teeth; and behind it, channel dropouts and samples a logger loses. Every effect is
//! off by default, and while off draws no random number and changes no value, so the seeds' runs
//! stay bit-identical.

use fmi_export::{StateError, StateReader, StateWriter};
use rand::Rng;
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
/// The channels the body's vibration reaches (the accelerometers), in this order in the vibration
/// arrays.
const VIBRATING: [usize; 2] = [channel::AY, channel::AX];
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

/// The body's vibration as an accelerometer feels it (engine, road, wheels): white noise through
/// a band-pass of two first-order high-pass sections at `vibration_low_frequency` and two
/// first-order low-pass sections at `vibration_high_frequency` (each the exact discretisation of
/// its continuous section, `a = exp(−2π f dt)`), scaled so that the output's standard deviation
/// is the parameter's RMS. Advanced once per integration step; independent per axis.
#[derive(Clone, Debug)]
struct Vibration {
    /// RMS per axis `[ay, ax]`, m/s²; 0 = off.
    rms: [f64; 2],
    high_pass: f64,
    low_pass: f64,
    /// `1 / sqrt(Σ h_k²)` of the band-pass's impulse response: unit output variance.
    unit_gain: f64,
    /// Per axis: `[previous input, high-pass 1, high-pass 2, low-pass 1, low-pass 2]`.
    filters: [[f64; 5]; 2],
}

impl Vibration {
    fn new(v: &Variables, integration_step: f64) -> Self {
        // Below the Nyquist frequency of the integration step, with room for the low-pass.
        let high = v
            .vibration_high_frequency
            .min(0.4 / integration_step)
            .max(v.vibration_low_frequency);
        let coefficient =
            |frequency: f64| (-std::f64::consts::TAU * frequency * integration_step).exp();
        let mut vibration = Self {
            rms: [v.vibration_std_ay_meas, v.vibration_std_ax_meas].map(|rms| rms.max(0.0)),
            high_pass: coefficient(v.vibration_low_frequency),
            low_pass: coefficient(high),
            unit_gain: 1.0,
            filters: [[0.0; 5]; 2],
        };
        if vibration.rms.iter().any(|rms| *rms > 0.0) {
            vibration.unit_gain = 1.0 / vibration.impulse_energy().sqrt();
        }
        vibration
    }

    /// One step of the band-pass for the input `input`.
    fn filter(&self, state: &mut [f64; 5], input: f64) {
        let [previous, high_1, high_2, low_1, low_2] = *state;
        let new_high_1 = self.high_pass * (high_1 + input - previous);
        let new_high_2 = self.high_pass * (high_2 + new_high_1 - high_1);
        let new_low_1 = self.low_pass * low_1 + (1.0 - self.low_pass) * new_high_2;
        let new_low_2 = self.low_pass * low_2 + (1.0 - self.low_pass) * new_low_1;
        *state = [input, new_high_1, new_high_2, new_low_1, new_low_2];
    }

    /// `Σ h_k²` of the band-pass's impulse response, summed until the slower section has decayed
    /// to 1e-12 of its start (a white input of unit variance gives this output variance).
    fn impulse_energy(&self) -> f64 {
        let slowest = self.high_pass.max(self.low_pass);
        let steps = (27.6 / -slowest.ln()).ceil().max(16.0) as usize + 16;
        let mut state = [0.0; 5];
        let mut energy = 0.0;
        for k in 0..steps * 2 {
            self.filter(&mut state, if k == 0 { 1.0 } else { 0.0 });
            energy += state[4] * state[4];
        }
        energy
    }

    fn advance(&mut self, rng: &mut ChaCha20Rng) {
        for axis in 0..2 {
            if self.rms[axis] > 0.0 {
                let draw: f64 = StandardNormal.sample(rng);
                let mut state = self.filters[axis];
                self.filter(&mut state, draw);
                self.filters[axis] = state;
            }
        }
    }

    /// The vibration on axis `axis` now, m/s².
    fn value(&self, axis: usize) -> f64 {
        self.rms[axis] * self.unit_gain * self.filters[axis][4]
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
    vibration: Vibration,
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
            vibration: Vibration::new(v, integration_step),
        }
    }

    /// What the sensors sense of the true values after a step of `dt` (the drift advances).
    pub fn apply(
        &mut self,
        values: &mut [f64; SENSORS],
        attitude: Attitude,
        dt: f64,
        rng: &mut ChaCha20Rng,
        fault_rng: &mut ChaCha20Rng,
    ) {
        self.advance_drift(dt, rng);
        self.vibration.advance(fault_rng);
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
        for (axis, i) in VIBRATING.into_iter().enumerate() {
            if self.vibration.rms[axis] > 0.0 {
                values[i] += self.vibration.value(axis);
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
        for filter in &self.vibration.filters {
            writer.f64s(filter);
        }
        if let Some(counter) = &self.teeth {
            writer.f64s(&counter.angle);
            writer.f64s(&counter.window_start_angle);
            writer.f64s(&counter.window_elapsed);
            writer.f64s(&counter.measured);
        }
    }

    pub fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        reader.f64s_into(&mut self.drift, "sensor drift")?;
        for filter in self.vibration.filters.iter_mut() {
            reader.f64s_into(filter, "accelerometer vibration filter")?;
        }
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

    /// The value channel `index` shows at `time` with the `sensor_blanking` input `blanking`
    /// while a logger's gap `dropped` lasts or not: the sensor's, NaN, or `last` (stale).
    pub fn shown(
        &self,
        index: usize,
        time: f64,
        blanking: i32,
        dropped: bool,
        value: f64,
        last: f64,
    ) -> f64 {
        let bit = 1 << index;
        let out = (self.channels & bit != 0 && time >= self.start && time < self.end)
            || blanking & bit as i32 != 0
            || dropped;
        match (out, self.hold_last) {
            (false, _) => value,
            (true, true) => last,
            (true, false) => f64::NAN,
        }
    }
}

/// Samples a logger or bus loses: gaps in which every channel drops out together, starting at
/// random instants (a Bernoulli trial per integration step, the discrete Poisson process) with
/// lengths uniform in `(0, max_gap]`; a gap starts no sooner than `max_gap` after the last one
/// ended, so that no two merge into a longer one. A renewal process: with the gaps' mean length
/// `E[gap] = max_gap / 2`, the start rate `λ = 1 / (E[gap] (1/f − 1) − max_gap)` makes the
/// long-run share of time in gaps, and so of the samples dropped, `f` (`sample_drop_fraction`).
#[derive(Clone, Debug)]
pub(crate) struct SampleDrops {
    /// Chance that a gap starts in one integration step of the nominal length.
    start_chance: f64,
    max_gap: f64,
    /// `[start, end)` of the current or last gap.
    gap: [f64; 2],
}

impl SampleDrops {
    /// None when `sample_drop_fraction` is 0.
    pub fn new(v: &Variables, integration_step: f64) -> Option<Self> {
        let fraction = v.sample_drop_fraction;
        (fraction > 0.0).then(|| {
            let max_gap = v.sample_drop_max_gap;
            let waiting = 0.5 * max_gap * (1.0 / fraction - 1.0) - max_gap;
            Self {
                start_chance: if waiting > integration_step {
                    integration_step / waiting
                } else {
                    1.0
                },
                max_gap,
                gap: [f64::NEG_INFINITY; 2],
            }
        })
    }

    /// After a step that ended at `time`: a new gap may start there if none lasts.
    pub fn advance(&mut self, time: f64, rng: &mut ChaCha20Rng) {
        if time < self.gap[1] + self.max_gap {
            return;
        }
        let trial: f64 = rng.random();
        if trial < self.start_chance {
            // (0, 1]: a gap is never empty
            let length = 1.0 - rng.random::<f64>();
            self.gap = [time, time + length * self.max_gap];
        }
    }

    /// Whether the samples at `time` are lost.
    pub fn dropped(&self, time: f64) -> bool {
        time >= self.gap[0] && time < self.gap[1]
    }

    pub fn write_state(&self, writer: &mut StateWriter) {
        writer.f64s(&self.gap);
    }

    pub fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        reader.f64s_into(&mut self.gap, "dropped-sample gap")
    }
}
