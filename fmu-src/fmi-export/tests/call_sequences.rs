//! The FMI call-sequence driver of the fuzz targets (`fmi_export::fuzzing`) on the toy model,
//! with pseudo-random inputs: a bounded, deterministic run in the test suite. Longer runs:
//! `FUZZ_CASES=1000000 cargo test --release -p fmi-export --test integration call_sequences:: -- --nocapture`;
//! coverage-guided runs on the real FMUs: see fmu-src/fmi-export/fuzz/README.md.

use crate::toy;

use fmi_export::fuzzing::drive_calls;
use fmi_export::CoSimulationModel;

/// Runs `drive` on `FUZZ_CASES` (default 2000) pseudo-random byte strings.
fn pseudo_random_cases(mut drive: impl FnMut(&[u8])) {
    let cases: u64 = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|text| text.parse().ok())
        .unwrap_or(2000);
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut data = Vec::new();
    let started = std::time::Instant::now();
    for _ in 0..cases {
        data.clear();
        // xorshift64: a fixed sequence, so every run tests the same inputs.
        let length = 16 + (seed % 600) as usize;
        for _ in 0..length {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            data.push(seed as u8);
        }
        drive(&data);
    }
    eprintln!("{cases} call sequences in {:.1?}", started.elapsed());
}

#[test]
fn random_call_sequences_neither_crash_nor_hang_nor_break_the_instance() {
    let api = fmi_export::fmi2_api_of!(crate::toy);
    pseudo_random_cases(|data| drive_calls(api, toy::Toy::GUID, toy::Toy::VARIABLES, data));
}

#[test]
fn random_fmi3_call_sequences_neither_crash_nor_hang_nor_break_the_instance() {
    pseudo_random_cases(fmi_export::fuzzing3::drive_calls::<toy::Toy>);
}
