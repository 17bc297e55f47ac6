//! FMI call sequences with arbitrary arguments on VehicleStateEstimator (fmi_export::fuzzing).
#![no_main]

use libfuzzer_sys::fuzz_target;
use VehicleStateEstimator::model_description::{GUID, VARIABLES};

fuzz_target!(|data: &[u8]| {
    let api = fmi_export::fmi2_api_of!(VehicleStateEstimator);
    fmi_export::fuzzing::drive_calls(api, GUID, VARIABLES, data);
});
