//! `harness fit --model b`: model B's per-axle cornering-stiffness scales by the accelerated EM
//! on model B itself ([`identify_two_track_scales_from_arrays`], 003: §3.1), with the car as the
//! VehicleStateEstimator builds model B from the same parameter values
//! ([`ParameterSource::two_track_lateral`]) and the rows as it reads them: inputs
//! `[δ, vx, ax]`, measurements `[ay, r]`.

use std::ops::Range;

use anyhow::{anyhow, Result};
use estimation::models::two_track_identification::{
    identify_two_track_scales_from_arrays, TwoTrackIdentificationConfig,
};
use estimation::particle::{ParticleFilterConfig, Proposal, ResamplingPolicy, ResamplingScheme};
use fmi_master::cosim::ParameterValue;
use fmi_master::fmu::{LoadedFmu, VariableInfo};
use vehicle_models::parameters::ParameterSource;
use vehicle_models::Integrator;

use super::fit::{held_input, real_value};
use super::Prepared;

/// The EM's settings for model B on a log sampled every `sample_time` s, with the sensors'
/// noise `[ay, r]` (the FMU's `measurement_noise_std_ay`, `_yaw_rate`).
///
/// `Q` per 10 ms over `[β, r, ay]` (scaled like a random walk for another sample time) is what
/// the model may miss in a step: as for model A ([`crate::mismatch::identification_config`])
/// small, so that the tyre law has to explain the data. The sideslip's 1e-4 rad is model A's
/// 2e-3 m/s of `vy` at 20 m/s, the yaw rate's 1e-3 rad/s model A's; `ay` is a state that model
/// B computes from the tyre forces each step (001: eq 1), so its noise says how closely those
/// forces must meet the measured `ay`: 0.05 m/s², half the campaigns' sensor noise.
pub fn identification_config(
    sample_time: f64,
    measurement_noise_std: [f64; 2],
) -> TwoTrackIdentificationConfig {
    let random_walk = (sample_time / 0.01).sqrt();
    TwoTrackIdentificationConfig {
        sample_time,
        integrator: Integrator::SemiImplicitEuler,
        process_noise_std: [1e-4, 1e-3, 0.05].map(|std| std * random_walk),
        measurement_noise_std,
        start: [1.0, 1.0],
        initial_std: [0.01, 0.01, 0.2],
        // As model A's: 100 particles, stratified resampling below half the effective size,
        // the linearised optimal proposal (R much tighter than the spread of the prediction).
        filter: ParticleFilterConfig {
            particle_count: 100,
            scheme: ResamplingScheme::Stratified,
            policy: ResamplingPolicy::EffectiveSampleSizeBelow(0.5),
            seed: 1,
        },
        proposal: Proposal::LinearisedOptimal,
        tolerance: 3e-3,
        max_cycles: 20,
        max_sweeps: 3,
        acceleration: Default::default(),
    }
}

/// `[k_F, k_R]` of model B by EM on the training rows, and whether the EM converged.
pub fn identify_scales(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    values: &[(VariableInfo, ParameterValue)],
    rows: Range<usize>,
) -> Result<([f64; 2], bool)> {
    let source = ParameterSource::new(|name| real_value(fmu, values, name).ok());
    let vehicle = source.two_track_lateral().map_err(|e| anyhow!(e))?;
    let (front_radius, rear_radius) = source.wheel_radii().map_err(|e| anyhow!(e))?;
    let (inputs, measurements) = training_rows(prepared, rows, [front_radius, rear_radius]);
    let noise = ["measurement_noise_std_ay", "measurement_noise_std_yaw_rate"]
        .map(|name| real_value(fmu, values, name).unwrap_or(f64::NAN));
    let config = identification_config(prepared.grid.step, noise);
    let result = identify_two_track_scales_from_arrays(&vehicle, &inputs, &measurements, &config)
        .map_err(|e| {
        anyhow!("identifying model B's cornering-stiffness scales on the training segment: {e}")
    })?;
    Ok((
        [result.parameters[0], result.parameters[1]],
        result.converged,
    ))
}

/// The rows as model B reads them: inputs `[δ, vx, ax]` and measurements `[ay, r]`. The speed
/// is `vx_meas`, else the mean of the wheel speeds' `ω r` (the FMU's fallback); where neither
/// is there the last one is held. `ax` is `ax_meas` held, 0 if the log has none (static axle
/// loads, as the FMU without it).
fn training_rows(
    prepared: &Prepared,
    rows: Range<usize>,
    radii: [f64; 2],
) -> (Vec<[f64; 3]>, Vec<[f64; 2]>) {
    let feed = |name: &str| {
        prepared
            .feeds
            .iter()
            .find(|f| f.input == name)
            .map(|f| &f.values[rows.clone()])
    };
    let measured = |name: &str| {
        feed(name)
            .map(<[f64]>::to_vec)
            .unwrap_or_else(|| vec![f64::NAN; rows.len()])
    };
    let (vx, front, rear) = (
        measured("vx_meas"),
        measured("omega_front_meas"),
        measured("omega_rear_meas"),
    );
    let speed: Vec<f64> = (0..rows.len())
        .map(|k| {
            if vx[k].is_finite() {
                vx[k]
            } else {
                (front[k] * radii[0] + rear[k] * radii[1]) / 2.0
            }
        })
        .collect();
    let speed = held_input(Some(&speed), rows.len());
    let steering = held_input(feed("steering_angle"), rows.len());
    let ax = held_input(feed("ax_meas"), rows.len());
    let inputs = (0..rows.len())
        .map(|k| [steering[k], speed[k], ax[k]])
        .collect();
    let (ay, yaw_rate) = (measured("ay_meas"), measured("yaw_rate_meas"));
    let measurements = (0..rows.len()).map(|k| [ay[k], yaw_rate[k]]).collect();
    (inputs, measurements)
}
