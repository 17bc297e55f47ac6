//! The real track recording (MBDS, `harness/logs/mbds/`) in the tests: the replay study's
//! representative subset against its committed rows (`docs/data/mbds_replay.csv`, which the
//! full study writes), and `harness fit` of the default model on what the log has (no wheel
//! speeds, no torques).
//!
//! Needs the packaged FMUs (`cargo run --release -p packaging`) in
//! `fmi_master::runner::default_fmu_dir()`.

use std::collections::BTreeMap;

use fmi_master::runner::{default_fmu_dir, workspace_root};
use harness::replay::fit::{fit, FitModel, FitOptions, Written};
use harness::replay::report::{self, score_table, ESTIMATOR};
use harness::replay::study::{cases, Baselines, Case, Study, COMMITTED_CSV, FITTED_MODEL};
use harness::replay::{estimator_path, replay, ReplayOptions};
use harness::summary::HEADER;

use crate::scratch::Scratch;

/// The committed rows by (model, estimator, wheel speeds).
fn committed() -> BTreeMap<(String, String, String), String> {
    let path = workspace_root().join(COMMITTED_CSV);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; write it with `harness replay-study --full --update-committed`",
            path.display()
        )
    });
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some(HEADER.join(",").as_str()),
        "{}",
        path.display()
    );
    lines
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            assert_eq!(fields.len(), 10, "{line}");
            assert_eq!(&fields[..2], ["real", "mbds_laps_2_6"], "{line}");
            (
                (
                    fields[2].to_string(),
                    fields[3].to_string(),
                    fields[4].to_string(),
                ),
                line.to_string(),
            )
        })
        .collect()
}

/// The default configuration (grip model, EKF) with and without wheel speeds, models A and B
/// with them, and the grip model fitted on lap 1 without them, rerun, must give the committed
/// rows to the digit, each better than answering zero sideslip: the committed file is the study's
/// output, not a hand-kept copy (regenerate it with `cargo run --release -p harness --
/// replay-study --full --update-committed` after a change to the estimator).
#[test]
fn the_replay_studys_subset_reproduces_its_committed_rows() {
    let rows = committed();
    for case in cases(true) {
        let key = (
            case.model.clone(),
            case.estimator.clone(),
            case.wheel_speeds_label().to_string(),
        );
        assert!(
            rows.contains_key(&key),
            "{COMMITTED_CSV} lacks the case {key:?}"
        );
    }
    let scratch = Scratch::new("replay-mbds-study");
    let mut study = Study::load(
        &estimator_path(None, &default_fmu_dir()),
        &scratch.0.join("fmu"),
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    study
        .fit_on_lap_1(&scratch.0)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let subset = [
        Case::new(FITTED_MODEL, "ekf", false),
        Case::new("grip", "ekf", true),
        Case::new("grip", "ekf", false),
        Case::new("model_a", "ekf", true),
        Case::new("model_b", "ekf", true),
    ];
    let rerun = study.run_all(&subset).unwrap_or_else(|e| panic!("{e:#}"));
    for row in &rerun {
        let key = (
            row.case.model.clone(),
            row.case.estimator.clone(),
            row.case.wheel_speeds_label().to_string(),
        );
        assert_eq!(
            row.csv_line(),
            rows[&key],
            "rerun against {COMMITTED_CSV}: regenerate it with `cargo run --release -p harness -- replay-study --full --update-committed`"
        );
        // The yardsticks need no filter: zero answers 1.82 deg, as published.
        assert!((row.zero_rmse_deg - study.baselines.published.zero_deg).abs() < 0.005);
        // Model A with the wheel speeds synthesised at the mean radius (3.6 % off each axle's)
        // read them as slip and was worse than zero until the rolling radii were learned.
        assert!(
            row.rmse_deg < row.zero_rmse_deg,
            "{key:?}: {} deg against zero's {}",
            row.rmse_deg,
            row.zero_rmse_deg
        );
    }
    // With the torques unknown, wheel speeds tell the grip model no more than vx_meas does, so
    // leaving them out must cost it little. The unmeasured wheel states wander to 58 % slip,
    // and when their combined-slip side forces fed the yaw-moment error and the saturation
    // test, the filter lost 0.08° and its NEES tripled.
    let grip = |wheel_speeds: bool| {
        rerun
            .iter()
            .find(|row| row.case == Case::new("grip", "ekf", wheel_speeds))
            .expect("the default configuration in the subset")
    };
    let (with, without) = (grip(true), grip(false));
    // The default configuration on a real car told only its basic data: within 0.50 deg on the
    // laps it never saw, with and without wheel speeds.
    for row in [with, without] {
        assert!(
            row.rmse_deg <= 0.50,
            "default configuration, {} wheel speeds: {} deg",
            row.case.wheel_speeds_label(),
            row.rmse_deg
        );
    }
    assert!(
        (without.rmse_deg - with.rmse_deg).abs() < 0.02,
        "without wheel speeds {} deg, with {}",
        without.rmse_deg,
        with.rmse_deg
    );
}

/// `harness fit` of the default model on lap 1 alone, as a new user with this log would run it:
/// no wheel speeds, no torques, the INS sideslip as the training reference. The accelerometer's
/// noise comes from the log (about 1.1 m/s² of vibration where the FMU's default assumes 0.1), and the
/// written file never makes the held-out part of lap 1 worse than the map's parameters.
#[test]
fn fit_of_the_grip_model_on_lap_1_learns_the_sensor_noise_and_never_writes_a_worse_file() {
    let scratch = Scratch::new("replay-mbds-fit");
    let logs = workspace_root().join("harness/logs/mbds");
    let out = scratch.0.join("mbds.ssv");
    let outcome = fit(&FitOptions {
        log: logs.join("mbds_20140222_01_01_03_250lm.csv.gz"),
        map: logs.join("mbds.toml"),
        parameters: None,
        fmu: estimator_path(None, &default_fmu_dir()),
        model: FitModel::default(),
        out: out.clone(),
        train: Some((149.99, 220.0)),
        validate: Some((220.0, 253.46)),
    })
    .unwrap_or_else(|e| panic!("fit: {e:#}"));
    eprintln!("{}", outcome.summary());
    assert_eq!(outcome.model, FitModel::Grip);
    let ay = outcome
        .sensor_noise
        .iter()
        .find(|s| s.parameter == "measurement_noise_std_ay")
        .expect("the ay noise from the log");
    // 1.16 m/s² on 150-220 s, 1.05 over the whole of lap 1: the vibration, not the cornering.
    assert!((1.0..1.3).contains(&ay.std), "{ay:?}");
    assert!(
        !outcome
            .sensor_noise
            .iter()
            .any(|s| s.input.starts_with("omega")),
        "the log has no wheel speeds"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let (before, after) = outcome.rmse("sideslip").expect("a sideslip reference");
    let held_out_rmse = |scores| report::estimator_rmse(scores, "sideslip").unwrap();
    match &outcome.written {
        Written::Fitted => {
            assert!(after <= before, "{before} -> {after} deg written");
            assert!(text.contains("process_noise_std_vy"), "{text}");
        }
        Written::SensorNoise {
            refused, scores, ..
        } => {
            assert!(after > before, "{refused}");
            let noise_alone = held_out_rmse(scores);
            assert!(
                noise_alone <= before,
                "{before} -> {noise_alone} deg written"
            );
            assert!(text.contains("measurement_noise_std_ay"), "{text}");
            assert!(!text.contains("process_noise_std_vy"), "{text}");
            assert!(outcome
                .summary()
                .contains("the sensor noise alone (written)"));
        }
        Written::Start { refused } => {
            assert!(after > before, "{refused}");
            assert!(!text.contains("measurement_noise_std_ay"), "{text}");
            assert!(outcome.summary().contains("NOT WRITTEN"));
        }
    }
    assert!(
        text.contains("<ssv:Enumeration value=\"single_track_grip\"/>"),
        "{text}"
    );
}

/// The recording as a new user replays it after setting the sensors' own noise (the
/// accelerometer's vibration of about 1.05 m/s², the gyro's 0.0047 rad/s: what `harness fit`
/// learns from the log) and without wheel speeds (the log has none). In one corner exit the
/// grip model's tyres saturate in the estimate, the gate lets the gyro in only at its edge and
/// the estimate drifts off the car; the gate must notice the gyro staying far off and re-seed,
/// so that no sideslip error grows beyond a few degrees and the speed stays with the car (a
/// filter that did not: 88° and 26 m/s off, its std 0.2°). The wheels nobody measures report
/// the free rolling the model applies, with a std that says they are not known (their states
/// wandered to 58 % slip).
#[test]
fn with_the_sensors_own_noise_and_no_wheel_speeds_the_filter_never_leaves_the_car() {
    let scratch = Scratch::new("replay-mbds-sensor-noise");
    let logs = workspace_root().join("harness/logs/mbds");
    let car = scratch.0.join("sensor_noise.ssv");
    std::fs::write(&car, SENSOR_NOISE_SSV).unwrap();
    let outcome = replay(&ReplayOptions {
        log: logs.join("mbds_20140222_01_01_03_250lm.csv.gz"),
        map: logs.join("mbds.toml"),
        parameters: Some(car),
        fmu: estimator_path(None, &default_fmu_dir()),
        out: scratch.0.join("replay"),
        plots: false,
    })
    .unwrap_or_else(|e| panic!("replay: {e:#}"));
    let score = |label: &str| {
        outcome
            .scores
            .iter()
            .find(|s| s.label == label && s.estimator == ESTIMATOR)
            .unwrap_or_else(|| panic!("no {label} score in {:?}", outcome.scores))
    };
    let (sideslip, vx) = (score("sideslip"), score("vx"));
    eprintln!("{}", score_table(&outcome.scores));
    assert_eq!(sideslip.non_finite, 0, "{sideslip:?}");
    assert!(
        sideslip.max_abs < 5.0,
        "largest sideslip error {} deg",
        sideslip.max_abs
    );
    assert!(sideslip.rmse < 0.8, "sideslip RMSE {} deg", sideslip.rmse);
    assert!(vx.max_abs < 1.0, "largest vx error {} m/s", vx.max_abs);
    let column = |name: &str| {
        outcome
            .recording
            .column(name)
            .unwrap_or_else(|| panic!("no {name} in the recording"))
    };
    let largest = |name: &str| column(name).iter().map(|x| x.abs()).fold(0.0, f64::max);
    // the wheel states start at the measured speed's free rolling, then nothing corrects them
    let laps_2_6_from = Baselines::read(&logs.join("baselines.toml"))
        .unwrap()
        .laps_2_6_from_s;
    let grid = &outcome.prepared.grid;
    let laps_2_6 = grid.rows_within(laps_2_6_from, grid.time(grid.rows - 1));
    let least_after_a_lap = |name: &str| {
        column(name)[laps_2_6.clone()]
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    };
    let slips = [largest("slip_front_est"), largest("slip_rear_est")];
    assert!(
        slips.iter().all(|&slip| slip < 1e-9),
        "wheel slip {slips:?}"
    );
    let stds = ["omega_front_std", "omega_rear_std"].map(least_after_a_lap);
    assert!(
        stds.iter().all(|&std| std > 10.0),
        "wheel speed std {stds:?} rad/s"
    );
}

/// The sensors' own noise on the MBDS recording, as `harness fit` learns it from lap 1.
const SENSOR_NOISE_SSV: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="sensor_noise">
  <ssv:Parameters>
    <ssv:Parameter name="measurement_noise_std_ay"><ssv:Real value="1.05"/></ssv:Parameter>
    <ssv:Parameter name="measurement_noise_std_yaw_rate"><ssv:Real value="0.0047"/></ssv:Parameter>
  </ssv:Parameters>
</ssv:ParameterSet>
"#;

/// Where a model cannot follow the car its status says so: model B, whose tyres and load
/// transfer are not this car's, has innovations above what its covariance allows (status bit
/// 8192, the NIS over the last second above its 99.9 % quantile) through most of laps 2-6 (64 %
/// of the samples measured), the default grip model hardly ever (0.6 %).
#[test]
fn the_status_says_where_a_model_does_not_follow_the_car() {
    let scratch = Scratch::new("replay-mbds-inconsistent");
    let logs = workspace_root().join("harness/logs/mbds");
    let laps_2_6_from = Baselines::read(&logs.join("baselines.toml"))
        .unwrap()
        .laps_2_6_from_s;
    let share_inconsistent = |name: &str, parameters: Option<&str>| {
        let car = parameters.map(|text| {
            let path = scratch.0.join(format!("{name}.ssv"));
            std::fs::write(&path, text).unwrap();
            path
        });
        let outcome = replay(&ReplayOptions {
            log: logs.join("mbds_20140222_01_01_03_250lm.csv.gz"),
            map: logs.join("mbds.toml"),
            parameters: car,
            fmu: estimator_path(None, &default_fmu_dir()),
            out: scratch.0.join(name),
            plots: false,
        })
        .unwrap_or_else(|e| panic!("replay: {e:#}"));
        let grid = &outcome.prepared.grid;
        let laps_2_6 = grid.rows_within(laps_2_6_from, grid.time(grid.rows - 1));
        let status = outcome.recording.column("status").expect("the status");
        let flagged = status[laps_2_6.clone()]
            .iter()
            .filter(|&&bits| (bits as i64) & 8192 != 0)
            .count();
        flagged as f64 / laps_2_6.len() as f64
    };
    let default = share_inconsistent("default", None);
    let model_b = share_inconsistent("model_b", Some(MODEL_B_SSV));
    assert!(
        default < 0.02,
        "default configuration inconsistent in {default}"
    );
    assert!(model_b > 0.3, "model B inconsistent in {model_b}");
}

/// Model B, the car's basic data from the map.
const MODEL_B_SSV: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="model_b">
  <ssv:Parameters>
    <ssv:Parameter name="model"><ssv:Enumeration value="two_track_3_state"/></ssv:Parameter>
  </ssv:Parameters>
</ssv:ParameterSet>
"#;
