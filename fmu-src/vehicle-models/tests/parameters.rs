//! Parameters are plain serde structs: defaults are the seed values, and a partial parameter
//! file only overrides what it names.

use vehicle_models::rear_axle::RearAxleParams;
use vehicle_models::reference::ReferenceVehicleParams;
use vehicle_models::tyre::{HsriParams, MagicFormulaParams};
use vehicle_models::{SingleTrackParams, TwoTrackParams};

#[test]
fn defaults_round_trip_through_toml() {
    let params = ReferenceVehicleParams::default();
    let text = toml::to_string(&params).expect("serialisable");
    let back: ReferenceVehicleParams = toml::from_str(&text).expect("parsable");
    assert_eq!(back, params);
    let text = toml::to_string(&RearAxleParams::default()).expect("serialisable");
    assert_eq!(
        toml::from_str::<RearAxleParams>(&text).unwrap(),
        RearAxleParams::default()
    );
}

#[test]
fn partial_files_keep_the_seed_defaults_and_unknown_keys_are_named() {
    let params: ReferenceVehicleParams = toml::from_str(
        "model = \"TwoTrack\"\n[two_track]\ncog_height = 0.6\n[hsri]\nfriction_base = 1.0\n",
    )
    .expect("partial file");
    assert_eq!(params.two_track.cog_height, 0.6);
    assert_eq!(
        params.two_track.chassis.mass,
        TwoTrackParams::default().chassis.mass
    );
    assert_eq!(params.hsri.friction_base, 1.0);
    assert_eq!(
        params.hsri.reference_load,
        HsriParams::default().reference_load
    );
    assert_eq!(params.single_track, SingleTrackParams::default());
    assert_eq!(params.magic_formula, MagicFormulaParams::default());

    let error =
        toml::from_str::<SingleTrackParams>("[chassis]\nmass = 1400.0\nmas = 3.0\n").unwrap_err();
    assert!(error.to_string().contains("mas"), "{error}");
}

#[test]
fn model_a_defaults_are_table_5_1() {
    let p = SingleTrackParams::default();
    assert_eq!(
        [
            p.chassis.mass,
            p.chassis.cog_to_front_axle,
            p.chassis.cog_to_rear_axle,
            p.chassis.yaw_inertia
        ],
        [1400.0, 1.4346, 1.4831, 2978.7]
    );
    assert_eq!(
        [
            p.chassis.front_wheel_inertia,
            p.chassis.rear_wheel_inertia,
            p.chassis.brake_split_front,
            p.chassis.steering_ratio
        ],
        [10.3, 3.0, 0.6, 14.97]
    );
    assert_eq!(
        [
            p.chassis.front_wheel_load,
            p.chassis.rear_wheel_load,
            p.chassis.front_wheel_radius,
            p.chassis.rear_wheel_radius
        ],
        [3492.0, 3374.0, 0.3, 0.3]
    );
}

/// The FMU parameter mapping of the per-axle tyres: at their start values
/// (the estimator's XML: factors 1, shape 1.3, curvature -1) the chassis and model B's two
/// tyres are the seed car's; an FMU that does not declare them (the ReferenceVehicle) gets the
/// same; a rear value reaches the rear tyre only; out-of-range values are named.
#[test]
fn per_axle_tyre_parameters_default_to_the_seed_car() {
    use std::collections::HashMap;
    use vehicle_models::parameters::{
        ParameterSource, TYRE_FRICTION_SCALE, TYRE_LATERAL_CURVATURE, TYRE_LATERAL_SHAPE,
        TYRE_REFERENCE_LOAD_SCALE,
    };
    use vehicle_models::Chassis;
    let chassis = Chassis::default();
    let hsri = HsriParams::default();
    let shared: HashMap<&str, f64> = HashMap::from([
        ("mass", chassis.mass),
        ("cog_to_front_axle", chassis.cog_to_front_axle),
        ("cog_to_rear_axle", chassis.cog_to_rear_axle),
        ("yaw_inertia", chassis.yaw_inertia),
        ("wheel_inertia_front", chassis.front_wheel_inertia),
        ("wheel_inertia_rear", chassis.rear_wheel_inertia),
        ("brake_distribution_front", chassis.brake_split_front),
        ("wheel_radius", chassis.front_wheel_radius),
        ("wheel_load_front", chassis.front_wheel_load),
        ("wheel_load_rear", chassis.rear_wheel_load),
        ("tyre_reference_load", hsri.reference_load),
        ("tyre_f00", hsri.friction_base),
        ("tyre_f01", hsri.friction_load),
        ("tyre_kr0", hsri.friction_decay_base),
        ("tyre_kr1", hsri.friction_decay_load),
        ("tyre_ca1", hsri.cornering_base),
        ("tyre_ca2", hsri.cornering_load),
        ("tyre_cs1", hsri.longitudinal_base),
        ("tyre_cs2", hsri.longitudinal_load),
        ("tyre_v_mu", hsri.reference_sliding_speed),
    ]);
    let mut declared = shared.clone();
    for (front, rear, start) in [
        (TYRE_FRICTION_SCALE.0, TYRE_FRICTION_SCALE.1, 1.0),
        (
            TYRE_REFERENCE_LOAD_SCALE.0,
            TYRE_REFERENCE_LOAD_SCALE.1,
            1.0,
        ),
        (TYRE_LATERAL_SHAPE.0, TYRE_LATERAL_SHAPE.1, 1.3),
        (TYRE_LATERAL_CURVATURE.0, TYRE_LATERAL_CURVATURE.1, -1.0),
    ] {
        declared.insert(front, start);
        declared.insert(rear, start);
    }
    let seed_tyres = (MagicFormulaParams::default(), MagicFormulaParams::default());
    for values in [&shared, &declared] {
        let source = ParameterSource::new(|name| values.get(name).copied());
        assert_eq!(source.chassis().unwrap(), chassis);
        assert_eq!(source.magic_formula_axles().unwrap(), seed_tyres);
    }
    let mut rear = declared.clone();
    rear.insert(TYRE_LATERAL_SHAPE.1, 1.6);
    rear.insert(TYRE_LATERAL_CURVATURE.1, 0.4);
    rear.insert(TYRE_FRICTION_SCALE.1, 0.9);
    let source = ParameterSource::new(|name| rear.get(name).copied());
    let (front_tyre, rear_tyre) = source.magic_formula_axles().unwrap();
    assert_eq!(front_tyre, MagicFormulaParams::default());
    assert_eq!(
        (rear_tyre.lateral_shape, rear_tyre.lateral_curvature),
        (1.6, 0.4)
    );
    let rear_chassis = source.chassis().unwrap();
    assert_eq!(
        (
            rear_chassis.front_tyre_friction_scale,
            rear_chassis.rear_tyre_friction_scale
        ),
        (1.0, 0.9)
    );
    for (name, bad) in [(TYRE_LATERAL_CURVATURE.1, 1.5), (TYRE_LATERAL_SHAPE.0, 0.0)] {
        let mut values = declared.clone();
        values.insert(name, bad);
        let source = ParameterSource::new(|name| values.get(name).copied());
        let error = source.magic_formula_axles().unwrap_err();
        assert!(error.contains(name), "{error}");
    }
}
