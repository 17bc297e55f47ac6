//! The campaigns' low-speed course, with clean sensors and with a real car's faulty ones
//! (vibrating accelerometer, jittered time stamps, lost samples), on the Ford Escort's full
//! vehicle with the default configuration alone (the grip model's EKF): a small subset of the
//! campaigns, which run every estimator on every car and model in the report.
//!
//! Needs the packaged FMUs, as the other tests of this crate.

use fmi_master::runner::{packaged_fmu_dir, scenario_dir, Environment};
use harness::campaigns::{Campaign, Row, DEFAULT_ESTIMATOR, SHIPPED_CAMPAIGNS};

use crate::scratch::Scratch;

/// The default configuration's row of campaign manoeuvre `manoeuvre` on the Ford Escort, and the
/// run's recorded true speed.
fn default_row(manoeuvre: &str) -> (Row, Vec<f64>) {
    let scratch = Scratch::new("low_speed_campaign");
    let env = Environment {
        fmu_dir: packaged_fmu_dir().expect("packaged FMUs"),
        out_dir: scratch.0.clone(),
    };
    let campaign = Campaign::load(&scenario_dir().join(SHIPPED_CAMPAIGNS))
        .and_then(|c| c.with_estimators(&[DEFAULT_ESTIMATOR]))
        .expect("campaigns");
    let car = campaign.file.dir.join(
        campaign
            .file
            .cars
            .iter()
            .find(|c| c.ends_with("ford_escort.ssv"))
            .expect("the campaigns drive the Ford Escort"),
    );
    let estimator_fmu = campaign.estimator_fmu(&env).expect("estimator FMU");
    let m = campaign.manoeuvre(manoeuvre).expect("a campaign manoeuvre");
    let (output, rows) = campaign
        .run_one(
            campaign.first_reference(),
            &car,
            m,
            m.section.clone(),
            &env,
            &estimator_fmu,
        )
        .unwrap_or_else(|e| panic!("{manoeuvre} runs: {e:#}"));
    let speed = output
        .result
        .column("vehicle.vx")
        .expect("the true speed is recorded")
        .to_vec();
    (rows.into_iter().next().expect("one row"), speed)
}

/// The course stops three times and holds, never rolling back, and reaches 13 m/s; the
/// yardstick is scored beside zero (at these speeds and angles most of the sideslip is the
/// kinematic one, which the steady-state formula has).
fn assert_the_course_was_driven(row: &Row, speed: &[f64]) {
    let lowest = speed.iter().fold(f64::INFINITY, |a, v| a.min(*v));
    let highest = speed.iter().fold(0.0f64, |a, v| a.max(*v));
    assert!(lowest > -0.1, "rolled back to {lowest} m/s");
    assert!((11.0..15.0).contains(&highest), "{highest}");
    // three stops held for at least a second each (10 ms steps)
    let standing: Vec<bool> = speed.iter().map(|v| v.abs() < 0.05).collect();
    let held = standing
        .windows(100)
        .enumerate()
        .filter(|(k, w)| w.iter().all(|s| *s) && (*k == 0 || !standing[k - 1]))
        .count();
    assert!(held >= 3, "{held} stops held 1 s");
    assert!(!row.diverged, "{row:?}");
    assert!(row.yardstick.is_finite() && row.yardstick > 0.0, "{row:?}");
    assert!(row.yardstick < row.zero_baseline, "{row:?}");
    eprintln!(
        "{}: {} RMSE {:.3} deg, zero {:.3} deg, yardstick {:.3} deg, NEES {:.2}: {}",
        row.manoeuvre,
        row.estimator,
        row.rmse.to_degrees(),
        row.zero_baseline.to_degrees(),
        row.yardstick.to_degrees(),
        row.mean_nees,
        row.yardstick_verdict()
    );
}

#[test]
fn the_low_speed_course_stops_holds_and_is_scored_beside_the_yardstick() {
    let (row, speed) = default_row("low_speed_course");
    assert_the_course_was_driven(&row, &speed);
}

#[test]
fn the_course_with_a_real_cars_faulty_sensors_runs_to_its_end() {
    let (row, speed) = default_row("low_speed_course_noisy");
    assert_the_course_was_driven(&row, &speed);
    assert!(row.rmse.is_finite(), "{row:?}");
}
