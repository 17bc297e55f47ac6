//! The modelDescription.xml parser and its checks on arbitrary text: an error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(description) = model_description::parse_str(text, "fuzz.xml") {
            let _ = model_description::validate::validate(&description, "fuzz.xml");
        }
    }
});
