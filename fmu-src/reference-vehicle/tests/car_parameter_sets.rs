//! The car files of vehicle-models (`fmu-src/vehicle-models/cars/*.toml`, each car's values in
//! one place) as SSP parameter-value files for the ReferenceVehicle (`cars/*.ssv` of this crate):
//! generated, kept current by this test (`UPDATE_CAR_PARAMETER_SETS=1 cargo test -p
//! reference-vehicle --test integration car_parameter_sets::` rewrites them), every name a parameter of the FMU.

use std::path::{Path, PathBuf};

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use fmi_export::Causality;
use vehicle_models::full_vehicle::CarData;
use vehicle_models::parameters::parameter_value_file;
use ReferenceVehicle::model_description::{vr, GUID, VARIABLES};

fn manifest_directory() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Every car file with its stem.
fn cars() -> Vec<(String, CarData)> {
    let directory = manifest_directory().join("../vehicle-models/cars");
    let mut cars: Vec<(String, CarData)> = std::fs::read_dir(&directory)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "toml"))
        .map(|path| {
            let text = std::fs::read_to_string(&path).unwrap();
            let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
            (stem, toml::from_str(&text).unwrap())
        })
        .collect();
    cars.sort_by(|a, b| a.0.cmp(&b.0));
    cars
}

fn ssv_path(stem: &str) -> PathBuf {
    manifest_directory()
        .join("cars")
        .join(format!("{stem}.ssv"))
}

#[test]
fn every_car_file_has_a_current_parameter_value_file() {
    let cars = cars();
    assert!(cars.len() >= 4, "the seed car and three real cars");
    for (stem, car) in &cars {
        let generated = parameter_value_file(car);
        if std::env::var_os("UPDATE_CAR_PARAMETER_SETS").is_some() {
            std::fs::write(ssv_path(stem), &generated).unwrap();
        }
        let stored = std::fs::read_to_string(ssv_path(stem)).unwrap_or_default();
        assert_eq!(
            stored, generated,
            "{stem}.ssv is stale: run UPDATE_CAR_PARAMETER_SETS=1 cargo test -p reference-vehicle --test integration car_parameter_sets::"
        );
    }
}

/// Every name is a parameter of the FMU, and every car's Real values lie within its min and max
/// (an FMU clamps values outside, which would silently change the car).
#[test]
fn every_name_in_a_parameter_value_file_is_a_parameter_of_the_fmu_and_in_range() {
    for (stem, car) in cars() {
        let text = parameter_value_file(&car);
        let names: Vec<&str> = text
            .split("<ssv:Parameter name=\"")
            .skip(1)
            .map(|rest| &rest[..rest.find('"').unwrap()])
            .collect();
        assert!(names.len() > 80, "{}", names.len());
        for name in names {
            let variable = VARIABLES.iter().find(|v| v.name == name);
            assert!(
                variable.is_some_and(|v| v.causality == Causality::Parameter),
                "{name} is no parameter of the ReferenceVehicle"
            );
        }
        for (name, value) in real_values(&text) {
            let variable = VARIABLES.iter().find(|v| v.name == name).unwrap();
            assert!(
                (variable.min..=variable.max).contains(&value),
                "{stem}: {name} = {value} outside [{}, {}]",
                variable.min,
                variable.max
            );
        }
    }
}

/// The `(name, value)` of every `ssv:Real` entry of a parameter-value file.
fn real_values(text: &str) -> Vec<(&str, f64)> {
    text.split("<ssv:Parameter name=\"")
        .skip(1)
        .filter_map(|rest| {
            let name = &rest[..rest.find('"')?];
            let value = rest.split("<ssv:Real value=\"").nth(1)?;
            Some((name, value[..value.find('"')?].parse().ok()?))
        })
        .collect()
}

/// A master that applies a car file and sets `model` to 1 or 2 runs the car's static wheel
/// loads (the file holds them), not the seed car's defaults; the models output them.
#[test]
fn a_car_file_gives_models_1_and_2_the_cars_static_wheel_loads() {
    for (stem, car) in cars() {
        let text = std::fs::read_to_string(ssv_path(&stem)).unwrap();
        let (front, rear) = car.vehicle.static_wheel_loads();
        for model in [1, 2] {
            let mut s = Slave::instantiate(fmi2_api_of!(ReferenceVehicle), "car", GUID)
                .expect("instantiate");
            for (name, value) in real_values(&text) {
                let variable = VARIABLES.iter().find(|v| v.name == name).unwrap();
                assert_eq!(s.set_real(variable.value_reference, value), Fmi2Status::Ok);
            }
            assert_eq!(s.set_integer(vr::MODEL, model), Fmi2Status::Ok);
            assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
            let loads = s.reals(&[vr::WHEEL_LOAD_FRONT_LEFT, vr::WHEEL_LOAD_REAR_RIGHT]);
            assert_eq!(loads, [front, rear], "{stem} on model {model}");
        }
    }
}
