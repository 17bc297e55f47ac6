//! The car files (`cars/*.toml`): each loads with serde, names its source, describes a plausible
//! car of its class; the seed car's file is the model's default.

use crate::full_vehicle_support;

use full_vehicle_support::{car, every_car, CAR_FILES};
use vehicle_models::full_vehicle::{FullVehicleParams, GRAVITY};

#[test]
fn the_seed_car_file_is_the_default_parameter_set() {
    assert_eq!(car("seed_car.toml").vehicle, FullVehicleParams::default());
}

#[test]
fn every_car_file_names_its_source_and_holds_a_plausible_car() {
    for file in CAR_FILES {
        let data = car(file);
        assert!(!data.name.is_empty() && !data.source.is_empty(), "{file}");
        let p = &data.vehicle;
        assert_eq!(p.validate(), Ok(()), "{file}");
        let (front, rear) = p.static_wheel_loads();
        assert!(front > 2000.0 && rear > 2000.0, "{file}: {front} {rear}");
        assert!((2.0 * (front + rear) / (p.body.mass * GRAVITY) - 1.0).abs() < 1e-12);
        assert!((800.0..2500.0).contains(&p.body.mass), "{file}");
        assert!(p.sprung_mass() > 0.8 * p.body.mass, "{file}");
        assert!(p.roll_lever() > 0.0, "{file}");
        let degrees_per_g = p.roll_gradient().to_degrees() * GRAVITY;
        assert!(
            (2.0..=8.0).contains(&degrees_per_g),
            "{file}: {degrees_per_g}"
        );
        assert!(
            (0.0..=1.0).contains(&p.drivetrain.drive_split_front),
            "{file}"
        );
        assert!(!p.drivetrain.abs.enabled, "{file}: ABS is off by default");
    }
}

#[test]
fn the_three_real_cars_are_a_front_drive_compact_a_rear_drive_saloon_and_a_van() {
    let cars = every_car();
    let find = |name: &str| &cars.iter().find(|(file, _)| *file == name).unwrap().1;
    let compact = find("ford_escort.toml");
    let saloon = find("bmw_320i.toml");
    let van = find("vw_vanagon.toml");
    assert_eq!(compact.drivetrain.drive_split_front, 1.0);
    assert_eq!(saloon.drivetrain.drive_split_front, 0.0);
    // the van is the heaviest and tallest
    assert!(van.body.mass > compact.body.mass && van.body.mass > saloon.body.mass);
    assert!(van.body.cog_height > compact.body.cog_height + 0.1);
}

#[test]
fn an_unknown_key_in_a_car_file_is_an_error() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cars/seed_car.toml"),
    )
    .unwrap()
    .replace("mass = 1400.0", "mass = 1400.0\nmas = 1.0");
    let parsed: Result<vehicle_models::full_vehicle::CarData, _> = toml::from_str(&text);
    assert!(parsed.is_err());
}

#[test]
fn validation_names_the_parameter_that_would_break_the_model() {
    let mut p = FullVehicleParams::default();
    p.tyre_rear.relaxation_length_lateral = 0.0;
    assert!(p
        .validate()
        .unwrap_err()
        .contains("tyre_rear.relaxation_length_lateral"));
    let mut p = FullVehicleParams::default();
    p.drivetrain.drive_split_front = 1.5;
    assert!(p.validate().unwrap_err().contains("drive_split_front"));
    let mut p = FullVehicleParams::default();
    p.suspension.roll_stiffness_front = 1000.0;
    p.suspension.roll_stiffness_rear = 1000.0;
    assert!(p.validate().unwrap_err().contains("roll stiffness"));
}

/// The FMU's parameter names (vehicle_models::parameters) cover every car exactly: each name once,
/// and reading a car's values back by name gives the car again, bit for bit.
#[test]
fn every_car_round_trips_through_the_fmu_parameter_names() {
    use vehicle_models::parameters::{full_vehicle_parameter_values, ParameterSource};
    for (file, params) in every_car() {
        let values = full_vehicle_parameter_values(&params);
        let names: std::collections::HashSet<&str> = values.iter().map(|(name, _)| *name).collect();
        assert_eq!(names.len(), values.len(), "{file}: a name twice");
        let source = ParameterSource::new(|name| {
            values
                .iter()
                .find(|(candidate, _)| *candidate == name)
                .map(|(_, value)| *value)
        });
        let read = source.full_vehicle(params.drivetrain.abs.enabled, params.internal_step);
        assert_eq!(read, Ok(params), "{file}");
    }
}
