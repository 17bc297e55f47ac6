//! Parameter bounds on the estimator: every Real and Integer parameter carries `min` and `max` in
//! the modelDescription, so a master can check a value before setting it and the FMU clamps (with
//! fmi2Warning) whatever lies outside; the bounds also cap every size the filter allocates from a
//! parameter (particle count, the adaptation window's ring).

const XML: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../modelDescription/VehicleStateEstimator.xml"
);

#[test]
fn every_real_and_integer_parameter_has_bounds() {
    let description = model_description::parse_file(XML).expect("VehicleStateEstimator.xml parses");
    let unbounded = description.unbounded_parameters();
    assert!(
        unbounded.is_empty(),
        "parameters without min or max: {unbounded:?}"
    );
}
