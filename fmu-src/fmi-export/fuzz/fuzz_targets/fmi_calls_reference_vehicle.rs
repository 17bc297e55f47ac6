//! FMI call sequences with arbitrary arguments on ReferenceVehicle (fmi_export::fuzzing).
#![no_main]

use libfuzzer_sys::fuzz_target;
use ReferenceVehicle::model_description::{GUID, VARIABLES};

fuzz_target!(|data: &[u8]| {
    let api = fmi_export::fmi2_api_of!(ReferenceVehicle);
    fmi_export::fuzzing::drive_calls(api, GUID, VARIABLES, data);
});
