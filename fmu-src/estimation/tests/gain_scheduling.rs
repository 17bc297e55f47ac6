//! Gain scheduling of the linear estimators (`RunningEstimator::reschedule`): the LKF and the
//! Luenberger observer re-linearised about their estimate on seed 000's high-ay ramp, far from
//! the straight driving they are first linearised about.

use crate::seed000_support;

use estimation::kalman::LinearKalmanFilter;
use estimation::luenberger::LuenbergerObserver;
use estimation::models::single_track::{seed_operating_point, SingleTrackEstimationModel};
use estimation::registry::RunningEstimator;
use estimation::{Estimator, FilterIssue, MeasurementMask, UpdateReport};
use nalgebra::{SMatrix, SVector};
use seed000_support::{reference_run, rmse, run_filter, seed_initial_estimate};
use vehicle_models::manoeuvre::{SeedManoeuvre, SEED_MANOEUVRE_DURATION};
use vehicle_models::single_track::state_index::VY;

const SEED: u64 = 5;

/// An estimator that re-schedules after each update, as the FMU's runner does.
struct Scheduled<E> {
    inner: E,
    threshold: f64,
    reschedules: usize,
}

impl<E: RunningEstimator<5, 4, 3>> Estimator<5, 4, 3> for Scheduled<E> {
    fn predict(&mut self, input: &SVector<f64, 3>) -> Result<(), FilterIssue> {
        self.inner.predict(input)
    }

    fn update(
        &mut self,
        measurement: &SVector<f64, 4>,
        input: &SVector<f64, 3>,
        mask: &MeasurementMask<4>,
    ) -> Result<UpdateReport<4>, FilterIssue> {
        let report = self.inner.update(measurement, input, mask);
        if self.inner.reschedule(input, self.threshold) {
            self.reschedules += 1;
        }
        report
    }

    fn state(&self) -> &SVector<f64, 5> {
        self.inner.state()
    }

    fn covariance(&self) -> &SMatrix<f64, 5, 5> {
        self.inner.covariance()
    }
}

fn lkf(t: f64) -> LinearKalmanFilter<SingleTrackEstimationModel, 5, 4, 3> {
    let (x0, u0) = seed_operating_point();
    let model = SingleTrackEstimationModel::seed_000(t).unwrap();
    LinearKalmanFilter::new(model, &x0, &u0, &seed_initial_estimate()).unwrap()
}

fn luenberger(t: f64) -> LuenbergerObserver<SingleTrackEstimationModel, 5, 4, 3> {
    let (x0, u0) = seed_operating_point();
    let model = SingleTrackEstimationModel::seed_000(t).unwrap();
    let design = model.default_observer_design();
    LuenbergerObserver::new(model, &x0, &u0, &design, &seed_initial_estimate()).unwrap()
}

fn vy_rmse(filter: &mut impl Estimator<5, 4, 3>, t: f64) -> f64 {
    let reference = reference_run(SeedManoeuvre::HighRamp, t, SEED);
    let estimates = run_filter(filter, &reference);
    rmse(
        &reference,
        &estimates,
        VY,
        0.0,
        SEED_MANOEUVRE_DURATION + 1.0,
    )
}

#[test]
fn the_scheduled_lkf_follows_the_tyres_into_the_nonlinear_range() {
    let t = 1e-2;
    let fixed = vy_rmse(&mut lkf(t), t);
    let mut scheduled = Scheduled {
        inner: lkf(t),
        threshold: 1.0,
        reschedules: 0,
    };
    let tracked = vy_rmse(&mut scheduled, t);
    println!(
        "high ramp at 10 ms, LKF vy RMSE: fixed {fixed:.3e}, scheduled {tracked:.3e} m/s ({} re-schedules)",
        scheduled.reschedules
    );
    // Seed 000's finding for the fixed LKF; scheduled, an order of magnitude better, and it
    // re-linearises only a fraction of the samples (a linear filter in between).
    assert!(fixed > 1e-2, "fixed LKF vy RMSE {fixed}");
    assert!(tracked < 0.1 * fixed, "scheduled {tracked}, fixed {fixed}");
    let samples = ((SEED_MANOEUVRE_DURATION + 1.0) / t) as usize;
    assert!(
        scheduled.reschedules > 0 && scheduled.reschedules < samples / 2,
        "{} re-schedules in {samples} samples",
        scheduled.reschedules
    );
}

#[test]
fn the_scheduled_observer_stays_stable_and_is_no_worse_than_the_fixed_one() {
    let t = 1e-2;
    let fixed = vy_rmse(&mut luenberger(t), t);
    let mut scheduled = Scheduled {
        inner: luenberger(t),
        threshold: 1.0,
        reschedules: 0,
    };
    let tracked = vy_rmse(&mut scheduled, t);
    println!(
        "high ramp at 10 ms, Luenberger vy RMSE: fixed {fixed:.3e}, scheduled {tracked:.3e} m/s ({} re-schedules)",
        scheduled.reschedules
    );
    // The extended observer runs on the model either way, so a re-scheduled gain changes its
    // error by little (measured: 1.994e-3 fixed, 2.002e-3 scheduled).
    assert!(
        tracked.is_finite() && tracked <= 1.05 * fixed,
        "scheduled {tracked}, fixed {fixed}"
    );
    // Into the tyres' nonlinear range: on its linearisation about straight driving the observer
    // was as far off as the seed's fixed LKF (vy RMSE 0.61 m/s, scheduled or not).
    assert!(fixed < 1e-2, "fixed {fixed}");
}
