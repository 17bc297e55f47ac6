//! One filter step (predict + update with all four measurements) of the Kalman-type estimators
//! on model A (5 states, 4 measurements, T = 1 ms), median printed by divan, plus the UKF of the
//! crate numeris on the same model for comparison.
//!
//! Run with:
//! `CARGO_TARGET_DIR=target/kalman cargo bench -p estimation --bench kalman`
//!
//! Per-step budgets on the 2-core CI machine: LKF <= 0.5 us, EKF <= 1.5 us, UKF 2n <= 2.5 us,
//! UKF scaled <= 3 us; ours must beat numeris' UKF (`numeris_ukf_scaled`, same scaled sigma
//! points alpha = 0.5, beta = 2, kappa = 0, same model functions, its own Cholesky and update).
//!
//! After divan's table, a summary times the four filters and numeris' UKF once more with their
//! samples interleaved (one sample of each in turn), so that a load on the machine hits all of
//! them alike, and prints median and fastest per step against the targets, and the ratio of our
//! scaled UKF to numeris' (the median of the per-round ratios, and of medians and fastest).

use std::hint::black_box;

use estimation::kalman::{InitialEstimate, SigmaPoints};
use estimation::models::single_track::SingleTrackEstimationModel;
use estimation::registry::{self, BoxedEstimator, EstimatorChoice};
use estimation::StateSpaceModel;
use nalgebra::SVector;

fn main() {
    divan::main();
    // `cargo bench` passes `--bench`; `cargo test --benches` and `--list` do not want the summary.
    let args: Vec<String> = std::env::args().collect();
    let benchmarking =
        args.iter().any(|a| a == "--bench") && !args.iter().any(|a| a == "--test" || a == "--list");
    if benchmarking {
        summary();
    }
}

const SAMPLE_TIME: f64 = 1e-3;

/// A moderate left turn (the end state of the seed-000 moderate ramp) and its measurement with a
/// small offset, so the update has something to correct.
fn operating_case() -> (SVector<f64, 5>, SVector<f64, 3>, SVector<f64, 4>) {
    let x = SVector::<f64, 5>::from([17.49, -0.031, 0.2086, 58.3, 58.3]);
    let u = SVector::<f64, 3>::from([0.035, 0.0, 0.0]);
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let y = model.measurement(&x, &u) + SVector::<f64, 4>::from([1e-4, -1e-4, 1e-3, -1e-3]);
    (x, u, y)
}

/// The filter `name` after 500 steps at the operating case, so that its covariance is settled.
fn settled(name: &str) -> BoxedEstimator<5, 4, 3> {
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let settings = model.seed_settings();
    let choice = EstimatorChoice::from_name(name).unwrap();
    let (x, u, y) = operating_case();
    let initial =
        InitialEstimate::diagonal(x, SVector::<f64, 5>::from([1e-2, 1e-4, 1e-4, 1e-2, 1e-2]));
    let mut filter = registry::build(model, choice, &settings, &initial).unwrap();
    for _ in 0..500 {
        let _ = filter.predict(&u);
        let _ = filter.update(&y, &u, &[true; 4]);
    }
    filter
}

/// One settled filter stepped again and again at the same input and measurement: it stays in
/// its settled state, and in cache, as in a real run (a fresh copy per iteration would time
/// cache misses instead).
fn bench_step(bencher: divan::Bencher, name: &str) {
    let mut filter = settled(name);
    let (_, u, y) = operating_case();
    bencher.bench_local(|| {
        let _ = filter.predict(black_box(&u));
        filter.update(black_box(&y), black_box(&u), &[true; 4])
    });
}

#[divan::bench]
fn lkf_step(bencher: divan::Bencher) {
    bench_step(bencher, "lkf");
}

#[divan::bench]
fn ekf_step(bencher: divan::Bencher) {
    bench_step(bencher, "ekf");
}

#[divan::bench]
fn ukf_2n_step(bencher: divan::Bencher) {
    bench_step(bencher, "ukf");
}

#[divan::bench]
fn ukf_scaled_step(bencher: divan::Bencher) {
    bench_step(bencher, "ukf_scaled");
}

#[divan::bench]
fn luenberger_step(bencher: divan::Bencher) {
    bench_step(bencher, "luenberger");
}

fn to_numeris<const K: usize>(v: &SVector<f64, K>) -> numeris::Vector<f64, K> {
    numeris::Vector::from_array(core::array::from_fn(|i| v[i]))
}

fn from_numeris<const K: usize>(v: &numeris::Vector<f64, K>) -> SVector<f64, K> {
    SVector::<f64, K>::from_fn(|i, _| v[i])
}

fn numeris_matrix<const R: usize, const C: usize>(
    m: &nalgebra::SMatrix<f64, R, C>,
) -> numeris::Matrix<f64, R, C> {
    let mut out = numeris::Matrix::<f64, R, C>::zeros();
    for r in 0..R {
        for c in 0..C {
            out[(r, c)] = m[(r, c)];
        }
    }
    out
}

/// numeris' UKF on model A, started from the settled state and covariance of our scaled UKF,
/// with `Q` and `R` converted once (as our filters hold them).
struct NumerisCase {
    ukf: numeris::estimate::Ukf<f64, 5, 4>,
    process_noise: numeris::Matrix<f64, 5, 5>,
    measurement_noise: numeris::Matrix<f64, 4, 4>,
}

impl NumerisCase {
    fn settled(model: &SingleTrackEstimationModel) -> Self {
        let ours = settled("ukf_scaled");
        let x0 = to_numeris(ours.state());
        let p0 = numeris_matrix(ours.covariance());
        Self {
            ukf: numeris::estimate::Ukf::<f64, 5, 4>::with_params(x0, p0, 0.5, 2.0, 0.0),
            process_noise: numeris_matrix(&model.process_noise()),
            measurement_noise: numeris_matrix(&model.measurement_noise()),
        }
    }

    /// One step (predict + update) through our model's functions.
    fn step(
        &mut self,
        model: &SingleTrackEstimationModel,
        u: &SVector<f64, 3>,
        z: &numeris::Vector<f64, 4>,
    ) -> Result<f64, numeris::estimate::EstimateError> {
        let _ = self.ukf.predict(
            |x| to_numeris(&model.transition(&from_numeris(x), u)),
            Some(&self.process_noise),
        );
        self.ukf.update(
            z,
            |x| to_numeris(&model.measurement(&from_numeris(x), u)),
            &self.measurement_noise,
        )
    }
}

#[divan::bench]
fn numeris_ukf_scaled_step(bencher: divan::Bencher) {
    let (_, u, y) = operating_case();
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let mut numeris = NumerisCase::settled(&model);
    let z = to_numeris(&y);
    bencher.bench_local(|| numeris.step(&model, black_box(&u), black_box(&z)));
}

/// The interleaved summary (see the module documentation).
fn summary() {
    const ROUNDS: usize = 301;
    const STEPS_PER_SAMPLE: usize = 64;
    let (_, u, y) = operating_case();
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let z = to_numeris(&y);
    let mut ours: Vec<(&str, f64, BoxedEstimator<5, 4, 3>)> = vec![
        ("LKF", 0.5, settled("lkf")),
        ("EKF", 1.5, settled("ekf")),
        ("UKF 2n", 2.5, settled("ukf")),
        ("UKF scaled", 3.0, settled("ukf_scaled")),
    ];
    let mut numeris_ukf = NumerisCase::settled(&model);
    // Per-step times in µs, one entry per round: ours in order, numeris last.
    let mut times = vec![Vec::with_capacity(ROUNDS); ours.len() + 1];
    let per_step =
        |start: std::time::Instant| start.elapsed().as_secs_f64() * 1e6 / STEPS_PER_SAMPLE as f64;
    for _ in 0..ROUNDS {
        for (index, (_, _, filter)) in ours.iter_mut().enumerate() {
            let start = std::time::Instant::now();
            for _ in 0..STEPS_PER_SAMPLE {
                let _ = filter.predict(black_box(&u));
                let _ = black_box(filter.update(black_box(&y), black_box(&u), &[true; 4]));
            }
            times[index].push(per_step(start));
        }
        let start = std::time::Instant::now();
        for _ in 0..STEPS_PER_SAMPLE {
            let _ = black_box(numeris_ukf.step(&model, black_box(&u), black_box(&z)));
        }
        times[ours.len()].push(per_step(start));
    }
    let scaled = ours.len() - 1;
    let numeris = ours.len();
    let mut paired: Vec<f64> = times[scaled]
        .iter()
        .zip(&times[numeris])
        .map(|(a, b)| a / b)
        .collect();
    let median = |values: &mut Vec<f64>| {
        values.sort_by(f64::total_cmp);
        values[values.len() / 2]
    };
    let stats: Vec<(f64, f64)> = times.iter_mut().map(|t| (median(t), t[0])).collect();
    println!();
    println!(
        "Summary: one step (predict + update) on model A, {ROUNDS} interleaved samples of \
         {STEPS_PER_SAMPLE} steps each"
    );
    println!(
        "{:<22} {:>12} {:>12} {:>10}",
        "filter", "median µs", "fastest µs", "target µs"
    );
    for (index, (name, target, _)) in ours.iter().enumerate() {
        let (median, fastest) = stats[index];
        let verdict = if median <= *target {
            format!("met, median {:.0} % below", 100.0 * (1.0 - median / target))
        } else {
            "MISSED".to_string()
        };
        println!("{name:<22} {median:>12.3} {fastest:>12.3} {target:>10.1}  {verdict}");
    }
    let (numeris_median, numeris_fastest) = stats[numeris];
    println!(
        "{:<22} {numeris_median:>12.3} {numeris_fastest:>12.3}",
        "numeris UKF scaled"
    );
    println!(
        "ours / numeris (UKF scaled): {:.3} (median of per-round ratios), {:.3} (medians), \
         {:.3} (fastest)",
        median(&mut paired),
        stats[scaled].0 / numeris_median,
        stats[scaled].1 / numeris_fastest
    );
}

/// The model calls the filters are built from, to read the filter timings against.
#[divan::bench]
fn model_a_transition(bencher: divan::Bencher) {
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let (x, u, _) = operating_case();
    bencher.bench_local(|| model.transition(black_box(&x), black_box(&u)));
}

#[divan::bench]
fn model_a_measurement(bencher: divan::Bencher) {
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let (x, u, _) = operating_case();
    bencher.bench_local(|| model.measurement(black_box(&x), black_box(&u)));
}

#[divan::bench]
fn model_a_transition_jacobian(bencher: divan::Bencher) {
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let (x, u, _) = operating_case();
    bencher.bench_local(|| model.transition_jacobian(black_box(&x), black_box(&u)));
}

#[divan::bench]
fn model_a_measurement_jacobian(bencher: divan::Bencher) {
    let model = SingleTrackEstimationModel::seed_000(SAMPLE_TIME).unwrap();
    let (x, u, _) = operating_case();
    bencher.bench_local(|| model.measurement_jacobian(black_box(&x), black_box(&u)));
}

/// The seed-001 estimator (model B, 3-state form, Magic Formula) in a steady 40° steering-wheel
/// turn at 65 km/h, T = 10 ms: the scaled UKF the seed proposes and its linear comparison filter.
fn bench_two_track_step(bencher: divan::Bencher, name: &str) {
    use estimation::models::two_track::{TwoTrackEstimationModel, SEED_001_SPEED};
    let model = TwoTrackEstimationModel::seed_001(0.01).unwrap();
    let settings = model.estimator_settings(
        SEED_001_SPEED,
        SigmaPoints::scaled(0.5, 2.0, 0.0),
        Ok(Default::default()),
    );
    let choice = EstimatorChoice::from_name(name).unwrap();
    let x = SVector::<f64, 3>::from([-0.004, 0.27, 4.9]);
    let steering_ratio = model.vehicle().vehicle.chassis.steering_ratio;
    let u = SVector::<f64, 3>::from([40f64.to_radians() / steering_ratio, SEED_001_SPEED, 0.0]);
    let y = SVector::<f64, 2>::from([4.95, 0.272]);
    let initial = InitialEstimate::diagonal(x, SVector::<f64, 3>::from([1e-4, 1e-4, 1e-2]));
    let mut filter = registry::build(model, choice, &settings, &initial).unwrap();
    for _ in 0..200 {
        let _ = filter.predict(&u);
        let _ = filter.update(&y, &u, &[true; 2]);
    }
    bencher.bench_local(|| {
        let _ = filter.predict(black_box(&u));
        filter.update(black_box(&y), black_box(&u), &[true; 2])
    });
}

#[divan::bench]
fn two_track_lkf_step(bencher: divan::Bencher) {
    bench_two_track_step(bencher, "lkf");
}

#[divan::bench]
fn two_track_ukf_scaled_step(bencher: divan::Bencher) {
    bench_two_track_step(bencher, "ukf_scaled");
}
