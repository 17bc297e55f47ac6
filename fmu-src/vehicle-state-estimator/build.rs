//! Generates the variable table, value references and GUID from the model description.
fn main() {
    model_description::generate_for_build("../../modelDescription/VehicleStateEstimator.xml");
}
