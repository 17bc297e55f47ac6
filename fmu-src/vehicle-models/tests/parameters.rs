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
