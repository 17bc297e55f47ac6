//! The XML's estimator enumeration against the estimation crate's registry.

use estimation::registry::EstimatorChoice;
use VehicleStateEstimator::model_description::EstimatorKind;

/// The XML's `EstimatorKind` items and the registry list the same estimators in the same order:
/// the FMU maps one to the other by name.
#[test]
fn the_xml_enumeration_and_the_registry_agree() {
    let xml: Vec<&str> = EstimatorKind::ALL.iter().map(|kind| kind.name()).collect();
    let registry: Vec<&str> = EstimatorChoice::ALL.iter().map(|c| c.name()).collect();
    assert_eq!(xml, registry);
}
