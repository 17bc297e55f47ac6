//! What a user knows of a car, given to every estimator instance of the robustness cases and the
//! mismatch campaigns: the campaigns' rule is "only a car's mass, yaw inertia, axle distances,
//! wheel radii and wheel loads, and everything else at its default". The values come from the
//! same SSP parameter-value file (.ssv) the ReferenceVehicle runs with, so the truth and the
//! estimator describe one car and nothing is written twice.

use std::path::Path;

use anyhow::{anyhow, Context, Result};

use fmi_master::cosim::ParameterValue;
use fmi_master::fmu::LoadedFmu;
use fmi_master::scenario::{Scenario, VarRef};
use fmi_master::ssv::{read_parameter_file, SsvValue};
use vehicle_models::parameters::STATIC_WHEEL_LOAD_PARAMETERS;

/// Parameters copied unchanged from the car file to the estimator (both FMUs name them alike:
/// 000 table 5.1's symbols, and the static load of one wheel per axle, which the car file holds
/// for the ReferenceVehicle's models 1 and 2, `vehicle_models::parameters::parameter_value_file`).
pub const COPIED_PARAMETERS: [&str; 9] = [
    "mass",
    "yaw_inertia",
    "cog_to_front_axle",
    "cog_to_rear_axle",
    "wheel_inertia_front",
    "wheel_inertia_rear",
    "brake_distribution_front",
    STATIC_WHEEL_LOAD_PARAMETERS[0],
    STATIC_WHEEL_LOAD_PARAMETERS[1],
];

/// The estimator's parameter values for the car of `car_file`: the copied ones; the wheel
/// radius, once as `wheel_radius` and once per axle (`wheel_radius_front`, `_rear`: the car
/// file's own per-axle values where it has them), so that either form of the estimator finds
/// its own.
pub fn estimator_values(car_file: &Path) -> Result<Vec<(String, f64)>> {
    let parameters = read_parameter_file(car_file)
        .with_context(|| format!("reading the car file {}", car_file.display()))?;
    let find = |name: &str| -> Option<f64> {
        parameters
            .iter()
            .rev()
            .find(|p| p.name == name)
            .and_then(|p| match p.value {
                SsvValue::Real(x) => Some(x),
                SsvValue::Integer(x) => Some(x as f64),
                _ => None,
            })
    };
    let value = |name: &str| -> Result<f64> {
        find(name).ok_or_else(|| {
            anyhow!(
                "car file {}: no Real parameter {name:?}; expected the car's {name} for the estimator",
                car_file.display()
            )
        })
    };
    let mut values = COPIED_PARAMETERS
        .iter()
        .map(|&name| Ok((name.to_string(), value(name)?)))
        .collect::<Result<Vec<_>>>()?;
    let radius = value("wheel_radius")?;
    values.push(("wheel_radius".into(), radius));
    for axle in ["front", "rear"] {
        let name = format!("wheel_radius_{axle}");
        let own = find(&name).unwrap_or(radius);
        values.push((name, own));
    }
    Ok(values)
}

/// [`estimator_values`] as parameter overrides of every instance in `instances`, those the
/// estimator FMU `estimator` has as parameters.
pub fn estimator_overrides(
    car_file: &Path,
    instances: &[String],
    estimator: &LoadedFmu,
) -> Result<Vec<(VarRef, ParameterValue)>> {
    let values: Vec<(String, f64)> = estimator_values(car_file)?
        .into_iter()
        .filter(|(name, _)| estimator.variable(name).is_some_and(|v| v.is_parameter()))
        .collect();
    Ok(instances
        .iter()
        .flat_map(|instance| {
            values.iter().map(|(name, value)| {
                (
                    VarRef {
                        instance: instance.clone(),
                        variable: name.clone(),
                    },
                    ParameterValue::Real(*value),
                )
            })
        })
        .collect())
}

/// The FMU `instance` of `scenario` runs, loaded (extracted below `work_dir`) to read its
/// model description.
pub fn load_fmu_of(
    scenario: &Scenario,
    instance: &str,
    fmu_dir: &Path,
    work_dir: &Path,
) -> Result<LoadedFmu> {
    let index = scenario
        .fmus
        .iter()
        .position(|f| f.name == instance)
        .ok_or_else(|| {
            anyhow!(
                "scenario {}: no [[fmu]] named {instance:?}",
                scenario.source.display()
            )
        })?;
    Ok(LoadedFmu::load(
        &scenario.fmu_path(index, fmu_dir),
        work_dir,
    )?)
}
