//! Helpers shared by the integration tests: a scratch folder, a zip writer, a scenario.

use std::io::Write;
use std::path::{Path, PathBuf};

use zip::write::SimpleFileOptions;

mod scratch;

pub use scratch::Scratch;

#[test]
fn a_scratch_folder_goes_when_its_test_fails_unless_kept() {
    let passing = Scratch::new("scratch-passing");
    let passing_path = passing.0.clone();
    assert_ne!(
        passing_path,
        Scratch::new("scratch-passing").0,
        "unique names"
    );
    drop(passing);
    assert!(!passing_path.exists(), "removed after a passing test");
    let mut failing_path = PathBuf::new();
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let failing = Scratch::new("scratch-failing");
        failing_path = failing.0.clone();
        std::fs::write(failing.0.join("evidence.txt"), "inspect me").unwrap();
        panic!("a failing test");
    }));
    assert!(outcome.is_err());
    let kept = scratch::keep_failed_test_dirs();
    assert_eq!(
        failing_path.join("evidence.txt").exists(),
        kept,
        "KEEP_TEST_DIRS={kept}"
    );
    if kept {
        std::fs::remove_dir_all(&failing_path).unwrap();
    }
}

/// The folder of the packaged FMUs (`fmi_master::runner::packaged_fmu_dir`); the test fails with
/// its message, which says how to build them, when they are missing.
pub fn packaged_fmus() -> PathBuf {
    fmi_master::runner::packaged_fmu_dir().unwrap_or_else(|error| panic!("{error:#}"))
}

/// A zip archive of `entries` (name, bytes), deflated.
pub fn write_zip(path: &Path, entries: &[(&str, &[u8])]) {
    let file = std::fs::File::create(path).unwrap();
    let mut zip = zip::ZipWriter::new(file);
    for (name, data) in entries {
        zip.start_file(*name, SimpleFileOptions::default()).unwrap();
        zip.write_all(data).unwrap();
    }
    zip.finish().unwrap();
}

/// A scenario that plans with the packaged FMUs: 10 steps of the high-ay ramp, the vehicle
/// connected to an EKF.
pub const GOOD: &str = r#"
name = "t"
step = 0.001
stop_time = 0.01
[manoeuvre]
library = "seed000_ramp_high_ay"
[[fmu]]
name = "vehicle"
path = "{fmu_dir}/ReferenceVehicle.fmu"
[[fmu]]
name = "ekf"
path = "{fmu_dir}/VehicleStateEstimator.fmu"
parameters = { sample_time = 0.001 }
[[connection]]
from = "vehicle"
to = "ekf"
[[input]]
signal = "steering_angle"
to = ["vehicle.steering_angle"]
[[score]]
label = "vy"
truth = "vehicle.vy"
estimate = "*.vy_est"
"#;
