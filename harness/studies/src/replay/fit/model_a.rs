//! Model A's part of `harness fit` (module text of [`super`], steps 1-3): the per-axle
//! cornering-stiffness scales by EM on the training segment's linear part, the process-noise
//! factor by the innovation likelihood, and the peak friction where the segment reaches the
//! limit.

use std::ops::Range;

use anyhow::{anyhow, Result};
use estimation::models::single_track_identification::{
    identify_scales_from_arrays, SingleTrackHsri,
};
use vehicle_models::parameters::ParameterSource;
use vehicle_models::single_track::{SingleTrackModel, SingleTrackParams};
use vehicle_models::HsriTyre;

use fmi_master::cosim::ParameterValue;
use fmi_master::fmu::{LoadedFmu, VariableInfo};

use super::super::Prepared;
use super::{real_value, scale_values, starting_scales, with_reals, FitContext, Found, ModelFit};

/// Model A: single track with HSRI tyres.
pub struct ModelA;

impl ModelFit for ModelA {
    fn item(&self) -> &'static str {
        "single_track_5_state"
    }

    fn fit(&self, cx: &FitContext) -> Result<Found> {
        let (fmu, prepared, start) = (cx.fmu, cx.prepared, cx.start);
        let rows = linear_rows(fmu, prepared, start, cx.train_rows.clone())?;
        let (scales, converged) = identify_scales(fmu, prepared, start, rows.clone())?;
        let mut fitted = scale_values(scales);
        let with_scales = with_reals(fmu, start, &fitted)?;
        let noise = fit_noise_a(fmu, prepared, &with_scales, cx.train_rows.clone())?;
        for name in NOISE_PARAMETERS {
            let factor = if name.starts_with("process") {
                noise.process
            } else {
                noise.measurement
            };
            fitted.push((
                name.to_string(),
                real_value(fmu, &with_scales, name)? * factor,
            ));
        }
        let with_noise = with_reals(fmu, start, &fitted)?;
        let friction = fit_friction(fmu, prepared, &with_noise, cx.train_rows.clone())?;
        if let super::super::friction::FrictionFit::Fitted { f00, .. } = friction {
            fitted.push(("tyre_f00".to_string(), f00));
        }
        Ok(Found {
            fitted,
            scales: Some((scales, converged)),
            scale_rows: Some(rows),
            noise_factors: (noise.process, noise.measurement),
            noise_fit: Some(noise),
            friction: Some(friction),
            ..Found::default()
        })
    }
}

/// Noise standard deviations the FMU declares; each is multiplied by the fitted noise scale.
const NOISE_PARAMETERS: [&str; 12] = [
    "process_noise_std_vx",
    "process_noise_std_vy",
    "process_noise_std_yaw_rate",
    "process_noise_std_omega_front",
    "process_noise_std_omega_rear",
    "process_noise_std_sideslip",
    "process_noise_std_ay",
    "measurement_noise_std_yaw_rate",
    "measurement_noise_std_ay",
    "measurement_noise_std_omega_front",
    "measurement_noise_std_omega_rear",
    "measurement_noise_std_vx",
];

/// Model A: the noise factors of greatest innovation likelihood on the training rows.
fn fit_noise_a(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    values: &[(VariableInfo, ParameterValue)],
    rows: Range<usize>,
) -> Result<super::super::noise::NoiseFit> {
    let (inputs, measurements) = training_rows(prepared, rows);
    let vehicle = vehicle(fmu, values)?;
    super::super::noise::fit_noise(&noise_problem(
        fmu,
        prepared,
        values,
        &vehicle,
        (&inputs, &measurements),
    )?)
}

/// Model A's likelihood problem on training rows with the noise `values` set.
fn noise_problem<'a>(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    values: &[(VariableInfo, ParameterValue)],
    vehicle: &'a SingleTrackHsri,
    (inputs, measurements): (&'a [[f64; 3]], &'a [[f64; 4]]),
) -> Result<super::super::noise::NoiseProblem<'a>> {
    let std = |names: &[&str]| {
        names
            .iter()
            .map(|n| real_value(fmu, values, n))
            .collect::<Result<Vec<f64>>>()
    };
    let process = std(&NOISE_PARAMETERS[..5])?;
    let measurement = std(&NOISE_PARAMETERS[7..11])?;
    Ok(super::super::noise::NoiseProblem {
        vehicle,
        sample_time: prepared.grid.step,
        process_std: [process[0], process[1], process[2], process[3], process[4]],
        measurement_std: [
            measurement[0],
            measurement[1],
            measurement[2],
            measurement[3],
        ],
        initial_std: crate::mismatch::identification_config().initial_std,
        inputs,
        measurements,
    })
}

/// Model A: `tyre_f00` where the training rows reach the friction limit
/// ([`super::super::friction`]), with the fitted scales and noise in `values`.
fn fit_friction(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    values: &[(VariableInfo, ParameterValue)],
    rows: Range<usize>,
) -> Result<super::super::friction::FrictionFit> {
    use super::super::friction::{
        axle_ceilings, golden_section, reach, FrictionFit, F00_RANGE, F00_TOLERANCE,
    };
    let (inputs, measurements) = training_rows(prepared, rows);
    let f00_start = real_value(fmu, values, "tyre_f00")?;
    // f0 at the reference load, q = 1 (000: 5.67).
    let f0 = f00_start - real_value(fmu, values, "tyre_f01")?;
    let ay: Vec<f64> = measurements.iter().map(|y| y[1]).collect();
    let reach = reach(&ay, f0);
    if !reach.identifiable() {
        return Ok(FrictionFit::NotIdentifiable(reach));
    }
    let data = (inputs.as_slice(), measurements.as_slice());
    let likelihood = |f00: f64| -> Result<f64> {
        let trial = with_reals(fmu, values, &[("tyre_f00".to_string(), f00)])?;
        let vehicle = vehicle(fmu, &trial)?;
        super::super::noise::negative_log_likelihood(
            &noise_problem(fmu, prepared, &trial, &vehicle, data)?,
            1.0,
            1.0,
        )
    };
    let negative_log_likelihood_start = likelihood(f00_start)?;
    let (f00, negative_log_likelihood) = golden_section(likelihood, F00_RANGE, F00_TOLERANCE)?;
    let trial = with_reals(fmu, values, &[("tyre_f00".to_string(), f00)])?;
    let speed = cornering_speed(&vehicle(fmu, &trial)?, &measurements, reach.sliding_ay);
    let ceiling_ay = axle_ceilings(&vehicle(fmu, &trial)?, speed)
        .into_iter()
        .fold(f64::INFINITY, f64::min);
    if ceiling_ay < reach.high_ay {
        return Ok(FrictionFit::Refused {
            reach,
            f00,
            ceiling_ay,
        });
    }
    Ok(FrictionFit::Fitted {
        reach,
        f00,
        f00_start,
        negative_log_likelihood,
        negative_log_likelihood_start,
    })
}

/// The speed of the rows beyond the sliding threshold `sliding_ay` (m/s², measured `|ay|`), the
/// median of the wheel speeds times their radii: the speed at which the friction was tested,
/// which sets the sliding speed in µ (000: 5.66, 5.69).
fn cornering_speed(vehicle: &SingleTrackHsri, measurements: &[[f64; 4]], sliding_ay: f64) -> f64 {
    let chassis = &vehicle.vehicle.chassis;
    let mut speeds: Vec<f64> = measurements
        .iter()
        .filter(|y| y[1].abs() > sliding_ay)
        .flat_map(|y| {
            [
                y[2] * chassis.front_wheel_radius,
                y[3] * chassis.rear_wheel_radius,
            ]
        })
        .filter(|v| v.is_finite())
        .map(f64::abs)
        .collect();
    speeds.sort_by(f64::total_cmp);
    speeds.get(speeds.len() / 2).copied().unwrap_or(0.0)
}

/// Model A: the longest run of `rows` where the measured `|ay|` stays below the sliding
/// threshold of the starting tyre ([`super::super::friction::reach`]), or all of `rows` when that run
/// is shorter than 10 rows (module text, step 1).
fn linear_rows(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    values: &[(VariableInfo, ParameterValue)],
    rows: Range<usize>,
) -> Result<Range<usize>> {
    let (_, measurements) = training_rows(prepared, rows.clone());
    let ay: Vec<f64> = measurements.iter().map(|y| y[1]).collect();
    // f0 at the reference load, q = 1 (000: 5.67), as the friction rule reads it.
    let f0 = real_value(fmu, values, "tyre_f00")? - real_value(fmu, values, "tyre_f01")?;
    let run = super::super::friction::longest_linear_run(
        &ay,
        super::super::friction::reach(&ay, f0).sliding_ay,
    );
    Ok(if run.len() < 10 {
        rows
    } else {
        rows.start + run.start..rows.start + run.end
    })
}

/// Model A's vehicle as the FMU builds it from `values` (and its start values).
fn vehicle(fmu: &LoadedFmu, values: &[(VariableInfo, ParameterValue)]) -> Result<SingleTrackHsri> {
    let source = ParameterSource::new(|name| real_value(fmu, values, name).ok());
    let [front, rear] = starting_scales(fmu, values)?;
    let params = SingleTrackParams {
        chassis: source.chassis().map_err(|e| anyhow!(e))?,
        cornering_stiffness_scale_front: front,
        cornering_stiffness_scale_rear: rear,
        ..SingleTrackParams::default()
    };
    Ok(SingleTrackModel::new(
        params,
        HsriTyre::new(source.hsri().map_err(|e| anyhow!(e))?),
    ))
}

/// `[k_F, k_R]` by EM on the training rows.
fn identify_scales(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    values: &[(VariableInfo, ParameterValue)],
    rows: Range<usize>,
) -> Result<([f64; 2], bool)> {
    let (inputs, measurements) = training_rows(prepared, rows);
    let mut config = crate::mismatch::identification_config();
    config.sample_time = prepared.grid.step;
    config.measurement_noise_std = [
        "measurement_noise_std_yaw_rate",
        "measurement_noise_std_ay",
        "measurement_noise_std_omega_front",
        "measurement_noise_std_omega_rear",
    ]
    .map(|name| real_value(fmu, values, name).unwrap_or(f64::NAN));
    let result =
        identify_scales_from_arrays(&vehicle(fmu, values)?, &inputs, &measurements, &config)
            .map_err(|e| {
                anyhow!("identifying the cornering-stiffness scales on the training segment: {e}")
            })?;
    Ok((
        [result.parameters[0], result.parameters[1]],
        result.converged,
    ))
}

/// The rows as model A reads them: inputs `[δ, drive, brake]` and measurements `[r, ay, ωF, ωR]`.
fn training_rows(prepared: &Prepared, rows: Range<usize>) -> (Vec<[f64; 3]>, Vec<[f64; 4]>) {
    let feed = |name: &str| {
        prepared
            .feeds
            .iter()
            .find(|f| f.input == name)
            .map(|f| &f.values[rows.clone()])
    };
    let held = |name: &str| held_input(feed(name), rows.len());
    let (steering, drive_torque, brake_torque) = (
        held("steering_angle"),
        held("drive_torque"),
        held("brake_torque"),
    );
    let inputs = (0..rows.len())
        .map(|k| [steering[k], drive_torque[k], brake_torque[k]])
        .collect();
    let measured = |name: &str| {
        feed(name)
            .map(<[f64]>::to_vec)
            .unwrap_or_else(|| vec![f64::NAN; rows.len()])
    };
    let y = [
        measured("yaw_rate_meas"),
        measured("ay_meas"),
        measured("omega_front_meas"),
        measured("omega_rear_meas"),
    ];
    let measurements = (0..rows.len())
        .map(|k| [y[0][k], y[1][k], y[2][k], y[3][k]])
        .collect();
    (inputs, measurements)
}

/// A driver input on the rows: a missing sample holds the previous one (0 before the first),
/// an input the map does not feed is 0, as the FMU's start value.
fn held_input(values: Option<&[f64]>, rows: usize) -> Vec<f64> {
    let Some(values) = values else {
        return vec![0.0; rows];
    };
    let mut last = 0.0;
    values
        .iter()
        .map(|v| {
            if v.is_finite() {
                last = *v;
            }
            last
        })
        .collect()
}
