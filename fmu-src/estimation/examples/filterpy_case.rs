//! The Rust side of the filterpy 2.0.0 comparison (tests/filterpy/): runs the EKF, the 2n UKF
//! and the scaled UKF on model A over a seed-000 manoeuvre and writes, for every sample, the
//! input, the measurement and each filter's state and covariance after the update.
//!
//! `cargo run --release -p estimation --example filterpy_case -- <out.csv> [alpha beta kappa]`
//!
//! Case: high steering ramp with braking (000 §7.2.1), filters at T = 10 ms (a seed sample time,
//! 000 §7.2.2), truth model A at 1 ms with the noise of SPEC §7, noise seed 11. Columns:
//! `t, u0..u2, y0..y3`, then for `ekf`, `ukf`, `ukf_scaled`: `x0..x4` and `P00..P44` (row-major).
//! The first row holds the initial estimate (no filter step yet); every later row is the result of
//! `predict(u(k-1))` followed by `update(y(k), u(k))`.

#[path = "../tests/seed000_support/mod.rs"]
mod seed000_support;

use std::io::Write;

use estimation::kalman::{
    ExtendedKalmanFilter, InitialEstimate, SigmaPoints, UnscentedKalmanFilter,
};
use estimation::models::single_track::SingleTrackEstimationModel;
use estimation::Estimator;
use nalgebra::SVector;
use vehicle_models::manoeuvre::SeedManoeuvre;

const SAMPLE_TIME: f64 = 0.01;
const NOISE_SEED: u64 = 11;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        return Err("usage: filterpy_case <out.csv> [alpha beta kappa]".into());
    };
    let numbers: Vec<f64> = args[1..]
        .iter()
        .map(|a| a.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("alpha, beta and kappa must be numbers: {e}"))?;
    let (alpha, beta, kappa) = match numbers.as_slice() {
        [] => (0.5, 2.0, 0.0),
        [a, b, k] => (*a, *b, *k),
        _ => return Err("give all three of alpha, beta, kappa or none".into()),
    };
    let reference =
        seed000_support::reference_run(SeedManoeuvre::HighRampBraking, SAMPLE_TIME, NOISE_SEED);
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME)?;
    // A start off the truth, so that the filters have something to correct. The initial variances
    // are moderate on purpose: with P(0) some 1e6 times R the first update is so ill-conditioned
    // (cond S ~ 1e6) that any two correct implementations differ by ~1e-8 in that step's P.
    let initial = InitialEstimate::diagonal(
        SVector::<f64, 5>::from([17.9, 0.01, 0.001, 59.9, 60.1]),
        SVector::<f64, 5>::from([1e-2, 1e-4, 1e-4, 1e-2, 1e-2]),
    );
    let mut ekf = ExtendedKalmanFilter::new(model.clone(), &initial)?;
    let mut ukf = UnscentedKalmanFilter::new(model.clone(), SigmaPoints::Symmetric, &initial)?;
    let mut scaled =
        UnscentedKalmanFilter::new(model, SigmaPoints::scaled(alpha, beta, kappa), &initial)?;

    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut header = vec!["t".to_string()];
    header.extend((0..3).map(|i| format!("u{i}")));
    header.extend((0..4).map(|i| format!("y{i}")));
    for name in ["ekf", "ukf", "ukf_scaled"] {
        header.extend((0..5).map(|i| format!("{name}_x{i}")));
        header.extend((0..25).map(|i| format!("{name}_P{}{}", i / 5, i % 5)));
    }
    writeln!(
        out,
        "# alpha={alpha} beta={beta} kappa={kappa} sample_time={SAMPLE_TIME}"
    )?;
    writeln!(out, "{}", header.join(","))?;
    for k in 0..reference.times.len() {
        if k > 0 {
            let (u_prev, u, y) = (
                &reference.inputs[k - 1],
                &reference.inputs[k],
                &reference.measurements[k],
            );
            for filter in [
                &mut ekf as &mut dyn Estimator<5, 4, 3>,
                &mut ukf,
                &mut scaled,
            ] {
                filter
                    .predict(u_prev)
                    .map_err(|e| format!("predict at step {k}: {e}"))?;
                filter
                    .update(y, u, &[true; 4])
                    .map_err(|e| format!("update at step {k}: {e}"))?;
            }
        }
        let mut row = vec![reference.times[k]];
        row.extend(reference.inputs[k].iter());
        row.extend(reference.measurements[k].iter());
        for filter in [&ekf as &dyn Estimator<5, 4, 3>, &ukf, &scaled] {
            row.extend(filter.state().iter());
            // nalgebra iterates column-major; P is symmetric, but write it row-major anyway.
            row.extend(filter.covariance().transpose().iter());
        }
        let text: Vec<String> = row.iter().map(|v| format!("{v:e}")).collect();
        writeln!(out, "{}", text.join(","))?;
    }
    Ok(())
}
