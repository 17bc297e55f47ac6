//! The project's own test drives: a ReferenceVehicle run (scenario
//! `harness/logs/record_ford_escort.toml`, co-simulated by the master) written as a log the way
//! a car's data logger would: CAN units and signs, no torques, multi-rate channels, jittered time
//! stamps, a text column; as CSV and as MDF4. `harness/logs/ford_escort_sis.{csv,mf4}` and the
//! drive past the limit `ford_escort_limit.csv` (`record_ford_escort_limit.toml`) are made by
//! `cargo run --release -p harness --example record_example_log`, and the tests make fresh ones.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use fmi_master::cosim::{ParameterValue, RunResult};
use fmi_master::recording::partial_name;
use fmi_master::runner::{run_scenario, workspace_root, Environment};
use fmi_master::scenario::{Scenario, VarRef};
use mf4_rs::blocks::common::DataType;
use mf4_rs::writer::MdfWriter;

use super::units::STANDARD_GRAVITY;

/// The Ford Escort's steering ratio (fmu-src/reference-vehicle/cars/ford_escort.ssv).
pub const STEERING_RATIO: f64 = 16.0;

/// A log column: its name, the recorded variable, factor from SI to the logged unit, and
/// whether it comes every 20 ms (the wheel speeds) instead of every 10 ms.
struct LogColumn {
    name: &'static str,
    variable: &'static str,
    factor: f64,
    slow: bool,
}

fn log_columns() -> Vec<LogColumn> {
    use std::f64::consts::PI;
    let deg = 180.0 / PI;
    let column = |name, variable, factor, slow| LogColumn {
        name,
        variable,
        factor,
        slow,
    };
    vec![
        // Positive to the right, as many steering-angle sensors count: the map's sign = -1.
        column(
            "steering_wheel_angle",
            "manoeuvre.steering_angle",
            -deg * STEERING_RATIO,
            false,
        ),
        column("yaw_rate", "vehicle.yaw_rate_meas", deg, false),
        column(
            "lateral_acceleration",
            "vehicle.ay_meas",
            1.0 / STANDARD_GRAVITY,
            false,
        ),
        // The ESC sensor cluster's longitudinal accelerometer, positive forward: the example
        // map leaves it out (its figures are those of a log without it), a map for the grip
        // model takes it (README, "Which model").
        column(
            "longitudinal_acceleration",
            "vehicle.ax_meas",
            1.0 / STANDARD_GRAVITY,
            false,
        ),
        column("vehicle_speed", "vehicle.vx_meas", 3.6, false),
        column(
            "wheel_speed_front",
            "vehicle.omega_front_meas",
            30.0 / PI,
            true,
        ),
        column(
            "wheel_speed_rear",
            "vehicle.omega_rear_meas",
            30.0 / PI,
            true,
        ),
        column("sideslip_ref", "vehicle.sideslip", deg, false),
        column("vy_ref", "vehicle.vy", 1.0, false),
        column("yaw_rate_ref", "vehicle.yaw_rate", deg, false),
    ]
}

/// Logger time stamp of row `n` of a 10 ms log: up to ±2 ms of deterministic jitter.
fn stamp(t: f64, n: usize) -> f64 {
    t + 0.002 * (1.7 * n as f64).sin()
}

/// The recorded drive of the example log (`harness/logs/record_ford_escort.toml`).
pub fn record_drive(fmu_dir: &Path, out_dir: &Path) -> Result<RunResult> {
    record_scenario(fmu_dir, "record_ford_escort.toml", out_dir, &[])
}

/// The drive of the scenario file `name` in `harness/logs`, with its parameters overridden by
/// `overrides` (as `harness run --set`: the same drive on another road, say).
pub fn record_scenario(
    fmu_dir: &Path,
    name: &str,
    out_dir: &Path,
    overrides: &[(VarRef, ParameterValue)],
) -> Result<RunResult> {
    let fmu_dir = &fmi_master::runner::packaged_fmus_in(fmu_dir)?;
    let scenario = Scenario::from_file(&workspace_root().join("harness/logs").join(name))?;
    let env = Environment {
        fmu_dir: fmu_dir.to_path_buf(),
        out_dir: out_dir.join("recording"),
    };
    let output = run_scenario(scenario, &env, overrides, false, |_| {})?;
    let _ = std::fs::remove_dir_all(env.work_dir());
    Ok(output.result)
}

fn column<'a>(run: &'a RunResult, name: &str) -> Result<&'a [f64]> {
    run.column(name)
        .ok_or_else(|| anyhow!("the recording has no column {name}"))
}

/// Writes the drive as `<stem>.csv` in `dir`; returns its path.
pub fn write_csv(run: &RunResult, dir: &Path, stem: &str) -> Result<PathBuf> {
    let columns = log_columns();
    let data: Vec<&[f64]> = columns
        .iter()
        .map(|c| column(run, c.variable))
        .collect::<Result<_>>()?;
    let mut text = String::from("time,");
    text += &columns.iter().map(|c| c.name).collect::<Vec<_>>().join(",");
    text += ",gear\n";
    for (n, &t) in run.times.iter().enumerate() {
        text += &format!("{:.4}", stamp(t, n));
        for (c, values) in columns.iter().zip(&data) {
            text.push(',');
            if !c.slow || n % 2 == 0 {
                text += &format!("{:.6}", values[n] * c.factor);
            }
        }
        text += ",D\n";
    }
    let path = dir.join(format!("{stem}.csv"));
    let partial = partial_name(&path);
    std::fs::write(&partial, text).with_context(|| format!("writing {}", partial.display()))?;
    renamed(&partial, &path)
}

/// Writes the drive as `<stem>.mf4` in `dir` (MDF 4, two channel groups: the 10 ms signals and
/// the 20 ms wheel speeds, each with its own master channel `time`); returns its path.
pub fn write_mf4(run: &RunResult, dir: &Path, stem: &str) -> Result<PathBuf> {
    let path = dir.join(format!("{stem}.mf4"));
    let partial = partial_name(&path);
    let text_path = partial
        .to_str()
        .ok_or_else(|| anyhow!("{} is not UTF-8", path.display()))?;
    let fail = |e: mf4_rs::error::MdfError| anyhow!("writing {}: {e:?}", path.display());
    let mut writer = MdfWriter::new(text_path).map_err(fail)?;
    writer.init_mdf_file().map_err(fail)?;
    // A fixed start (midnight UTC, 1 Jan 2000, a simulated drive has no date): the same drive gives
    // the same file, byte for byte.
    const START_NS: u64 = 946_684_800_000_000_000;
    writer.set_start_time(START_NS, 0, 0, 0, 0).map_err(fail)?;
    let columns = log_columns();
    for slow in [false, true] {
        let group: Vec<&LogColumn> = columns.iter().filter(|c| c.slow == slow).collect();
        let rows: Vec<usize> = (0..run.times.len())
            .filter(|n| !slow || n % 2 == 0)
            .collect();
        let cg = writer.add_channel_group(None, |_| {}).map_err(fail)?;
        let time = writer
            .add_channel(&cg, None, |ch| {
                ch.data_type = DataType::FloatLE;
                ch.bit_count = 64;
                ch.name = Some("time".into());
            })
            .map_err(fail)?;
        writer.set_time_channel(&time).map_err(fail)?;
        let mut previous = time;
        for c in &group {
            previous = writer
                .add_channel(&cg, Some(&previous), |ch| {
                    ch.data_type = DataType::FloatLE;
                    ch.bit_count = 64;
                    ch.name = Some(c.name.into());
                })
                .map_err(fail)?;
        }
        let mut table: Vec<Vec<f64>> = vec![rows.iter().map(|&n| stamp(run.times[n], n)).collect()];
        for c in &group {
            let values = column(run, c.variable)?;
            table.push(rows.iter().map(|&n| values[n] * c.factor).collect());
        }
        writer.start_data_block_for_cg(&cg, 0).map_err(fail)?;
        let slices: Vec<&[f64]> = table.iter().map(Vec::as_slice).collect();
        writer.write_columns_f64(&cg, &slices).map_err(fail)?;
        writer.finish_data_block(&cg).map_err(fail)?;
    }
    writer.finalize().map_err(fail)?;
    renamed(&partial, &path)
}

/// Files are written under a temporary name and renamed when complete.
fn renamed(partial: &Path, path: &Path) -> Result<PathBuf> {
    std::fs::rename(partial, path)
        .with_context(|| format!("renaming {} to {}", partial.display(), path.display()))?;
    Ok(path.to_path_buf())
}
