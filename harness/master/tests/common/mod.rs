//! Helpers shared by the integration tests: a scratch folder, a zip writer, a scenario.

use std::io::Write;
use std::path::{Path, PathBuf};

use zip::write::SimpleFileOptions;

/// A fresh folder under the system's temporary folder, removed on drop.
pub struct Scratch(pub PathBuf);

impl Scratch {
    pub fn new(name: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("harness-fmu-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A zip archive of `entries` (name, bytes), deflated.
/// The folder of the packaged FMUs (`fmi_master::runner::packaged_fmu_dir`); the test fails with
/// its message, which says how to build them, when they are missing.
pub fn packaged_fmus() -> PathBuf {
    fmi_master::runner::packaged_fmu_dir().unwrap_or_else(|error| panic!("{error:#}"))
}

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
