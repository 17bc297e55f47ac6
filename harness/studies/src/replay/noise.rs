//! Noise levels of model A by the innovation likelihood: offline (the `estimation` library's
//! EKF on the estimator's model A, as the EM of [`super::fit`] uses it; no FMU), the
//! prediction-error form of the Gaussian likelihood of the training data,
//! `−log L = Σ_t ½ (e_tᵀ S_t⁻¹ e_t + log det S_t)` with `e_t = y_t − h(x̂⁻_t)` and
//! `S_t = H P⁻ Hᵀ + R` over the rows present at `t` (Schweppe 1965; the form of
//! `estimation::identification::parameter_information`), minimised over a factor on every
//! process-noise standard deviation on a grid of powers of two from 1/8 to 256 (12 EKF runs over
//! the training rows; a factor of 2 is as fine as a noise level is worth knowing).
//!
//! The measurement noise stays as the map and `--parameters` give it: it is a sensor's data-sheet
//! value (or measured standing still), while the process noise stands for what the model gets
//! wrong, which no data sheet gives. Fitted together on a drive the model cannot reproduce, the
//! likelihood traded one for the other: on the example log (harness/logs, 100 km/h to the
//! limit) it chose 1/8 of the sensors' true noise (0.002 rad/s, 0.05 m/s², 0.05 rad/s, which the
//! map gives) with 4 times the map's process noise: sensor variances 64 times smaller than they
//! are, a property of the model's error and not of the sensors.

use anyhow::{anyhow, Result};
use nalgebra::{SMatrix, SVector};

use estimation::kalman::{ExtendedKalmanFilter, InitialEstimate};
use estimation::models::single_track::SingleTrackEstimationModel;
use estimation::models::single_track_identification::{
    initial_state_from_measurement, SingleTrackHsri,
};
use estimation::{Estimator, StateSpaceModel};
use vehicle_models::Integrator;

/// The factors tried on the standard deviations.
const FACTORS: [f64; 12] = [
    0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0,
];

/// What the search found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseFit {
    /// Factor on every process-noise standard deviation.
    pub process: f64,
    /// Factor on every measurement-noise standard deviation: 1, the sensors' values kept (see
    /// the module text).
    pub measurement: f64,
    /// `−log L` per sample at the factors found and at (1, 1).
    pub negative_log_likelihood: f64,
    pub negative_log_likelihood_start: f64,
}

/// The training data and the starting noise of model A.
pub struct NoiseProblem<'a> {
    pub vehicle: &'a SingleTrackHsri,
    pub sample_time: f64,
    /// Standard deviations `[vx, vy, r, ωF, ωR]` per sample.
    pub process_std: [f64; 5],
    /// Standard deviations `[r, ay, ωF, ωR]`.
    pub measurement_std: [f64; 4],
    /// Prior standard deviations of the initial state.
    pub initial_std: [f64; 5],
    pub inputs: &'a [[f64; 3]],
    pub measurements: &'a [[f64; 4]],
}

/// The factors of least `−log L` (see the module text).
pub fn fit_noise(problem: &NoiseProblem) -> Result<NoiseFit> {
    let start = negative_log_likelihood(problem, 1.0, 1.0)?;
    let mut best = (f64::INFINITY, 1.0, 1.0);
    for &process in &FACTORS {
        let value = negative_log_likelihood(problem, process, 1.0)?;
        if value < best.0 {
            best = (value, process, 1.0);
        }
    }
    Ok(NoiseFit {
        process: best.1,
        measurement: best.2,
        negative_log_likelihood: best.0,
        negative_log_likelihood_start: start,
    })
}

/// `−log L` per used sample with the noise standard deviations scaled.
pub(super) fn negative_log_likelihood(
    problem: &NoiseProblem,
    process: f64,
    measurement: f64,
) -> Result<f64> {
    let squared = |std: f64, factor: f64| (std * factor).powi(2);
    let model = SingleTrackEstimationModel::new(
        problem.vehicle.clone(),
        problem.sample_time,
        Integrator::SemiImplicitEuler,
        problem.process_std.map(|s| squared(s, process)),
        problem.measurement_std.map(|s| squared(s, measurement)),
    )
    .map_err(|e| anyhow!("model A for the noise fit: {}", e.0))?;
    let complete = |y: &[f64; 4]| y.iter().all(|v| v.is_finite());
    let first = problem
        .measurements
        .iter()
        .position(complete)
        .ok_or_else(|| anyhow!("no complete measurement row in the training segment"))?;
    let initial = InitialEstimate::diagonal(
        initial_state_from_measurement(problem.vehicle, &problem.measurements[first]),
        SVector::from(problem.initial_std.map(|s| s * s)),
    );
    let mut filter =
        ExtendedKalmanFilter::new(model.clone(), &initial).map_err(|e| anyhow!("EKF: {}", e.0))?;
    let r = model.measurement_noise();
    let (mut sum, mut samples) = (0.0, 0usize);
    for t in first + 1..problem.inputs.len() {
        let _ = filter.predict(&SVector::from(problem.inputs[t - 1]));
        let input = SVector::from(problem.inputs[t]);
        let h = model.measurement_jacobian(filter.state(), &input);
        let mut s: SMatrix<f64, 4, 4> = h * filter.covariance() * h.transpose() + r;
        let y = SVector::from(problem.measurements[t]);
        let mask = problem.measurements[t].map(f64::is_finite);
        let Ok(report) = filter.update(&y, &input, &mask) else {
            continue;
        };
        if report.rows_used == 0 {
            continue;
        }
        // A row that was not used carries no information: unit variance, no correlation.
        for row in (0..4).filter(|&row| !report.used[row]) {
            s.row_mut(row).fill(0.0);
            s.column_mut(row).fill(0.0);
            s[(row, row)] = 1.0;
        }
        let Some(cholesky) = s.cholesky() else {
            continue;
        };
        let log_det: f64 = 2.0 * cholesky.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        let e = report.innovation;
        sum += 0.5 * (e.dot(&cholesky.solve(&e)) + log_det);
        samples += 1;
    }
    if samples == 0 {
        return Err(anyhow!("no measurement update in the training segment"));
    }
    Ok(sum / samples as f64)
}
