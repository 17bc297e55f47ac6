//! The steady-state single-track yardstick of a campaign run (`fmi_master::yardstick`): the
//! sideslip a linear single-track model gives in a steady corner from the road-wheel angle and
//! the measured speed, with the car's true linear cornering stiffness at static load per axle.
//! No filter; an estimator that does not beat it has not earned its keep.
//!
//! The stiffness is the truth model's own: for the full vehicle (model 3) the car file's
//! combined-slip tyre, `K_yα(F_z)` (Pacejka 2012, 4.E25) at each axle's static wheel load; for
//! models 1 and 2 the seed's HSRI tyre, `Cα = (Cα1 + Cα2 Fz/FZref) Fz` (000: 5.70), at the car
//! file's static wheel loads (model 2's Magic Formula tyre is matched to it, same stiffness).
//! Both wheels of an axle together.

use std::path::Path;

use anyhow::{anyhow, Context, Result};

use fmi_master::cosim::RunResult;
use fmi_master::ssv::{read_parameter_file, SsvValue};
use fmi_master::yardstick::SingleTrackData;
use vehicle_models::parameters::{ParameterSource, STATIC_WHEEL_LOAD_PARAMETERS};
use vehicle_models::tyre::combined_slip::CombinedSlipTyre;
use vehicle_models::tyre::HsriParams;

use super::metrics::{column, rms, SIDESLIP_MIN_SPEED};

/// The full vehicle's `model` parameter.
const FULL_VEHICLE: i64 = 3;

/// The linear single-track data of the car of `car_file` on the ReferenceVehicle's model
/// `model` (1, 2 or 3), with the vehicle's parameters `overrides` (name, value) set after the
/// file's (a drawn car's tyres, say): the car the run's truth is.
pub fn single_track_data(
    car_file: &Path,
    model: i64,
    overrides: &[(String, f64)],
) -> Result<SingleTrackData> {
    let parameters = read_parameter_file(car_file)
        .with_context(|| format!("reading the car file {}", car_file.display()))?;
    let lookup = |name: &str| {
        let overridden = overrides.iter().rev().find(|(n, _)| n == name);
        overridden.map(|(_, value)| *value).or_else(|| {
            parameters
                .iter()
                .rev()
                .find(|p| p.name == name)
                .and_then(|p| match p.value {
                    SsvValue::Real(x) => Some(x),
                    SsvValue::Integer(x) => Some(x as f64),
                    _ => None,
                })
        })
    };
    let source = ParameterSource::new(lookup);
    let car = |error: String| anyhow!("car file {}: {error}", car_file.display());
    if model == FULL_VEHICLE {
        let params = source.full_vehicle(false, 1e-3).map_err(car)?;
        let (front_load, rear_load) = params.static_wheel_loads();
        let axle = |tyre: &vehicle_models::tyre::combined_slip::CombinedSlipParams, load: f64| {
            2.0 * CombinedSlipTyre::new(tyre.clone()).cornering_stiffness(load)
        };
        Ok(SingleTrackData {
            mass: params.body.mass,
            lf: params.body.cog_to_front_axle,
            lr: params.body.cog_to_rear_axle,
            cf: axle(&params.tyre_front, front_load),
            cr: axle(&params.tyre_rear, rear_load),
        })
    } else {
        let value = |name: &str| source.positive(name).map_err(car);
        let hsri = HsriParams::default();
        Ok(SingleTrackData {
            mass: value("mass")?,
            lf: value("cog_to_front_axle")?,
            lr: value("cog_to_rear_axle")?,
            cf: 2.0 * hsri.cornering_stiffness(value(STATIC_WHEEL_LOAD_PARAMETERS[0])?),
            cr: 2.0 * hsri.cornering_stiffness(value(STATIC_WHEEL_LOAD_PARAMETERS[1])?),
        })
    }
}

/// The yardstick's sideslip RMSE, rad, over the samples the campaigns score (true speed at
/// least [`SIDESLIP_MIN_SPEED`]): the steady-state sideslip at the manoeuvre's road-wheel angle
/// and the vehicle's measured speed (`vx_meas`; a missing sample holds the last one) against
/// the vehicle's true sideslip.
pub fn rmse(result: &RunResult, vehicle: &str, car: &SingleTrackData) -> Result<f64> {
    let truth = column(result, vehicle, "sideslip")?;
    let speed = column(result, vehicle, "vx")?;
    let measured = column(result, vehicle, "vx_meas")?;
    let angle = column(result, "manoeuvre", "steering_angle")?;
    let mut last_measured = f64::NAN;
    let errors = (0..truth.len()).filter_map(|k| {
        if measured[k].is_finite() {
            last_measured = measured[k];
        }
        (speed[k].abs() >= SIDESLIP_MIN_SPEED)
            .then(|| car.steady_state_sideslip(last_measured, angle[k]) - truth[k])
    });
    Ok(rms(errors))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmi_master::runner::scenario_dir;

    fn car_file(name: &str) -> std::path::PathBuf {
        scenario_dir().join(format!("../../fmu-src/reference-vehicle/cars/{name}.ssv"))
    }

    /// The Ford Escort's data: its mass and axle distances, and stiffnesses of a car's order
    /// (tens of kN/rad per axle); models 1 and 2 (the seed's HSRI tyre at the car's loads) and
    /// the full vehicle (its own tyres) differ, each the truth model's own.
    #[test]
    fn each_reference_model_gets_its_own_tyres_stiffness_at_static_load() {
        let full = single_track_data(&car_file("ford_escort"), 3, &[]).unwrap();
        let planar = single_track_data(&car_file("ford_escort"), 1, &[]).unwrap();
        for car in [full, planar] {
            assert_eq!(car.mass, 1225.9);
            assert_eq!((car.lf, car.lr), (0.88392, 1.50876));
            for stiffness in [car.cf, car.cr] {
                assert!((2e4..3e5).contains(&stiffness), "{car:?}");
            }
        }
        assert_ne!(full.cf, planar.cf);
        // a drawn car's tyre: the stiffness follows its p_Ky1
        let stiff = [(
            "tyre_front_p_ky1".to_string(),
            2.0 * ky1(&car_file("ford_escort")),
        )];
        let drawn = single_track_data(&car_file("ford_escort"), 3, &stiff).unwrap();
        assert!((drawn.cf / full.cf - 2.0).abs() < 1e-12);
        assert_eq!(drawn.cr, full.cr);
        let hsri = HsriParams::default();
        let front_load =
            full.mass * vehicle_models::GRAVITY * full.lr / (2.0 * (full.lf + full.lr));
        // the car file's static loads are the full vehicle's
        assert!((planar.cf - 2.0 * hsri.cornering_stiffness(front_load)).abs() < 1.0);
    }

    fn ky1(car_file: &Path) -> f64 {
        let parameters = read_parameter_file(car_file).unwrap();
        match parameters
            .iter()
            .find(|p| p.name == "tyre_front_p_ky1")
            .unwrap()
            .value
        {
            SsvValue::Real(x) => x,
            _ => panic!("p_ky1 is not Real"),
        }
    }

    #[test]
    fn a_car_file_without_the_data_is_named_in_the_error() {
        let dir = std::env::temp_dir().join(format!("yardstick_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("empty.ssv");
        std::fs::write(
            &path,
            "<?xml version=\"1.0\"?>\n<ssv:ParameterSet xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\" version=\"1.0\" name=\"e\"><ssv:Parameters/></ssv:ParameterSet>\n",
        )
        .unwrap();
        for model in [1, 3] {
            let error = format!("{:#}", single_track_data(&path, model, &[]).unwrap_err());
            assert!(error.contains("empty.ssv"), "{error}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
