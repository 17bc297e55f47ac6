//! The master's defences against bad input, each a regression test of a defect found by
//! probing: names that become paths, sizes that allocate, numeric scenario fields, .fmu
//! extraction limits, FIFOs, results written under a temporary name, the work folder, `inspect`
//! and the Monte Carlo seed variables.
//!
//! The tests marked "packaged FMUs" need `cargo run --release -p packaging` first (as
//! plan_errors.rs), in `fmi_master::runner::default_fmu_dir()`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use fmi_master::cosim::Plan;
use fmi_master::fmu::{limits, platform_folder, FmuError, LoadedFmu};
use fmi_master::montecarlo;
use fmi_master::runner::{self, Environment, WorkFolder};
use fmi_master::scenario::{Scenario, VarRef, MAX_STEPS};

use crate::common::{packaged_fmus, write_zip, Scratch, GOOD};

fn parse(text: &str) -> Result<Scenario, String> {
    Scenario::from_str_at(text, Path::new("probe.toml"), Path::new(".")).map_err(|e| e.to_string())
}

#[test]
fn scenario_names_that_would_leave_the_output_folder_are_refused() {
    for bad in [
        "../x",
        "a/b",
        "..",
        ".hidden",
        "a\\b",
        "",
        "name with space",
        "c:x",
    ] {
        let text = GOOD.replace("name = \"t\"", &format!("name = {bad:?}"));
        let error = parse(&text).expect_err(bad);
        assert!(error.contains("`name`"), "{bad:?}: {error}");
    }
    for good in ["seed000_ramp-2", "a.b", "X9"] {
        let text = GOOD.replace("name = \"t\"", &format!("name = {good:?}"));
        parse(&text).unwrap_or_else(|e| panic!("{good:?}: {e}"));
    }
}

#[test]
fn a_huge_stop_time_or_a_tiny_step_is_refused_before_anything_is_allocated() {
    for (field, value) in [
        ("stop_time", "1e12"),
        ("stop_time", "1e300"),
        ("step", "1e-300"),
        ("step", "5e-324"),
    ] {
        let text = match field {
            "stop_time" => GOOD.replace("stop_time = 0.01", &format!("stop_time = {value}")),
            _ => GOOD.replace("step = 0.001", &format!("step = {value}")),
        };
        let error = parse(&text).expect_err(value);
        assert!(
            error.contains(&MAX_STEPS.to_string()) || error.contains("whole number"),
            "{field} = {value}: {error}"
        );
    }
}

/// Every numeric field of a scenario, fed 0, negative, NaN, infinite, tiny and huge values:
/// refused with a message or accepted, never a panic.
#[test]
fn no_numeric_scenario_value_panics() {
    let values = [
        "0", "-1", "nan", "inf", "-inf", "1e-300", "5e-324", "1e300", "-1e300",
    ];
    let with_sis = GOOD.replace(
        "library = \"seed000_ramp_high_ay\"",
        "library = \"fmvss126_sine_with_dwell\"\n[manoeuvre.amplitude_from_sis]\nscenario = \"s.toml\"\nlateral_acceleration = \"vehicle.ay\"\nscale = 5.0\nmax_amplitude_deg = 270.0",
    );
    let fields: [(&str, &str, &str); 6] = [
        (GOOD, "step = 0.001", "step = {}"),
        (GOOD, "stop_time = 0.01", "stop_time = {}"),
        (
            GOOD,
            "stop_time = 0.01",
            "stop_time = 0.01\nstart_time = {}",
        ),
        (GOOD, "sample_time = 0.001", "sample_time = {}"),
        (&with_sis, "scale = 5.0", "scale = {}"),
        (
            &with_sis,
            "max_amplitude_deg = 270.0",
            "max_amplitude_deg = {}",
        ),
    ];
    let mut cases = 0;
    for (base, from, template) in fields {
        assert!(base.contains(from), "{from}");
        for value in values {
            let text = base.replace(from, &template.replace("{}", value).replace("}}", "}"));
            let outcome = std::panic::catch_unwind(|| {
                if let Ok(scenario) = parse(&text) {
                    let _ = scenario.step_count();
                    let _ = scenario.manoeuvre();
                }
            });
            assert!(outcome.is_ok(), "panic for {template} = {value}");
            cases += 1;
        }
    }
    assert_eq!(cases, 54);
}

fn model_description() -> String {
    std::fs::read_to_string(runner::workspace_root().join("modelDescription/ReferenceVehicle.xml"))
        .expect("modelDescription/ReferenceVehicle.xml")
}

fn binary_entry() -> String {
    format!(
        "binaries/{}/ReferenceVehicle{}",
        platform_folder().unwrap(),
        std::env::consts::DLL_SUFFIX
    )
}

#[test]
fn a_zip_bomb_is_refused_before_it_is_extracted() {
    let scratch = Scratch::new("bomb");
    let fmu = scratch.0.join("bomb.fmu");
    let xml = model_description();
    // 64 MiB of zeros deflate to about 64 KiB: a ratio of about 1000.
    let zeros = vec![0u8; 64 << 20];
    write_zip(
        &fmu,
        &[
            ("modelDescription.xml", xml.as_bytes()),
            (&binary_entry(), &zeros),
        ],
    );
    let work = scratch.0.join("work");
    let error = LoadedFmu::load(&fmu, &work).expect_err("a bomb");
    assert!(matches!(error, FmuError::TooLarge { .. }), "{error}");
    assert!(error.to_string().contains("ratio"), "{error}");
    assert!(!work.exists(), "nothing was extracted");
}

#[test]
fn an_archive_of_too_many_entries_is_refused() {
    let scratch = Scratch::new("entries");
    let fmu = scratch.0.join("many.fmu");
    let names: Vec<String> = (0..=limits::MAX_ENTRIES)
        .map(|i| format!("resources/{i}"))
        .collect();
    let mut entries: Vec<(&str, &[u8])> = names.iter().map(|n| (n.as_str(), &b""[..])).collect();
    let xml = model_description();
    entries.push(("modelDescription.xml", xml.as_bytes()));
    write_zip(&fmu, &entries);
    let error = LoadedFmu::load(&fmu, &scratch.0.join("work")).expect_err("too many");
    assert!(error.to_string().contains("entries"), "{error}");
}

#[test]
fn a_fifo_is_refused_not_waited_on() {
    let scratch = Scratch::new("fifo");
    let fifo = scratch.0.join("model.fmu");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    let work = scratch.0.join("work");
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = sender.send(LoadedFmu::load(&fifo, &work).map(|_| ()));
    });
    let outcome = receiver
        .recv_timeout(Duration::from_secs(10))
        .expect("LoadedFmu::load hung on a FIFO");
    let error = outcome.expect_err("a FIFO is no FMU");
    assert!(error.to_string().contains("not a regular file"), "{error}");
}

#[test]
fn the_work_folder_is_removed_on_every_exit_path_including_a_panic() {
    let scratch = Scratch::new("work");
    let env = Environment {
        fmu_dir: scratch.0.join("no-fmus"),
        out_dir: scratch.0.join("out"),
    };
    let outcome = std::panic::catch_unwind(|| {
        let work = env.work_folder();
        std::fs::create_dir_all(work.path().join("fmu-1")).unwrap();
        panic!("a failing run");
    });
    assert!(outcome.is_err());
    assert!(!env.work_dir().exists(), "removed after a panic");
    let work = WorkFolder::new(env.work_dir());
    std::fs::create_dir_all(work.path()).unwrap();
    drop(work);
    assert!(!env.work_dir().exists(), "removed after a normal end");
}

#[test]
fn a_failed_run_removes_the_previous_csv() {
    let scratch = Scratch::new("csv");
    let env = Environment {
        fmu_dir: scratch.0.join("no-fmus"),
        out_dir: scratch.0.join("out"),
    };
    std::fs::create_dir_all(&env.out_dir).unwrap();
    let previous = env.out_dir.join("t.csv");
    std::fs::write(&previous, "time\n0\n").unwrap();
    let scenario = parse(GOOD).unwrap();
    let outcome = runner::run_scenario(scenario, &env, &[], false, |_| {});
    assert!(outcome.is_err(), "no FMUs in {}", env.fmu_dir.display());
    assert!(!previous.exists(), "the previous run's CSV looked current");
}

#[test]
fn inspect_fails_when_the_binary_cannot_be_loaded() {
    let scratch = Scratch::new("inspect-binary");
    let fmu = scratch.0.join("broken.fmu");
    let xml = model_description();
    write_zip(
        &fmu,
        &[
            ("modelDescription.xml", xml.as_bytes()),
            (&binary_entry(), b"not a shared library"),
        ],
    );
    let mut listing = Vec::new();
    let error = runner::inspect(&fmu, &scratch.0.join("work"), &mut listing)
        .expect_err("a binary that cannot be loaded");
    assert!(listing.is_empty(), "nothing listed for a broken FMU");
    let message = format!("{error:#}");
    assert!(message.contains("broken.fmu"), "{message}");
}

/// The packaged vehicle FMU with its modelDescription's GUID changed.
fn fmu_with_changed_guid(scratch: &Scratch) -> PathBuf {
    let original = packaged_fmus().join("ReferenceVehicle.fmu");
    let mut archive = zip::ZipArchive::new(std::fs::File::open(original).unwrap()).unwrap();
    let mut entries = Vec::new();
    for index in 0..archive.len() {
        let mut entry = archive.by_index(index).unwrap();
        if entry.is_dir() {
            continue;
        }
        let name = entry.name().unwrap().to_string();
        let mut data = Vec::new();
        std::io::Read::read_to_end(&mut entry, &mut data).unwrap();
        if name == "modelDescription.xml" {
            let xml = String::from_utf8(data).unwrap();
            let start = xml.find("guid=\"").unwrap() + 6;
            data = format!(
                "{}{{00000000-dead-beef-0000-000000000000}}{}",
                &xml[..start],
                &xml[start + xml[start..].find('"').unwrap()..]
            )
            .into_bytes();
        }
        entries.push((name, data));
    }
    let fmu = scratch.0.join("other-guid.fmu");
    let borrowed: Vec<(&str, &[u8])> = entries
        .iter()
        .map(|(n, d)| (n.as_str(), d.as_slice()))
        .collect();
    write_zip(&fmu, &borrowed);
    fmu
}

#[test]
fn inspect_instantiates_and_fails_on_a_guid_the_binary_does_not_know() {
    // Packaged FMUs.
    let scratch = Scratch::new("inspect-guid");
    let mut listing = Vec::new();
    let good = packaged_fmus().join("ReferenceVehicle.fmu");
    runner::inspect(&good, &scratch.0.join("work"), &mut listing).expect("the packaged FMU");
    let listing = String::from_utf8(listing).unwrap();
    assert!(listing.contains("instantiated") && listing.contains("steering_angle"));
    let fmu = fmu_with_changed_guid(&scratch);
    let error = runner::inspect(&fmu, &scratch.0.join("work"), &mut Vec::new())
        .expect_err("a GUID the binary does not know");
    assert!(
        format!("{error:#}").contains("fmi2Instantiate"),
        "{error:#}"
    );
}

/// A writer whose reader went away, as stdout under `| head`.
struct ClosedPipe;

impl Write for ClosedPipe {
    fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
        Err(std::io::ErrorKind::BrokenPipe.into())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn inspect_into_a_closed_pipe_ends_quietly() {
    // Packaged FMUs.
    let scratch = Scratch::new("inspect-pipe");
    let good = packaged_fmus().join("ReferenceVehicle.fmu");
    let error = runner::inspect(&good, &scratch.0.join("work"), &mut ClosedPipe)
        .expect_err("the pipe is closed");
    assert!(runner::is_broken_pipe(&error), "{error:#}");
}

#[test]
fn a_seed_variable_must_be_an_integer_parameter() {
    // Packaged FMUs.
    let scratch = Scratch::new("seed-var");
    let scenario = parse(GOOD).unwrap();
    let plan = Plan::new(scenario, &packaged_fmus(), &scratch.0.join("work")).unwrap();
    for (name, expected) in [
        ("ekf.estimator", "Enumeration"),
        ("vehicle.mass", "Real"),
        ("vehicle.vy", "Integer parameter"),
    ] {
        let r = VarRef::parse(name).unwrap();
        let error = montecarlo::run(&plan, 2, 1, &[r], &|| {}).expect_err(name);
        assert!(error.to_string().contains(expected), "{name}: {error}");
    }
    let error = montecarlo::run(&plan, usize::MAX, 1, &[], &|| {}).expect_err("runs");
    assert!(error.to_string().contains("--runs"), "{error}");
}
