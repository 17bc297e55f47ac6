//! The scenario parser and every check that runs without FMUs, on arbitrary text: an error,
//! never a panic.
#![no_main]

use std::path::Path;

use fmi_master::scenario::Scenario;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(scenario) = Scenario::from_str_at(text, Path::new("fuzz.toml"), Path::new(".")) {
            let _ = scenario.step_count();
            if let Ok(Some(manoeuvre)) = scenario.manoeuvre() {
                let _ = manoeuvre.duration();
            }
        }
    }
});
