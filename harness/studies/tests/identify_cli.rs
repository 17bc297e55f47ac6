//! `harness identify`: the command on a small simulated data set recovers model C's parameters,
//! a recorded CSV (the same data, columns shuffled) gives the same result, parallel noise seeds
//! equal single runs, and bad CSV files and identification files are refused with a message
//! naming the file, the line/column or field and what was expected. Also: every command ends
//! quietly when its output pipe is closed.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fmi_master::runner::scenario_dir;
use harness::identify::{self, JobData, JobOverrides};

use crate::scratch::Scratch;

const HARNESS: &str = env!("CARGO_BIN_EXE_harness");

/// Seed 003's truth and start (003: 3.18, §3.2).
const TRUTH: [f64; 4] = [8.36, 7.78, 0.62, 1.014];
const START: [f64; 4] = [7.942, 7.386, 0.56, 0.91];

fn harness(args: &[&str]) -> Output {
    Command::new(HARNESS)
        .args(args)
        .output()
        .expect("the harness binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).to_string()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The rows of a CSV written by the harness, as header -> column.
fn read_table(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header = reader.headers().unwrap().iter().map(String::from).collect();
    let rows = reader
        .records()
        .map(|r| r.unwrap().iter().map(String::from).collect())
        .collect();
    (header, rows)
}

/// The last iteration's parameters of each run in history.csv, keyed by run label.
fn final_parameters(history: &Path) -> Vec<(String, [f64; 4])> {
    let (header, rows) = read_table(history);
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let columns = ["Csf", "Csr", "m_over_J", "lf"].map(column);
    let mut out: Vec<(String, [f64; 4])> = Vec::new();
    for row in rows {
        let p = columns.map(|c| row[c].parse::<f64>().unwrap());
        match out.iter_mut().find(|(label, _)| *label == row[0]) {
            Some(entry) => entry.1 = p,
            None => out.push((row[0].clone(), p)),
        }
    }
    out
}

fn relative_errors(p: &[f64; 4]) -> [f64; 4] {
    std::array::from_fn(|j| ((p[j] - TRUTH[j]) / TRUTH[j]).abs())
}

/// A small seed-003 data set: 200 samples, 25 particles (the seed: 500 and 50), so that the
/// test stays fast while the identification still has to work.
fn small_identification_file(dir: &Path, name: &str, noise_seeds: &str) -> PathBuf {
    write(
        dir,
        &format!("{name}.toml"),
        &format!(
            r#"
name = "{name}"
[simulation]
samples = 200
noise_seeds = {noise_seeds}
[identification]
particles = 25
"#
        ),
    )
}

#[test]
fn identifies_a_simulated_data_set_and_the_same_data_as_csv() {
    let dir = Scratch::new("identify");
    let file = small_identification_file(&dir.0, "small", "[4]");
    let out = dir.0.join("out");
    let output = harness(&[
        "identify",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("noise seed 4") && stdout.contains("Table 3.1"),
        "{stdout}"
    );

    let folder = out.join("small");
    let png = std::fs::read(folder.join("convergence.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let runs = final_parameters(&folder.join("history.csv"));
    assert_eq!(runs.len(), 1);
    let (label, identified) = &runs[0];
    assert_eq!(label, "noise seed 4");
    // From 5-10 % off at the start to well below: the stiffnesses within 1.5 %, the weakly
    // determined m/J and lf (003: §3.2) within 3 %, each at least 3 times closer than the start.
    let errors = relative_errors(identified);
    let start_errors = relative_errors(&START);
    for j in 0..4 {
        let limit = if j < 2 { 0.015 } else { 0.03 };
        assert!(
            errors[j] < limit && errors[j] < start_errors[j] / 3.0,
            "parameter {j}: identified {identified:?}, relative errors {errors:?}"
        );
    }
    // The history starts at the start and records every iteration.
    let (header, rows) = read_table(&folder.join("history.csv"));
    let csf = header.iter().position(|h| h == "Csf").unwrap();
    assert_eq!(rows[0][csf].parse::<f64>().unwrap(), START[0]);
    assert!(rows.len() >= 2);
    assert!(header.iter().any(|h| h == "rel_error_lf_percent"));

    // The simulated data set, written as CSV with its columns in another order, identified as a
    // recorded data set: the same numbers (the columns are read by name, nothing is lost in the
    // number format).
    let data = folder.join("data_seed4.csv");
    let (header, rows) = read_table(&data);
    let order = [6, 3, 0, 5, 1, 4, 2];
    let mut shuffled = String::from("# the data of noise seed 4, columns shuffled\n");
    shuffled += &order.map(|c| header[c].as_str()).join(",");
    shuffled.push('\n');
    for row in rows {
        shuffled += &order.map(|c| row[c].as_str()).join(",");
        shuffled.push('\n');
    }
    write(&dir.0, "recorded.csv", &shuffled);
    // Same identification settings as the simulated run (25 particles), through a file that
    // points at the CSV.
    let recorded = write(
        &dir.0,
        "recorded.toml",
        "name = \"recorded\"\ndata = \"recorded.csv\"\n\
         true_parameters = [8.36, 7.78, 0.62, 1.014]\n[identification]\nparticles = 25\n",
    );
    let output = harness(&[
        "identify",
        recorded.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let from_csv = final_parameters(&out.join("recorded").join("history.csv"));
    assert_eq!(from_csv.len(), 1);
    for j in 0..4 {
        let difference = (from_csv[0].1[j] - identified[j]).abs() / identified[j];
        assert!(
            difference == 0.0,
            "CSV {:?} vs simulated {identified:?}",
            from_csv[0].1
        );
    }
}

#[test]
fn parallel_noise_seeds_give_the_single_runs_results() {
    let dir = Scratch::new("identify");
    let file = write(
        &dir.0,
        "tiny.toml",
        r#"
name = "tiny"
[simulation]
samples = 60
[identification]
particles = 12
max_iterations = 3
"#,
    );
    let load = |overrides: JobOverrides| identify::load(&file, &overrides).unwrap();
    let both = load(JobOverrides {
        noise_seed: Some(7),
        seeds: Some(2),
        truth: None,
    });
    assert_eq!(both.config.noise_seeds, vec![7, 8]);
    let together = identify::run(&both, &|| {}).unwrap();
    for (index, seed) in [7u64, 8].into_iter().enumerate() {
        let alone = identify::run(
            &load(JobOverrides {
                noise_seed: Some(seed),
                seeds: None,
                truth: None,
            }),
            &|| {},
        )
        .unwrap();
        assert_eq!(alone.runs.len(), 1);
        assert_eq!(together.runs[index].noise_seed, Some(seed));
        assert_eq!(together.runs[index].result, alone.runs[0].result);
    }
}

#[test]
fn the_shipped_file_is_seed_003_section_3_2() {
    let path = scenario_dir().join("identification/seed003_identification.toml");
    let job = identify::load(&path, &JobOverrides::default()).unwrap();
    assert_eq!(job.data, JobData::Simulated);
    assert_eq!(job.truth, Some(TRUTH));
    let library = harness::seed003::Seed003Config::default();
    assert_eq!(
        job.config,
        harness::seed003::Seed003Config {
            noise_seeds: vec![library.noise_seeds[0]],
            ..library
        }
    );
}

// ------------------------------------------------------------------------------------------
// Bad data sets

const GOOD_CSV: &str = "time,dvx_ref_dt,steering_angle,vx_ref,vy_ref,yaw_rate,yaw_angle
0,0.1,-0.05,14,0.2,-0.44,0.12
0.01,0.1,-0.05,14.001,0.21,-0.43,0.115
0.02,0.1,-0.049,14.002,0.22,-0.42,0.11
";

fn csv_error(text: &str) -> String {
    let dir = Scratch::new("identify");
    let path = write(&dir.0, "drive.csv", text);
    match identify::read_csv(&path) {
        Ok(data) => panic!("accepted {data:?} from:\n{text}"),
        Err(e) => format!("{e:#}"),
    }
}

/// [`csv_error`] of `text` names every one of `parts`.
fn assert_csv_refused(text: &str, parts: &[&str]) {
    assert_names(&csv_error(text), parts);
}

fn assert_names(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(message.contains(part), "{part:?} missing in: {message}");
    }
}

#[test]
fn a_good_csv_is_read_with_its_sample_time_and_missing_measurements() {
    let dir = Scratch::new("identify");
    let text = GOOD_CSV.replace("0.21,-0.43", ",NaN");
    let data = identify::read_csv(&write(&dir.0, "drive.csv", &text)).unwrap();
    assert_eq!(data.len(), 3);
    assert!((data.sample_time - 0.01).abs() < 1e-15);
    assert_eq!(data.inputs[1], [0.1, -0.05, 14.001]);
    assert!(data.measurements[1][0].is_nan() && data.measurements[1][1].is_nan());
    assert_eq!(data.measurements[1][2], 0.115);
}

#[test]
fn a_bad_number_names_file_line_and_column() {
    assert_csv_refused(
        &GOOD_CSV.replace("-0.05,14.001", "abc,14.001"),
        &[
            "drive.csv",
            "line 3",
            "column 3",
            "steering_angle",
            "\"abc\" is not a number",
            "rad",
        ],
    );
}

#[test]
fn comment_lines_count_in_the_line_number() {
    let text =
        format!("# drive of 2017-05-04\n# second comment\n{GOOD_CSV}").replace("14.002", "x");
    assert_csv_refused(&text, &["line 6", "column 4", "vx_ref"]);
}

#[test]
fn a_missing_input_is_refused_but_a_missing_measurement_is_not() {
    assert_csv_refused(
        &GOOD_CSV.replace("0.01,0.1,", "0.01,,"),
        &[
            "line 3",
            "column 2",
            "dvx_ref_dt",
            "empty",
            "only measurements may be missing",
        ],
    );
    assert_csv_refused(
        &GOOD_CSV.replace("0.22,-0.42", "inf,-0.42"),
        &["line 4", "column 5", "vy_ref", "not a finite number"],
    );
}

#[test]
fn header_mistakes_name_the_column() {
    assert_csv_refused(
        &GOOD_CSV.replace("yaw_rate", "yawrate"),
        &[
            "line 1",
            "column 6",
            "unknown column \"yawrate\"",
            "time, dvx_ref_dt",
        ],
    );
    assert_csv_refused(
        &GOOD_CSV.replace("vx_ref,", "vy_ref,"),
        &["line 1", "column 5", "appears twice", "column 4"],
    );
    assert_csv_refused(
        &GOOD_CSV.replace(",yaw_angle", "").replace(",0.12\n", "\n"),
        &["line 1", "missing column \"yaw_angle\""],
    );
}

#[test]
fn a_short_row_names_its_line() {
    assert_csv_refused(
        &GOOD_CSV.replace("14.001,0.21,", "14.001,"),
        &["drive.csv", "line 3", "6 fields, expected 7"],
    );
}

#[test]
fn time_must_increase_uniformly() {
    assert_csv_refused(
        &GOOD_CSV.replace("0.02,", "0.01,"),
        &[
            "line 4",
            "column 1",
            "not after the previous sample",
            "strictly increasing",
        ],
    );
    let uneven = GOOD_CSV.replace("0.02,", "0.025,") + "0.03,0.1,-0.049,14.003,0.23,-0.41,0.105\n";
    assert_csv_refused(&uneven, &["line 4", "0.015", "uniformly spaced"]);
}

#[test]
fn too_little_data_is_refused() {
    assert_csv_refused("", &["drive.csv", "empty", "header"]);
    let one_row: String = GOOD_CSV.lines().take(2).map(|l| format!("{l}\n")).collect();
    assert_csv_refused(&one_row, &["1 data rows", "at least 2"]);
    assert_csv_refused(
        &GOOD_CSV
            .replace(",0.12\n", ",\n")
            .replace(",0.115\n", ",\n")
            .replace(",0.11\n", ",\n"),
        &["no row has all three measurements"],
    );
}

/// Runs the command, which must fail; its error output.
fn refused(args: &[&str]) -> String {
    let output = harness(args);
    assert!(!output.status.success(), "{args:?} succeeded");
    stderr(&output)
}

/// `harness identify` on the file `name` in `dir` holding `text` must fail naming every one of
/// `parts`.
fn assert_data_refused(dir: &Path, name: &str, text: &str, parts: &[&str]) {
    let path = write(dir, name, text);
    let out = dir.join("out");
    let e = refused(&[
        "identify",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_names(&e, parts);
}

#[test]
fn the_command_names_a_missing_or_wrong_file() {
    let e = refused(&[
        "identify",
        "/nonexistent/drive.csv",
        "--out",
        "/nonexistent/out",
    ]);
    assert_names(&e, &["/nonexistent/drive.csv"]);

    let dir = Scratch::new("identify");
    let out = dir.0.to_str().unwrap();
    let bad = GOOD_CSV.replace("0.22", "oops");
    let parts = ["drive.csv", "line 4", "column 5", "vy_ref"];
    assert_data_refused(&dir.0, "drive.csv", &bad, &parts);
    assert_data_refused(
        &dir.0,
        "drive.txt",
        GOOD_CSV,
        &["drive.txt", ".csv", ".toml"],
    );

    let good = write(&dir.0, "good.csv", GOOD_CSV);
    let good = good.to_str().unwrap();
    let e = refused(&["identify", good, "--truth", "8.36,7.78", "--out", out]);
    assert_names(&e, &["--truth", "2 values", "expected 4"]);
    let e = refused(&["identify", good, "--seeds", "3", "--out", out]);
    assert_names(&e, &["--seeds", "recorded data set"]);
}

/// `rows` samples at 10 ms of a constant speed and steering angle, every state measured 0.
fn constant_drive_csv(rows: usize, speed: f64, steering: f64) -> String {
    let mut text =
        String::from("time,dvx_ref_dt,steering_angle,vx_ref,vy_ref,yaw_rate,yaw_angle\n");
    for k in 0..rows {
        text += &format!("{},0,{steering},{speed},0,0,0\n", k as f64 * 0.01);
    }
    text
}

/// A standing vehicle could give m/J = 564 and exit 0. Data that cannot determine the
/// parameters are refused, naming the file and the reason, with a non-zero exit.
#[test]
fn data_that_cannot_determine_the_parameters_are_refused() {
    let dir = Scratch::new("identify");
    assert_data_refused(
        &dir.0,
        "standing.csv",
        &constant_drive_csv(50, 0.0, 0.05),
        &["standing.csv", "row 0", "Vx_ref = 0", "low-speed guard"],
    );
    assert_data_refused(
        &dir.0,
        "straight.csv",
        &constant_drive_csv(50, 14.0, 0.0),
        &["straight.csv", "do not determine", "Csf", "Cramér-Rao"],
    );
}

// ------------------------------------------------------------------------------------------
// Bad identification files

fn file_error(text: &str) -> String {
    let dir = Scratch::new("identify");
    let path = write(&dir.0, "ident.toml", text);
    match identify::load(&path, &JobOverrides::default()) {
        Ok(job) => panic!("accepted {job:?} from:\n{text}"),
        Err(e) => format!("{e:#}"),
    }
}

const GOOD_FILE: &str = r#"
name = "t"
[simulation]
samples = 100
[identification]
particles = 20
"#;

#[test]
fn a_good_file_overrides_only_what_it_names() {
    let dir = Scratch::new("identify");
    let job = identify::load(
        &write(&dir.0, "t.toml", GOOD_FILE),
        &JobOverrides::default(),
    )
    .unwrap();
    assert_eq!(job.config.samples, 100);
    assert_eq!(job.config.filter.particle_count, 20);
    assert_eq!(job.config.sample_time, 0.01);
    assert_eq!(job.config.noise_seeds.len(), 1);
}

#[test]
fn unknown_fields_and_syntax_errors_name_file_and_position() {
    let e = file_error(&GOOD_FILE.replace("particles", "particels"));
    assert_names(&e, &["ident.toml", "particels", "line 6"]);
    let e = file_error(&GOOD_FILE.replace("samples = 100", "samples = \"many\""));
    assert_names(&e, &["ident.toml", "line 4", "samples"]);
}

#[test]
fn field_errors_name_the_field() {
    for (from, to, field, what) in [
        (
            "samples = 100",
            "samples = 1",
            "simulation.samples",
            "at least 2",
        ),
        (
            "particles = 20",
            "particles = 1",
            "identification.particles",
            "at least 2",
        ),
        (
            "particles = 20",
            "start = [7.9, 7.4, 0.56, 3.0]",
            "identification.start",
            "wheelbase",
        ),
        (
            "particles = 20",
            "start = [7.9, -7.4, 0.56, 0.9]",
            "identification.start",
            "Csr = -7.4",
        ),
        (
            "particles = 20",
            "measurement_noise_std = [0.005, 0.0, 1e-4]",
            "identification.measurement_noise_std",
            "positive",
        ),
        (
            "particles = 20",
            "tolerance = 0.0",
            "identification.tolerance",
            "positive",
        ),
        ("name = \"t\"", "name = \"../t\"", "name", "output folder"),
    ] {
        let e = file_error(&GOOD_FILE.replace(from, to));
        assert_names(&e, &["ident.toml", &format!("field `{field}`"), what]);
    }
}

#[test]
fn exactly_one_data_source() {
    let e = file_error("name = \"t\"\n");
    assert_names(&e, &["ident.toml", "field `data`", "neither"]);
    let e = file_error(&GOOD_FILE.replace("name = \"t\"", "name = \"t\"\ndata = \"d.csv\""));
    assert_names(&e, &["field `data`", "both"]);
    let e = file_error("name = \"t\"\ndata = \"missing.csv\"\n");
    assert_names(&e, &["ident.toml", "field `data`", "missing.csv"]);
}

#[test]
fn a_file_can_point_at_a_csv_with_its_truth() {
    let dir = Scratch::new("identify");
    write(&dir.0, "drive.csv", GOOD_CSV);
    let path = write(
        &dir.0,
        "ident.toml",
        "name = \"t\"\ndata = \"drive.csv\"\ntrue_parameters = [8.36, 7.78, 0.62, 1.014]\n",
    );
    let job = identify::load(&path, &JobOverrides::default()).unwrap();
    assert_eq!(job.truth, Some(TRUTH));
    assert!(matches!(&job.data, JobData::Recorded { data, .. } if data.len() == 3));
    // A CSV error inside it names both files.
    write(&dir.0, "drive.csv", &GOOD_CSV.replace("14.002", "?"));
    let e = format!(
        "{:#}",
        identify::load(&path, &JobOverrides::default()).unwrap_err()
    );
    assert_names(
        &e,
        &[
            "ident.toml",
            "field `data`",
            "drive.csv",
            "line 4",
            "vx_ref",
        ],
    );
}

#[test]
fn a_co_simulation_scenario_is_recognised() {
    let path = scenario_dir().join("seed000_ramp_high_ay.toml");
    let e = format!(
        "{:#}",
        identify::load(&path, &JobOverrides::default()).unwrap_err()
    );
    assert_names(
        &e,
        &[
            "seed000_ramp_high_ay.toml",
            "co-simulation scenario",
            "harness run",
        ],
    );
}

#[test]
fn overrides_that_do_not_fit_the_data_are_refused() {
    let dir = Scratch::new("identify");
    let path = write(&dir.0, "t.toml", GOOD_FILE);
    let e = identify::load(
        &path,
        &JobOverrides {
            truth: Some(TRUTH),
            ..JobOverrides::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert_names(&e, &["--truth", "simulation.true_parameters"]);
    let e = identify::load(
        &path,
        &JobOverrides {
            seeds: Some(0),
            ..JobOverrides::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert_names(&e, &["--seeds", "at least 1"]);
}

#[test]
fn truth_on_the_command_line_gives_relative_errors_for_a_recorded_set() {
    let dir = Scratch::new("identify");
    let out = dir.0.join("out");
    // A recorded data set that determines the parameters: a small simulated one, as CSV (a
    // few rows are refused as not identifying anything, see
    // data_that_cannot_determine_the_parameters_are_refused).
    let file = small_identification_file(&dir.0, "small", "[4]");
    let output = harness(&[
        "identify",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let good = dir.0.join("good.csv");
    std::fs::copy(out.join("small").join("data_seed4.csv"), &good).unwrap();
    let output = harness(&[
        "identify",
        good.to_str().unwrap(),
        "--truth",
        "8.36,7.78,0.62,1.014",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let (header, rows) = read_table(&out.join("good").join("history.csv"));
    let column = header
        .iter()
        .position(|h| h == "rel_error_Csf_percent")
        .unwrap();
    // Row 0 is the start, 5 % below the truth.
    let start_error: f64 = rows[0][column].parse().unwrap();
    assert!((start_error - 100.0 * (START[0] - TRUTH[0]) / TRUTH[0]).abs() < 1e-9);
}

/// The command's exit status and error output when its reader has gone before it writes: the
/// read end of its stdout pipe is closed right after the start (the child holds only the write
/// end), so its first write fails with EPIPE.
fn into_a_closed_pipe(args: &[&str]) -> Output {
    let mut child = Command::new(HARNESS)
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the harness binary starts");
    drop(child.stdout.take());
    child.wait_with_output().expect("the harness binary ends")
}

#[test]
fn a_closed_pipe_ends_the_command_quietly() {
    // Two commands with their own output code: the library listing and the identification
    // (its header line); every command writes through the one handle main.rs checks for
    // BrokenPipe; a bare `println!` would panic with exit status 101.
    let dir = Scratch::new("identify");
    let file = small_identification_file(&dir.0, "pipe", "[4]");
    let out = dir.0.join("out");
    let identify = [
        "identify",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    for args in [&["manoeuvres"][..], &identify[..]] {
        let output = into_a_closed_pipe(args);
        assert!(output.status.success(), "{args:?}: {}", stderr(&output));
        assert!(
            !stderr(&output).contains("panicked"),
            "{args:?}: {}",
            stderr(&output)
        );
    }
}

/// The sideslip RMSE of `instance` in `harness run`'s score table (its printed form, `{:.4e}`).
fn printed_sideslip_rmse(stdout: &str, instance: &str) -> String {
    stdout
        .lines()
        .map(|line| line.split_whitespace().collect::<Vec<_>>())
        .find(|words| words.len() > 2 && words[0] == "sideslip" && words[1] == instance)
        .map(|words| words[2].to_string())
        .unwrap_or_else(|| panic!("no sideslip row of {instance} in:\n{stdout}"))
}

/// `harness montecarlo` drives the same manoeuvre as `harness run`: a sine with dwell whose
/// amplitude comes from a slowly increasing steer (`[manoeuvre.amplitude_from_sis]`) is resolved
/// before the runs. Skipped, the Monte Carlo runs would drive the library's default amplitude
/// and report errors several times those of the same seed under `harness run`.
#[test]
fn montecarlo_drives_the_sine_with_dwell_that_run_drives() {
    let fmu_dir = fmi_master::runner::packaged_fmu_dir().expect("packaged FMUs");
    let fmu_dir = fmu_dir.to_str().expect("UTF-8 path");
    let scenario = scenario_dir().join("fmvss126_sine_with_dwell.toml");
    let scenario = scenario.to_str().expect("UTF-8 path");
    let dir = Scratch::new("identify");
    let out = |name: &str| dir.0.join(name).to_str().unwrap().to_string();

    let run = harness(&[
        "run",
        scenario,
        "--fmu-dir",
        fmu_dir,
        "--no-plots",
        "--out",
        &out("run"),
        "--set",
        "vehicle.seed=1",
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let run_stdout = String::from_utf8_lossy(&run.stdout).to_string();

    let montecarlo = harness(&[
        "montecarlo",
        scenario,
        "--fmu-dir",
        fmu_dir,
        "--runs",
        "2",
        "--first-seed",
        "1",
        "--instances",
        "vehicle,EKF",
        "--threads",
        "1",
        "--out",
        &out("montecarlo"),
    ]);
    assert!(montecarlo.status.success(), "{}", stderr(&montecarlo));
    let printed = String::from_utf8_lossy(&montecarlo.stdout).to_string();
    assert!(
        printed.contains("sine with dwell: 0.3 g at a steering angle of"),
        "{printed}"
    );

    let runs_csv = Path::new(&out("montecarlo"))
        .join("fmvss126_sine_with_dwell")
        .join("runs.csv");
    let (header, rows) = read_table(&runs_csv);
    let column = header
        .iter()
        .position(|name| name == "EKF.sideslip.rmse")
        .expect("EKF.sideslip.rmse column");
    let first_seed = &rows[0];
    assert_eq!(first_seed[0], "1", "the first row is seed 1");
    let montecarlo_rmse: f64 = first_seed[column].parse().unwrap();
    assert_eq!(
        format!("{montecarlo_rmse:.4e}"),
        printed_sideslip_rmse(&run_stdout, "EKF"),
        "seed 1's EKF sideslip RMSE differs between montecarlo and run"
    );
}
