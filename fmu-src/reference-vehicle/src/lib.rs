//! FMU **ReferenceVehicle**: the "true" planar motion of a car and its corrupted series-production
//! sensor signals, as an FMI 2.0 Co-Simulation FMU (modelIdentifier `ReferenceVehicle`).
//!
//! The interface is modelDescription/ReferenceVehicle.xml (variables, units, sign conventions);
//! the value references, GUID and start values are generated from it at build time.
//!
//! - **Vehicle.** Model A (`model = 1`): the 5-state single-track model with HSRI tyres of seed
//!   000; model B (`model = 2`): the 7-state two-track model with roll-moment load transfer and
//!   Magic Formula tyres of seed 001, the same car (the vehicle parameters apply to both; the
//!   Magic Formula tyre is matched to the HSRI `tyre_*` parameters). Both come from the
//!   `vehicle-models` crate's switchable reference vehicle, discretised with the seed-000 scheme
//!   (000: 6.1-6.5) or RK4 (`integrator`), and report the same truth (model B: axle values are
//!   the mean of left and right wheel). Model 3 (`model = 3`): the full vehicle of
//!   `vehicle_models::full_vehicle` (roll, load transfer, four wheel spins, combined-slip MF 5.2
//!   tyres, drivetrains, standstill), parameterised by the shared vehicle parameters and its own
//!   (`cog_height` … `tyre_rear_*`, mapped once in `vehicle_models::parameters`), driven also by
//!   the `road_friction` input; it reports roll and the four wheels' speeds and loads (module
//!   `vehicle`). The car starts driving straight at `vx0` with freely rolling wheels. The cars
//!   of `vehicle-models/cars/*.toml` ship as SSP parameter-value files, `cars/*.ssv`.
//! - **Sub-stepping.** A doStep of length `h` runs `n = ceil(h / integration_step)` equal steps
//!   of `h / n`, holding the driver inputs (a non-finite input keeps its last finite value and
//!   the step answers fmi2Warning).
//! - **Process noise** (seed 000, ch. 7; models 1 and 2 only): after every integration step, Gaussian noise with the
//!   standard deviations `process_noise_std_*` (scaled by `sqrt(dt / integration_step)` when a
//!   step is shorter) is added to `[vx, vy, r, ωF, ωR]` (model B: `[vx, vy, r, ωFL, ωFR, ωRL,
//!   ωRR]`, each wheel with its axle's standard deviation).
//! - **Sensor chain** (seed 000 ch. 7 noise; seed 001 CAN-like corruption; the sensors of a series car),
//!   per integration step and per signal, in this order: true value → what the sensor senses
//!   (gravity through roll, bank and grade; bias and its random-walk drift; wheel speed from
//!   counted teeth; module `sensors`) → + white Gaussian noise → quantisation
//!   (rounding to a multiple of `quantum_*`) → transport delay of `sensor_latency` (whole
//!   integration steps) → sample-and-hold every `sensor_sample_period` (sample instants
//!   `t0 + k·period`) → dropout of chosen channels for a time, or while the `sensor_blanking`
//!   input names them (NaN or stale). Each channel may have its own period and delay
//!   (`sample_period_*`, `latency_*`; -1 = the common value), as the messages of a car's CAN
//!   buses have. The chain starts primed with the noise-free initial values. Real sensors'
//!   faults join it: the body's band-limited vibration on the accelerometers (in front of the
//!   noise), sample instants jittered around their latency (`sample_jitter`) and samples a
//!   logger loses in gaps (`sample_drop_*`, behind the dropouts); their draws come from the
//!   seed's second stream, so switching one on leaves every other draw as it was. Every sensor
//!   effect is off by default.
//! - **Direct feed-through**: when the master sets new inputs at a communication point, the
//!   outputs that depend on them (ModelStructure) are re-evaluated at that instant before they
//!   are read (`refresh_outputs`); see harness/scenarios/README.md, "Direct feed-through".
//! - `noise = false` switches off process noise, noise, quantisation, sampling and latency; the
//!   `*_meas` outputs then equal what the sensors sense (the truth, unless an issue-13 effect is
//!   on).
//! - **Randomness** comes from one ChaCha20 generator seeded with `seed`; its position is part
//!   of the FMU state, so the same parameters and seed give bit-identical outputs in any master
//!   and thread, and a restored state continues bit-identically.
//! - A step whose state turns non-finite answers fmi2Discard (the outputs keep their last
//!   values).
//!
#![allow(non_snake_case)] // the crate is named after the modelIdentifier

use fmi_export::{
    CoSimulationModel, InstantiationContext, StateError, StateReader, StateWriter, StepOutcome,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use vehicle_models::parameters::positive;
use vehicle_models::reference::MAX_STATE_DIM;
use vehicle_models::{DriverInputVector, ReferenceModelKind, VehicleTruth};

mod sensors;
mod vehicle;

use sensors::{Attitude, Dropout, SampleDrops, SensorEffects, SENSORS};
use vehicle::{Vehicle, WheelTruth};

/// Generated from modelDescription/ReferenceVehicle.xml.
pub mod model_description {
    include!(concat!(env!("OUT_DIR"), "/model_description.rs"));
}

use model_description::Variables;

/// The ChaCha20 stream of the sensor faults' draws (the seeds' noise uses stream 0).
const FAULT_STREAM: u64 = 1;

/// The generator of the sensor faults' draws for `seed`.
fn fault_generator(seed: u64) -> ChaCha20Rng {
    let mut generator = ChaCha20Rng::seed_from_u64(seed);
    generator.set_stream(FAULT_STREAM);
    generator
}

/// Longest delay line, in integration steps (sensor_latency <= 1 s, step >= 1e-5 s).
const MAX_LATENCY_STEPS: usize = 100_000;

/// The true sensor values `[r, ay, ωF, ωR, ax, vx]` of a truth record.
fn sensor_values(truth: &VehicleTruth) -> [f64; SENSORS] {
    [
        truth.yaw_rate,
        truth.lateral_acceleration,
        truth.omega_front,
        truth.omega_rear,
        truth.longitudinal_acceleration,
        truth.longitudinal_velocity,
    ]
}

/// Rounds to the nearest multiple of `quantum` (no quantisation when `quantum` is 0).
fn quantise(value: f64, quantum: f64) -> f64 {
    if quantum > 0.0 {
        (value / quantum).round() * quantum
    } else {
        value
    }
}

/// Standard deviations of the process noise on the states of the running model (the entries
/// beyond its state dimension are unused).
fn process_noise_std(vehicle: &Vehicle, v: &Variables) -> [f64; MAX_STATE_DIM] {
    let Vehicle::Planar { model, .. } = vehicle else {
        // model 3 is the detailed truth: no process noise
        return [0.0; MAX_STATE_DIM];
    };
    let (vx, vy, r, front, rear) = (
        v.process_noise_std_vx,
        v.process_noise_std_vy,
        v.process_noise_std_yaw_rate,
        v.process_noise_std_omega_front,
        v.process_noise_std_omega_rear,
    );
    match model.kind() {
        // [vx, vy, r, ωF, ωR] (000 ch. 7)
        ReferenceModelKind::SingleTrack => [vx, vy, r, front, rear, 0.0, 0.0],
        // [vx, vy, r, ωFL, ωFR, ωRL, ωRR]: seed 000 has no per-wheel noise, so each wheel of an
        // axle gets the axle's standard deviation, drawn independently (project choice).
        ReferenceModelKind::TwoTrack => [vx, vy, r, front, front, rear, rear],
    }
}

/// The standard deviations of the sensors' white noise, `[r, ay, ωF, ωR, ax, vx]`.
fn sensor_noise_std(v: &Variables) -> [f64; SENSORS] {
    [
        v.noise_std_yaw_rate_meas,
        v.noise_std_ay_meas,
        v.noise_std_omega_front_meas,
        v.noise_std_omega_rear_meas,
        v.noise_std_ax_meas,
        v.noise_std_vx_meas,
    ]
}

/// Everything that evolves during a simulation, built from the parameters at initialisation.
#[derive(Clone, Debug)]
struct Simulation {
    /// Model 1, 2 or 3 with its state (vehicle-models crate).
    vehicle: Vehicle,
    integration_step: f64,
    noise_on: bool,
    /// Standard deviations of the process noise on the first `state_dim` states.
    process_noise_std: [f64; MAX_STATE_DIM],
    sensor_noise_std: [f64; SENSORS],
    quantum: [f64; SENSORS],
    /// Per channel: sample period (0: every integration step) and delay in integration steps.
    timing: ChannelTiming,
    rng: ChaCha20Rng,
    /// The draws of the real sensors' faults (vibration, jitter, dropped samples): the same
    /// seed's stream [`FAULT_STREAM`], so switching a fault on leaves every other draw as it was.
    fault_rng: ChaCha20Rng,
    /// The driver input applied during the steps (last finite values).
    input: DriverInputVector,
    /// The road input `[road_friction, road_bank_angle, road_grade_angle]` (last finite values).
    road: [f64; ROAD_INPUTS],
    /// Gravity, bias, drift and tooth counting in front of the noise chain.
    effects: SensorEffects,
    dropout: Dropout,
    /// The samples a logger loses (`sample_drop_fraction`), None when off.
    drops: Option<SampleDrops>,
    /// Ring buffer of the longest channel delay + 1 corrupted samples; `delay_head` is the
    /// newest.
    delay_line: Vec<[f64; SENSORS]>,
    delay_head: usize,
    /// Sample-and-hold output of the sensor chain.
    held: [f64; SENSORS],
    /// The standard-normal draws of the newest delay-line entry, kept so that the entry can be
    /// re-evaluated with the inputs set at the communication point (`resample_at_inputs`).
    newest_draws: [f64; SENSORS],
    /// Per channel: whether the newest delay-line entry reached `held` at the end of the last
    /// step (no latency and a sample instant there).
    newest_is_held: [bool; SENSORS],
    next_sample_time: [f64; SENSORS],
    time: f64,
    /// The truth at the current state and input, computed once per integration step and reused
    /// by the outputs (model B's truth costs a load-transfer loop).
    truth: VehicleTruth,
    wheels: WheelTruth,
}

/// Number of road inputs.
const ROAD_INPUTS: usize = 3;

/// The input variables, driver then road, in the order of `Simulation::input` and `road`.
const INPUT_NAMES: [&str; 3 + ROAD_INPUTS] = [
    "steering_angle",
    "drive_torque",
    "brake_torque",
    "road_friction",
    "road_bank_angle",
    "road_grade_angle",
];

impl Simulation {
    /// Builds the simulation from the parameters and starts it at `start_time`.
    fn start(v: &Variables, start_time: f64) -> Result<Self, String> {
        let vehicle = Vehicle::build(v)?;
        let process_noise_std = process_noise_std(&vehicle, v);
        let integration_step = positive("integration_step", v.integration_step)?;
        let timing = ChannelTiming::new(v, integration_step)?;
        let seed = u64::try_from(v.seed)
            .map_err(|_| format!("parameter seed = {}; expected a value >= 0", v.seed))?;
        let input = DriverInputVector::new(
            finite_or(v.steering_angle, 0.0),
            finite_or(v.drive_torque, 0.0),
            finite_or(v.brake_torque, 0.0),
        );
        let road = [
            finite_or(v.road_friction, 1.0),
            finite_or(v.road_bank_angle, 0.0),
            finite_or(v.road_grade_angle, 0.0),
        ];
        let (truth, wheels) = vehicle.truth(&input);
        let mut sensed = sensor_values(&truth);
        let effects =
            SensorEffects::new(v, &timing.period, integration_step, [sensed[2], sensed[3]]);
        effects.sense(&mut sensed, attitude(&wheels, &road));
        let initial = quantised_sensors(
            &sensed,
            &[
                v.quantum_yaw_rate_meas,
                v.quantum_ay_meas,
                v.quantum_omega_front_meas,
                v.quantum_omega_rear_meas,
                v.quantum_ax_meas,
                v.quantum_vx_meas,
            ],
            v.noise,
        );
        Ok(Self {
            truth,
            wheels,
            road,
            effects,
            dropout: Dropout::new(v)?,
            drops: SampleDrops::new(v, integration_step),
            vehicle,
            integration_step,
            noise_on: v.noise,
            process_noise_std,
            sensor_noise_std: sensor_noise_std(v),
            quantum: [
                v.quantum_yaw_rate_meas,
                v.quantum_ay_meas,
                v.quantum_omega_front_meas,
                v.quantum_omega_rear_meas,
                v.quantum_ax_meas,
                v.quantum_vx_meas,
            ],
            rng: ChaCha20Rng::seed_from_u64(seed),
            fault_rng: fault_generator(seed),
            input,
            delay_line: vec![initial; timing.longest_delay() + 1],
            delay_head: 0,
            held: initial,
            newest_draws: [0.0; SENSORS],
            newest_is_held: timing.delay_steps.map(|steps| steps == 0),
            next_sample_time: timing.period.map(|period| start_time + period),
            timing,
            time: start_time,
        })
    }

    /// One integration step of length `dt` with the current input, then the sensor chain.
    fn integration_step(&mut self, dt: f64) -> Result<(), String> {
        // The input holds only finite values and brake_torque >= 0 (its min), so an error here
        // is a non-finite state; the step is then not applied.
        self.vehicle
            .step(&self.input, &self.road, dt)
            .map_err(|error| {
                format!(
                    "the vehicle step at t = {} failed: {error}; the model left its valid range",
                    self.time
                )
            })?;
        if let (true, Some(planar)) = (self.noise_on, self.vehicle.planar_mut()) {
            // Process noise per T_ref step (000 ch. 7); a shorter step gets the Wiener scaling.
            let scale = if dt == self.integration_step {
                1.0
            } else {
                (dt / self.integration_step).sqrt()
            };
            for (value, std) in planar
                .state_mut()
                .iter_mut()
                .zip(self.process_noise_std.iter())
            {
                let draw: f64 = StandardNormal.sample(&mut self.rng);
                *value += draw * std * scale;
            }
        }
        if let Some(name) = self.vehicle.non_finite_state() {
            return Err(format!(
                "the vehicle state {name} became non-finite at t = {}; the model left its valid range",
                self.time + dt
            ));
        }
        self.time += dt;
        if let Some(drops) = &mut self.drops {
            drops.advance(self.time, &mut self.fault_rng);
        }
        (self.truth, self.wheels) = self.vehicle.truth(&self.input);
        let mut truth = sensor_values(&self.truth);
        self.effects.apply(
            &mut truth,
            attitude(&self.wheels, &self.road),
            dt,
            &mut self.rng,
            &mut self.fault_rng,
        );
        if !self.noise_on {
            self.held = truth;
            return Ok(());
        }
        for draw in self.newest_draws.iter_mut() {
            *draw = StandardNormal.sample(&mut self.rng);
        }
        let length = self.delay_line.len();
        self.delay_head = (self.delay_head + 1) % length;
        self.delay_line[self.delay_head] = self.corrupted(&truth);
        for i in 0..SENSORS {
            let delay = self.timing.delay_steps[i];
            let sampled = sample_due(
                &mut self.next_sample_time[i],
                self.timing.period[i],
                self.time,
            );
            let delay = if sampled {
                self.timing.jittered(delay, &mut self.fault_rng)
            } else {
                delay
            };
            if sampled {
                // The entry `delay` steps behind the head (ring buffer).
                self.held[i] = self.delay_line[(self.delay_head + length - delay) % length][i];
            }
            self.newest_is_held[i] = sampled && delay == 0;
        }
        Ok(())
    }

    /// A sensed sample with the newest draws of white noise, quantised (seed 000 ch. 7 noise,
    /// seed 001 quantisation).
    fn corrupted(&self, sensed: &[f64; SENSORS]) -> [f64; SENSORS] {
        std::array::from_fn(|i| {
            quantise(
                sensed[i] + self.newest_draws[i] * self.sensor_noise_std[i],
                self.quantum[i],
            )
        })
    }

    /// Takes the driver and road inputs as the master set them (a non-finite value keeps the
    /// last finite one and is named in the returned warning); true when any value changed.
    fn take_inputs(&mut self, requested: [f64; 3 + ROAD_INPUTS]) -> (bool, Option<String>) {
        let (mut changed, mut warning) = (false, None);
        for (i, value) in requested.into_iter().enumerate() {
            let held = if i < 3 {
                &mut self.input[i]
            } else {
                &mut self.road[i - 3]
            };
            if !value.is_finite() {
                warning = Some(format!(
                    "input {} is {value}; the last finite value {held} is held",
                    INPUT_NAMES[i]
                ));
            } else if value.to_bits() != held.to_bits() {
                *held = value;
                changed = true;
            }
        }
        (changed, warning)
    }

    /// Re-evaluates what depends directly on the inputs at the current instant, after the
    /// master set new inputs at a communication point: the truth (models 1 and 2: `ay`, `ax`
    /// and the front tyre's slips depend on the steering angle through 000: 5.63) and the
    /// sensor sample taken at this instant (the accelerometers' gravity also depends on the
    /// road's bank and grade). The state, the random draws, the drift and the tooth counter stay
    /// as the step left them, so this is the same sample seen with the inputs of `t_n`, as
    /// `y(k) = h(x(k), u(k))` (000: 4.99-4.102) has it; the reasons are in
    /// harness/scenarios/README.md, "Direct feed-through".
    fn resample_at_inputs(&mut self) {
        (self.truth, self.wheels) = self.vehicle.truth(&self.input);
        let mut sensed = sensor_values(&self.truth);
        self.effects
            .sense_held(&mut sensed, attitude(&self.wheels, &self.road));
        if !self.noise_on {
            self.held = sensed;
            return;
        }
        let corrupted = self.corrupted(&sensed);
        self.delay_line[self.delay_head] = corrupted;
        for ((held, value), newest) in self.held.iter_mut().zip(corrupted).zip(self.newest_is_held)
        {
            if newest {
                *held = value;
            }
        }
    }

    fn write_state(&self, writer: &mut StateWriter) {
        self.vehicle.write_state(writer);
        writer.f64s(self.input.as_slice());
        writer.f64s(&self.road);
        for byte in self.rng.get_seed() {
            writer.u8(byte);
        }
        writer.u64(self.rng.get_stream());
        let word_position = self.rng.get_word_pos();
        writer.u64(word_position as u64);
        writer.u64((word_position >> 64) as u64);
        writer.u64(self.delay_line.len() as u64);
        for entry in &self.delay_line {
            writer.f64s(entry);
        }
        writer.u64(self.delay_head as u64);
        writer.f64s(&self.held);
        writer.f64s(&self.newest_draws);
        for held in self.newest_is_held {
            writer.bool(held);
        }
        writer.f64s(&self.next_sample_time);
        writer.f64(self.time);
        self.effects.write_state(writer);
        if let Some(drops) = &self.drops {
            drops.write_state(writer);
        }
        let fault_position = self.fault_rng.get_word_pos();
        writer.u64(fault_position as u64);
        writer.u64((fault_position >> 64) as u64);
    }

    fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        self.vehicle.read_state(reader)?;
        reader.f64s_into(self.input.as_mut_slice(), "driver input")?;
        reader.f64s_into(&mut self.road, "road input")?;
        let mut seed = [0u8; 32];
        for byte in seed.iter_mut() {
            *byte = reader.u8("random generator seed")?;
        }
        let stream = reader.u64("random generator stream")?;
        let low = reader.u64("random generator position")?;
        let high = reader.u64("random generator position")?;
        self.rng = ChaCha20Rng::from_seed(seed);
        self.rng.set_stream(stream);
        self.rng
            .set_word_pos(u128::from(low) | (u128::from(high) << 64));
        let length = reader.u64("delay line length")?;
        if length != self.delay_line.len() as u64 {
            return Err(StateError::new(format!(
                "the delay line has {length} entries in the serialized state; the parameters give {}",
                self.delay_line.len()
            )));
        }
        for entry in self.delay_line.iter_mut() {
            reader.f64s_into(entry, "delay line")?;
        }
        let head = reader.u64("delay line head")?;
        if head >= length {
            return Err(StateError::new(format!(
                "delay line head {head} is outside the {length} entries"
            )));
        }
        self.delay_head = head as usize;
        reader.f64s_into(&mut self.held, "held sensor values")?;
        reader.f64s_into(&mut self.newest_draws, "newest noise draws")?;
        for held in self.newest_is_held.iter_mut() {
            *held = reader.bool("newest sample held")?;
        }
        reader.f64s_into(&mut self.next_sample_time, "next sample times")?;
        self.time = reader.f64("simulation time")?;
        self.effects.read_state(reader)?;
        if let Some(drops) = &mut self.drops {
            drops.read_state(reader)?;
        }
        let low = reader.u64("fault generator position")?;
        let high = reader.u64("fault generator position")?;
        self.fault_rng = ChaCha20Rng::from_seed(seed);
        self.fault_rng.set_stream(FAULT_STREAM);
        self.fault_rng
            .set_word_pos(u128::from(low) | (u128::from(high) << 64));
        (self.truth, self.wheels) = self.vehicle.truth(&self.input);
        Ok(())
    }
}

/// Roll, bank and grade, for the accelerometers' gravity components.
fn attitude(wheels: &WheelTruth, road: &[f64; ROAD_INPUTS]) -> Attitude {
    Attitude {
        roll: wheels.roll_angle,
        bank: road[1],
        grade: road[2],
    }
}

/// Whether a sample is taken at `time` on a channel sampled every `period` (0: at every
/// integration step), advancing `next` past `time` if so.
fn sample_due(next: &mut f64, period: f64, time: f64) -> bool {
    if period <= 0.0 {
        return true;
    }
    let tolerance = 1e-9 * period;
    if time < *next - tolerance {
        return false;
    }
    // Whole periods past the current time, in one step: a loop adding the period would never
    // end where the period is below the clock's resolution.
    let periods = ((time + tolerance - *next) / period).floor() + 1.0;
    *next += periods * period;
    if *next <= time {
        *next = time + period;
    }
    true
}

/// The CAN timing of each sensor channel (yaw rate, ay, wheel speeds, ax and
/// vx come in different messages at different rates): the channel's own parameter, or the
/// common `sensor_sample_period` / `sensor_latency` where it is -1.
#[derive(Clone, Copy, Debug)]
struct ChannelTiming {
    /// Sample period, s (0: every integration step).
    period: [f64; SENSORS],
    /// Transport delay in whole integration steps.
    delay_steps: [usize; SENSORS],
    /// Largest time-stamp error of a sample (`sample_jitter`) in whole integration steps.
    jitter_steps: usize,
}

impl ChannelTiming {
    fn new(v: &Variables, integration_step: f64) -> Result<Self, String> {
        let periods = channel_periods(v);
        let latencies = [
            ("latency_yaw_rate_meas", v.latency_yaw_rate_meas),
            ("latency_ay_meas", v.latency_ay_meas),
            ("latency_omega_front_meas", v.latency_omega_front_meas),
            ("latency_omega_rear_meas", v.latency_omega_rear_meas),
            ("latency_ax_meas", v.latency_ax_meas),
            ("latency_vx_meas", v.latency_vx_meas),
        ];
        for (name, own) in OWN_PERIOD_NAMES.into_iter().zip(own_periods(v)) {
            if own != -1.0 && !(0.0..=1.0).contains(&own) {
                return Err(format!(
                    "parameter {name} = {own}; expected -1 (sensor_sample_period) or 0 to 1 s"
                ));
            }
        }
        let mut delay_steps = [0; SENSORS];
        for (steps, (name, own)) in delay_steps.iter_mut().zip(latencies) {
            let (name, latency) = if own == -1.0 {
                ("sensor_latency", v.sensor_latency)
            } else {
                (name, own)
            };
            let whole = (latency / integration_step).round();
            if !(0.0..=MAX_LATENCY_STEPS as f64).contains(&whole) {
                return Err(format!(
                    "parameter {name} = {latency} is {whole} integration steps; expected 0 to {MAX_LATENCY_STEPS}"
                ));
            }
            *steps = whole as usize;
        }
        let jitter = (v.sample_jitter / integration_step).round();
        if !(0.0..=MAX_LATENCY_STEPS as f64).contains(&jitter) {
            return Err(format!(
                "parameter sample_jitter = {} is {jitter} integration steps; expected 0 to {MAX_LATENCY_STEPS}",
                v.sample_jitter
            ));
        }
        Ok(Self {
            period: periods,
            delay_steps,
            jitter_steps: jitter as usize,
        })
    }

    /// The delay line's reach: the longest delay plus the jitter.
    fn longest_delay(&self) -> usize {
        self.delay_steps.into_iter().max().unwrap_or(0) + self.jitter_steps
    }

    /// The delay of one sample of a channel delayed by `delay` steps: `delay` plus a uniform
    /// draw in ±`jitter_steps`, never below 0 (no sample from the future). Draws nothing without
    /// jitter.
    fn jittered(&self, delay: usize, rng: &mut ChaCha20Rng) -> usize {
        if self.jitter_steps == 0 {
            return delay;
        }
        let jitter = self.jitter_steps as i64;
        let offset: i64 = rng.random_range(-jitter..=jitter);
        (delay as i64 + offset).max(0) as usize
    }
}

/// The channels' own sample-period parameters, in channel order.
const OWN_PERIOD_NAMES: [&str; SENSORS] = [
    "sample_period_yaw_rate_meas",
    "sample_period_ay_meas",
    "sample_period_omega_front_meas",
    "sample_period_omega_rear_meas",
    "sample_period_ax_meas",
    "sample_period_vx_meas",
];

fn own_periods(v: &Variables) -> [f64; SENSORS] {
    [
        v.sample_period_yaw_rate_meas,
        v.sample_period_ay_meas,
        v.sample_period_omega_front_meas,
        v.sample_period_omega_rear_meas,
        v.sample_period_ax_meas,
        v.sample_period_vx_meas,
    ]
}

/// Each channel's sample period: its own parameter, or `sensor_sample_period` where that is -1.
fn channel_periods(v: &Variables) -> [f64; SENSORS] {
    own_periods(v).map(|own| {
        if own == -1.0 {
            v.sensor_sample_period
        } else {
            own
        }
    })
}

fn finite_or(value: f64, fallback: f64) -> f64 {
    if value.is_finite() {
        value
    } else {
        fallback
    }
}

/// The initial sensor outputs: the noise-free truth, quantised when the chain is on.
fn quantised_sensors(
    truth: &[f64; SENSORS],
    quantum: &[f64; SENSORS],
    noise_on: bool,
) -> [f64; SENSORS] {
    if noise_on {
        std::array::from_fn(|i| quantise(truth[i], quantum[i]))
    } else {
        *truth
    }
}

/// The ReferenceVehicle FMU.
#[derive(Clone, Debug)]
pub struct ReferenceVehicle {
    variables: Variables,
    simulation: Option<Simulation>,
    /// The `sensor_blanking` input the outputs were last published with.
    shown_blanking: i32,
}

impl ReferenceVehicle {
    /// Copies the truth and the sensor chain's output into the output variables.
    fn publish(&mut self) {
        let Some(simulation) = &self.simulation else {
            return;
        };
        let truth = simulation.truth;
        let v = &mut self.variables;
        v.vx = truth.longitudinal_velocity;
        v.vy = truth.lateral_velocity;
        v.yaw_rate = truth.yaw_rate;
        v.omega_front = truth.omega_front;
        v.omega_rear = truth.omega_rear;
        v.sideslip = truth.sideslip;
        v.ay = truth.lateral_acceleration;
        v.ax = truth.longitudinal_acceleration;
        v.slip_angle_front = truth.slip_angle_front;
        v.slip_angle_rear = truth.slip_angle_rear;
        v.slip_front = truth.slip_front;
        v.slip_rear = truth.slip_rear;
        let wheels = simulation.wheels;
        v.roll_angle = wheels.roll_angle;
        [
            v.omega_front_left,
            v.omega_front_right,
            v.omega_rear_left,
            v.omega_rear_right,
        ] = wheels.wheel_speed;
        [
            v.wheel_load_front_left,
            v.wheel_load_front_right,
            v.wheel_load_rear_left,
            v.wheel_load_rear_right,
        ] = wheels.wheel_load;
        let measured = [
            &mut v.yaw_rate_meas,
            &mut v.ay_meas,
            &mut v.omega_front_meas,
            &mut v.omega_rear_meas,
            &mut v.ax_meas,
            &mut v.vx_meas,
        ];
        let dropped = simulation
            .drops
            .as_ref()
            .is_some_and(|drops| drops.dropped(simulation.time));
        for (i, output) in measured.into_iter().enumerate() {
            *output = simulation.dropout.shown(
                i,
                simulation.time,
                v.sensor_blanking,
                dropped,
                simulation.held[i],
                *output,
            );
        }
        self.shown_blanking = v.sensor_blanking;
    }

    /// The input variables, driver then road, in the order of [`INPUT_NAMES`].
    fn requested_inputs(&self) -> [f64; 3 + ROAD_INPUTS] {
        let v = &self.variables;
        [
            v.steering_angle,
            v.drive_torque,
            v.brake_torque,
            v.road_friction,
            v.road_bank_angle,
            v.road_grade_angle,
        ]
    }

    /// The simulation's internal time (for tests).
    pub fn simulation_time(&self) -> Option<f64> {
        self.simulation.as_ref().map(|s| s.time)
    }
}

impl CoSimulationModel for ReferenceVehicle {
    type Variables = Variables;
    const MODEL_IDENTIFIER: &'static str = model_description::MODEL_IDENTIFIER;
    const GUID: &'static str = model_description::GUID;
    const VARIABLES: &'static [fmi_export::VariableInfo] = model_description::VARIABLES;
    const LOG_CATEGORIES: &'static [&'static str] = model_description::LOG_CATEGORIES;
    const FMI3_VARIABLES: &'static [fmi_export::Fmi3Variable] = model_description::FMI3_VARIABLES;
    const OUTPUT_DEPENDENCIES: &'static [(u32, &'static [u32])] =
        model_description::OUTPUT_DEPENDENCIES;

    /// The finest internal step: the integration step, or the sensor sample period where it is
    /// shorter (the sample-and-hold advances one period at a time), so that fmi-export refuses
    /// a period that would make a doStep loop for hours (`sensor_sample_period =
    /// 1e-300` lies inside its declared range and hung the first doStep).
    fn internal_step_size(&self) -> Option<f64> {
        let v = &self.variables;
        Some(
            channel_periods(v)
                .into_iter()
                .filter(|period| *period > 0.0)
                .fold(v.integration_step, f64::min),
        )
    }

    fn instantiate(_context: &InstantiationContext) -> Self {
        Self {
            variables: Variables::default(),
            simulation: None,
            shown_blanking: 0,
        }
    }

    fn variables(&self) -> &Variables {
        &self.variables
    }

    fn variables_mut(&mut self) -> &mut Variables {
        &mut self.variables
    }

    fn initialize(&mut self, start_time: f64) -> Result<(), String> {
        self.simulation = Some(Simulation::start(&self.variables, start_time)?);
        self.publish();
        Ok(())
    }

    fn do_step(&mut self, current_time: f64, step_size: f64) -> StepOutcome {
        let requested = self.requested_inputs();
        let Some(simulation) = self.simulation.as_mut() else {
            return StepOutcome::Error(String::from("the simulation was not initialised"));
        };
        // Inputs set after the last read: the sample of t_n is re-evaluated with them first, so
        // that a delayed or held sample carries the inputs of its instant whether or not the
        // master read the outputs in between.
        let (changed, warning) = simulation.take_inputs(requested);
        if changed {
            simulation.resample_at_inputs();
        }
        // The tunable noise levels take effect with this doStep: the sample of
        // t_n above keeps the levels it was drawn with.
        simulation.sensor_noise_std = sensor_noise_std(&self.variables);
        simulation.process_noise_std = process_noise_std(&simulation.vehicle, &self.variables);
        // The FMU's own clock follows the master's communication points exactly.
        simulation.time = current_time;
        let steps = ((step_size / simulation.integration_step) * (1.0 - 1e-9))
            .ceil()
            .max(1.0);
        let dt = if steps == 1.0 {
            step_size
        } else {
            step_size / steps
        };
        let dt = if (dt - simulation.integration_step).abs() <= 1e-12 * simulation.integration_step
        {
            simulation.integration_step
        } else {
            dt
        };
        for _ in 0..steps as u64 {
            if let Err(message) = simulation.integration_step(dt) {
                return StepOutcome::Discard(message);
            }
        }
        simulation.time = current_time + step_size;
        self.publish();
        match warning {
            Some(message) => StepOutcome::Warning(message),
            None => StepOutcome::Ok,
        }
    }

    /// Direct feed-through (ModelStructure `<Outputs>` dependencies): outputs read after the
    /// master set new inputs at a communication point are those of the new inputs.
    fn refresh_outputs(&mut self) {
        let requested = self.requested_inputs();
        let Some(simulation) = self.simulation.as_mut() else {
            return;
        };
        if let (true, _) = simulation.take_inputs(requested) {
            simulation.resample_at_inputs();
            self.publish();
        } else if self.variables.sensor_blanking != self.shown_blanking {
            self.publish();
        }
    }

    fn write_state(&self, writer: &mut StateWriter) -> Result<(), String> {
        match &self.simulation {
            None => writer.bool(false),
            Some(simulation) => {
                writer.bool(true);
                simulation.write_state(writer);
            }
        }
        Ok(())
    }

    fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        if reader.bool("simulation present")? {
            let mut simulation =
                Simulation::start(&self.variables, 0.0).map_err(StateError::new)?;
            simulation.read_state(reader)?;
            self.simulation = Some(simulation);
        } else {
            self.simulation = None;
        }
        Ok(())
    }
}

fmi_export::export_fmi2!(ReferenceVehicle);
fmi_export::export_fmi3!(ReferenceVehicle);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantisation_rounds_to_the_nearest_multiple() {
        assert_eq!(quantise(0.0149, 0.01), 0.01);
        assert_eq!(quantise(-0.0151, 0.01), -0.02);
        assert_eq!(quantise(0.123456, 0.0), 0.123456);
    }
}
