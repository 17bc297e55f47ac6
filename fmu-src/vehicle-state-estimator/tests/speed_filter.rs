//! Model B's speed filter (`speed_filter`): without `ax` the measured speed passes through; with
//! it the filtered speed is nearer the truth than the sensor, a glitch is gated, and a real step
//! is re-admitted after the lock-out (the FMU's `readmit_time`); through the FMU, model B's
//! `vx_est` and `vx_std` with and without `ax_meas`.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel, GUID};
use VehicleStateEstimator::runner::ChiSquareGate;
use VehicleStateEstimator::speed_filter::{
    SpeedFilter, SpeedSample, AX_OFFSET_TIME_CONSTANT, HELD_AX_STD, HELD_AX_TIME,
    LATERAL_CORRELATION_TIME,
};
use VehicleStateEstimator::status;

const T: f64 = 0.01;
const GATE: ChiSquareGate = ChiSquareGate {
    threshold: 10.83,
    readmit_samples: 50,
};

fn sample(measured: f64, ax: Option<f64>) -> SpeedSample {
    SpeedSample {
        measured,
        measurement_variance: 0.1 * 0.1,
        ax,
        yaw_rate: 0.0,
        lateral_velocity: 0.0,
        lateral_velocity_variance: 0.0,
        sample_time: T,
        process_variance: 0.005 * 0.005,
        min_speed: 1.0,
        offset_variance: 0.0,
    }
}

/// A car braking at 4 m/s² from 25 m/s for 4 s; the speed sensor's noise 0.1 m/s. Returns
/// the largest error of the filtered speed and of the measured one after the first second.
fn braking(ax_known: bool, glitch_at: Option<usize>, gate: Option<ChiSquareGate>) -> (f64, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, 0.1).unwrap();
    let mut filter = SpeedFilter::measured(25.0);
    let (mut filtered, mut raw) = (0.0f64, 0.0f64);
    for k in 0..400 {
        let truth = 25.0 - 4.0 * T * k as f64;
        let mut measured = truth + noise.sample(&mut rng);
        if glitch_at == Some(k) {
            measured += 30.0;
        }
        let bits = filter.step(&sample(measured, ax_known.then_some(-4.0)), gate);
        assert_eq!(bits & status::SENSOR_READMITTED, 0, "k = {k}");
        if k >= 100 {
            filtered = filtered.max((filter.value - truth).abs());
            raw = raw.max((measured - truth).abs());
        }
    }
    (filtered, raw)
}

#[test]
fn without_ax_the_speed_is_the_measured_one() {
    let mut filter = SpeedFilter::measured(20.0);
    for measured in [20.0, 21.5, 19.0] {
        assert_eq!(filter.step(&sample(measured, None), Some(GATE)), 0);
        assert_eq!((filter.value, filter.rejected), (measured, 0));
        assert_eq!(filter.std(), None);
    }
}

#[test]
fn with_ax_the_filtered_speed_is_closer_to_the_truth_than_the_measured_one() {
    let (filtered, raw) = braking(true, None, Some(GATE));
    println!("largest error: filtered {filtered:.3} m/s, measured {raw:.3} m/s");
    assert!(filtered < 0.4 * raw, "filtered {filtered}, measured {raw}");
}

#[test]
fn a_glitch_in_the_measured_speed_is_gated() {
    let (clean, _) = braking(true, None, Some(GATE));
    let (glitched, raw) = braking(true, Some(200), Some(GATE));
    let (ungated, _) = braking(true, Some(200), None);
    println!(
        "largest error: {clean:.3} m/s clean, {glitched:.3} with a 30 m/s glitch, {ungated:.3} ungated"
    );
    assert!(raw > 29.0);
    assert!(glitched < 1.5 * clean, "{glitched} against {clean}");
    assert!(ungated > 1.0, "{ungated}");
}

#[test]
fn a_lateral_estimate_that_lost_itself_cannot_run_the_speed_away() {
    let mut filter = SpeedFilter::measured(20.0);
    filter.step(&sample(20.0, Some(0.0)), Some(GATE));
    let wild = SpeedSample {
        yaw_rate: 1e3,
        lateral_velocity: 1e6,
        lateral_velocity_variance: 0.0,
        ..sample(20.0, Some(0.0))
    };
    filter.step(&wild, Some(GATE));
    assert_eq!((filter.value, filter.ahead), (20.0, 20.0));
}

#[test]
fn a_real_step_in_the_speed_is_readmitted_after_the_lock_out() {
    let mut filter = SpeedFilter::measured(20.0);
    filter.step(&sample(20.0, Some(0.0)), Some(GATE));
    let mut bits = Vec::new();
    for _ in 0..GATE.readmit_samples {
        bits.push(filter.step(&sample(25.0, Some(0.0)), Some(GATE)));
    }
    assert!(bits[..bits.len() - 1]
        .iter()
        .all(|&b| b == status::ROW_GATED));
    assert_eq!(
        *bits.last().unwrap(),
        status::ROW_GATED | status::SENSOR_READMITTED
    );
    assert_eq!(filter.value, 25.0);
}

#[test]
fn a_missing_ax_is_held_for_half_a_second_and_then_the_filter_stops() {
    let mut filter = SpeedFilter::measured(20.0);
    filter.step(&sample(20.0, Some(-4.0)), Some(GATE));
    let running = filter.step(&sample(20.0 - 4.0 * T, Some(-4.0)), Some(GATE));
    assert_eq!(running, 0);
    let before = filter;
    // One all-zero sensor row: neither ax nor a measured speed.
    assert_eq!(
        filter.step(&sample(f64::NAN, None), Some(GATE)),
        status::ROW_SKIPPED
    );
    assert_eq!(
        filter.value,
        before.value - 4.0 * T,
        "predicted with the held ax"
    );
    let added = filter.variance - before.variance;
    let expected = 0.005 * 0.005 + (T * HELD_AX_STD).powi(2);
    assert!(
        (added - expected).abs() < 1e-15,
        "{added} against {expected}"
    );
    // ax missing with the speed measured: still filtering, until HELD_AX_TIME has passed.
    let held = (HELD_AX_TIME / T).ceil() as usize;
    for k in 1..held {
        filter.step(&sample(20.0 - 4.0 * T * (k + 2) as f64, None), Some(GATE));
        assert!(filter.filtering(), "k = {k}");
    }
    filter.step(&sample(17.5, None), Some(GATE));
    assert!(!filter.filtering());
    assert_eq!((filter.value, filter.std()), (17.5, None));
}

#[test]
fn without_a_measured_speed_the_filter_predicts_for_half_a_second_and_then_stops() {
    let mut filter = SpeedFilter::measured(20.0);
    filter.step(&sample(20.0, Some(-4.0)), Some(GATE));
    let held = (HELD_AX_TIME / T).ceil() as usize;
    for k in 1..=held {
        let bits = filter.step(&sample(f64::NAN, Some(-4.0)), Some(GATE));
        assert_eq!(bits, status::ROW_SKIPPED, "k = {k}");
        assert!(filter.filtering(), "k = {k}");
        assert!((filter.value - (20.0 - 4.0 * T * k as f64)).abs() < 1e-9);
    }
    filter.step(&sample(f64::NAN, Some(-4.0)), Some(GATE));
    assert!(!filter.filtering(), "the integrated ax alone drifts");
    assert_eq!(filter.std(), None);
}

/// An accelerometer that reads 0.3 m/s² too high (a grade of 3 %): 5 s straight at 20 m/s, then
/// 10 s in a corner at 0.3 rad/s, the speed sensor's noise 0.1 m/s. With `ax_offset_std` 0.2
/// the filter learns the offset while the car drives straight and holds it in the corner (it only
/// decays there, as its prior does), where
/// `r vy` and the offset enter the speed alike; without it the speed's std does not cover its
/// error. Returns the offset at the end of the straight and at the end, and the mean NEES of
/// the speed over the run after the first second.
fn offset_run(offset_std: f64) -> (f64, f64, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 0.1).unwrap();
    let mut filter = SpeedFilter::measured(20.0);
    let (mut learned, mut nees, mut count) = (f64::NAN, 0.0, 0);
    for k in 0..1500 {
        let cornering = k >= 500;
        let at = SpeedSample {
            yaw_rate: if cornering { 0.3 } else { 0.0 },
            offset_variance: offset_std * offset_std,
            ..sample(20.0 + noise.sample(&mut rng), Some(0.3))
        };
        filter.step(&at, Some(GATE));
        if k == 499 {
            learned = filter.ax_offset;
        }
        if k >= 100 {
            nees += (filter.value - 20.0).powi(2) / filter.variance;
            count += 1;
        }
    }
    (learned, filter.ax_offset, nees / count as f64)
}

#[test]
fn the_accelerometer_offset_is_learned_driving_straight_and_held_in_a_corner() {
    let (learned, held, nees) = offset_run(0.2);
    println!("offset learned {learned}, at the end {held}, speed NEES {nees}");
    assert!((learned - 0.3).abs() < 0.05, "{learned}");
    // in the corner the measured speed does not update it: it only decays as its prior does
    let decay = (-1000.0 * T / AX_OFFSET_TIME_CONSTANT).exp();
    assert!(
        (held - learned * decay).abs() < 1e-12,
        "held in the corner: {held} against {}",
        learned * decay
    );
    assert!(nees < 2.0, "{nees}");
    let (_, untouched, without) = offset_run(0.0);
    println!("without the offset state: speed NEES {without}");
    assert_eq!(untouched, 0.0);
    assert!(without > 5.0, "{without}");
}

#[test]
fn the_lateral_estimates_uncertainty_widens_the_prediction_with_the_yaw_rate() {
    let straight = sample(20.0, Some(0.0));
    let cornering = SpeedSample {
        yaw_rate: 0.5,
        lateral_velocity: 1.0,
        lateral_velocity_variance: 0.3 * 0.3,
        ..straight
    };
    assert_eq!(straight.prediction_variance(), straight.process_variance);
    let lateral = cornering.prediction_variance() - cornering.process_variance;
    let expected = 2.0 * LATERAL_CORRELATION_TIME * T * (0.5f64 * 0.3).powi(2);
    assert!(
        (lateral - expected).abs() < 1e-15,
        "{lateral} against {expected}"
    );
    let not_finite = SpeedSample {
        lateral_velocity_variance: f64::INFINITY,
        ..cornering
    };
    assert_eq!(
        not_finite.prediction_variance(),
        not_finite.process_variance
    );
}

/// Model B at its defaults through the C ABI, braking straight at 4 m/s² from 25 m/s for 3 s,
/// the speed sensor's noise 0.1 m/s (the default `measurement_noise_std_vx`), a 30 m/s glitch
/// in `vx_meas` at 1.5 s when `glitch`; `ax_meas` as given. Returns the RMS and largest error
/// of `vx_est` after the first second, and the last `vx_std`.
fn model_b_braking(ax_meas: Option<f64>, glitch: bool) -> (f64, f64, f64) {
    let mut s = Slave::instantiate(fmi2_api_of!(VehicleStateEstimator), "speed", GUID)
        .expect("instantiate");
    assert_eq!(
        s.set_integer(vr::MODEL, EstimatorModel::TwoTrack3State as i32),
        Fmi2Status::Ok
    );
    assert_eq!(
        s.set_integer(vr::ESTIMATOR, EstimatorKind::Ekf as i32),
        Fmi2Status::Ok
    );
    assert_eq!(s.set_real(vr::SAMPLE_TIME, T), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0, 0.1).unwrap();
    let (mut squared, mut largest, mut count) = (0.0, 0.0f64, 0);
    for k in 0..300 {
        let t = k as f64 * T;
        let speed = 25.0 - 4.0 * t;
        let mut measured = speed + noise.sample(&mut rng);
        if glitch && k == 150 {
            measured += 30.0;
        }
        let wheel = speed / 0.3;
        for (reference, value) in [
            (vr::STEERING_ANGLE, 0.0),
            (vr::YAW_RATE_MEAS, 0.0),
            (vr::AY_MEAS, 0.0),
            (vr::OMEGA_FRONT_MEAS, wheel),
            (vr::OMEGA_REAR_MEAS, wheel),
            (vr::VX_MEAS, measured),
            (vr::AX_MEAS, ax_meas.unwrap_or(0.0)),
        ] {
            assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
        }
        assert_eq!(s.do_step(t, T), Fmi2Status::Ok);
        // The outputs are the estimate at the next sample instant.
        let error = s.get_real(vr::VX_EST).1 - (speed - 4.0 * T);
        if k >= 100 {
            squared += error * error;
            largest = largest.max(error.abs());
            count += 1;
        }
    }
    let rms = (squared / f64::from(count)).sqrt();
    (rms, largest, s.get_real(vr::VX_STD).1)
}

#[test]
fn model_b_filters_its_speed_with_a_measured_ax_and_takes_it_as_measured_without() {
    let (filtered, filtered_largest, filtered_std) = model_b_braking(Some(-4.0), false);
    // ax_meas left at its start value 0 (unconnected): the speed as measured, its std the
    // sensor's, the error the sensor's noise (and its one-sample lag behind the prediction).
    let (measured, measured_largest, measured_std) = model_b_braking(None, false);
    println!(
        "vx_est error RMS / largest: {filtered:.3} / {filtered_largest:.3} m/s filtered (std \
         {filtered_std:.3}), {measured:.3} / {measured_largest:.3} m/s as measured (std {measured_std})"
    );
    assert_eq!(measured_std, 0.1);
    assert!(measured > 0.08, "{measured}");
    assert!(filtered < 0.4 * measured, "{filtered} against {measured}");
    assert!(
        filtered_std < 0.05 && filtered_std > 0.5 * filtered,
        "{filtered_std}"
    );
    let (glitched, glitched_largest, _) = model_b_braking(Some(-4.0), true);
    assert!(
        glitched_largest < 1.5 * filtered_largest,
        "a 30 m/s glitch: largest error {glitched_largest} against {filtered_largest} ({glitched} RMS)"
    );
}
