//! The lateral accelerometer's offset and gain (`lateral_accelerometer`, parameters
//! `ay_offset_std` and `ay_gain_std`): the offset learned driving straight, the gain (where
//! switched on) in a steady corner, nothing from a transient, a glitch, an all-zero row or a
//! crawl; through the FMU, the grip model's sideslip on a step steer whose `ay` reads 0.3 m/s²
//! high.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use VehicleStateEstimator::lateral_accelerometer::{
    AySample, LateralAccelerometer, AY_CALIBRATION_TIME_CONSTANT,
};
use VehicleStateEstimator::model_description::{vr, Variables};

use crate::yaw_rate_offset::{assert_learning_restores, largest_sideslip_error, SensorOffset};

const T: f64 = 0.01;
const SPEED: f64 = 20.0;
const AY_NOISE: f64 = 0.1;
const GYRO_NOISE: f64 = 0.0035;

fn learner(gain_std: f64) -> LateralAccelerometer {
    let v = Variables {
        sample_time: T,
        measurement_noise_std_ay: AY_NOISE,
        measurement_noise_std_yaw_rate: GYRO_NOISE,
        ay_gain_std: gain_std,
        ..Variables::default()
    };
    LateralAccelerometer::from_parameters(&v, true)
        .expect("valid parameters")
        .expect("on by default")
}

/// `samples` samples at `speed` with the road-wheel angle `steering` and the yaw rate
/// `yaw_rate`, whose accelerometer reads `offset + (1 + gain) r vx` with noise, as does the
/// gyro.
fn feed(
    learner: &mut LateralAccelerometer,
    rng: &mut ChaCha8Rng,
    samples: usize,
    (steering, yaw_rate, speed): (f64, f64, f64),
    (offset, gain): (f64, f64),
) {
    let ay_noise = Normal::new(0.0, AY_NOISE).unwrap();
    let gyro_noise = Normal::new(0.0, GYRO_NOISE).unwrap();
    for _ in 0..samples {
        let ay = offset + (1.0 + gain) * yaw_rate * speed + ay_noise.sample(rng);
        learner.step(&AySample {
            ay,
            yaw_rate: yaw_rate + gyro_noise.sample(rng),
            all_zero: false,
            steering,
            speed: Some(speed),
            ay_variance: AY_NOISE * AY_NOISE,
        });
    }
}

/// Asserts that `estimate` is `learned` decayed over `samples` samples without an update.
fn assert_only_decayed(estimate: f64, learned: f64, samples: usize) {
    let decayed = learned * (-(samples as f64) * T / AY_CALIBRATION_TIME_CONSTANT).exp();
    assert!(
        (estimate - decayed).abs() <= 1e-12 * decayed.abs(),
        "{estimate} vs {decayed}"
    );
}

#[test]
fn driving_straight_the_offset_is_learned_and_the_gain_left_alone() {
    let mut learner = learner(0.0);
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    feed(
        &mut learner,
        &mut rng,
        30_000,
        (0.0, 0.0, SPEED),
        (0.2, 0.0),
    );
    let std = learner.covariance[(0, 0)].sqrt();
    println!(
        "straight 5 min: offset {} m/s², std {std}",
        learner.estimate[0]
    );
    assert!((learner.estimate[0] - 0.2).abs() < 3.0 * std, "{learner:?}");
    // about half the prior's 0.2 m/s²: an offset that drifts over 600 s, told from a crossfall
    // that changes every 5 s (measured 0.091 m/s²)
    assert!(std < 0.1, "{learner:?}");
    assert_eq!(learner.estimate[1], 0.0);
    assert_eq!(learner.corrected(1.0), 1.0 - learner.estimate[0]);
}

#[test]
fn in_a_steady_corner_the_gain_is_learned_where_it_is_switched_on() {
    let mut learner = learner(0.15);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    feed(&mut learner, &mut rng, 200, (0.0, 0.0, SPEED), (0.1, 0.12));
    // a steady corner at 5 m/s²: the gyro's 0.25 rad/s times 20 m/s
    feed(
        &mut learner,
        &mut rng,
        300,
        (0.03, 0.25, SPEED),
        (0.1, 0.12),
    );
    let [offset, gain] = [learner.estimate[0], learner.estimate[1]];
    println!(
        "offset {offset} m/s², gain {gain} (stds {} and {})",
        learner.covariance[(0, 0)].sqrt(),
        learner.covariance[(1, 1)].sqrt()
    );
    assert!((gain - 0.12).abs() < 0.02, "{learner:?}");
    assert!((offset - 0.1).abs() < 0.1, "{learner:?}");
    let corrected = learner.corrected(0.1 + 1.12 * 5.0);
    assert!((corrected - 5.0).abs() < 0.1, "{corrected}");
}

#[test]
fn a_transient_a_glitch_an_all_zero_row_or_a_crawl_teaches_nothing() {
    let mut learner = learner(0.15);
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    feed(&mut learner, &mut rng, 300, (0.0, 0.0, SPEED), (0.2, 0.0));
    let learned = learner.estimate[0];
    let mut samples = 0;
    // a steering ramp of 0.5 rad/s (a lane change's): never quasi-steady
    for k in 1..=20 {
        let steering = 0.005 * f64::from(k);
        feed(
            &mut learner,
            &mut rng,
            1,
            (steering, 5.0 * steering, SPEED),
            (0.2, 0.3),
        );
        samples += 1;
    }
    assert_only_decayed(learner.estimate[0], learned, samples);
    let steady = AySample {
        ay: 0.2,
        yaw_rate: 0.0,
        all_zero: false,
        steering: 0.1,
        speed: Some(SPEED),
        ay_variance: AY_NOISE * AY_NOISE,
    };
    // settle the quasi-steady test at the ramp's end with glitches: 100 m/s² each sample
    for _ in 0..200 {
        learner.step(&AySample {
            ay: 100.0,
            ..steady
        });
        samples += 1;
    }
    learner.step(&AySample {
        all_zero: true,
        ..steady
    });
    learner.step(&AySample {
        speed: Some(3.0),
        ..steady
    });
    samples += 2;
    assert_only_decayed(learner.estimate[0], learned, samples);
}

#[test]
fn negative_standard_deviations_are_refused_and_zeros_switch_the_learner_off() {
    let with = |offset: f64, gain: f64| {
        LateralAccelerometer::from_parameters(
            &Variables {
                ay_offset_std: offset,
                ay_gain_std: gain,
                ..Variables::default()
            },
            true,
        )
    };
    let refused = with(-0.1, 0.0).unwrap_err();
    assert!(refused.contains("ay_offset_std"), "{refused}");
    let refused = with(0.1, f64::NAN).unwrap_err();
    assert!(refused.contains("ay_gain_std"), "{refused}");
    assert_eq!(with(0.0, 0.0), Ok(None));
}

/// Where the model's filter estimates the gain (the grip model), the learner learns the offset
/// only: nothing at all without `ay_offset_std`, and in a steady corner no gain.
#[test]
fn a_model_that_estimates_the_gain_leaves_the_learner_the_offset() {
    let v = Variables {
        sample_time: T,
        measurement_noise_std_ay: AY_NOISE,
        measurement_noise_std_yaw_rate: GYRO_NOISE,
        ay_gain_std: 0.15,
        ..Variables::default()
    };
    let off = Variables {
        ay_offset_std: 0.0,
        ..v.clone()
    };
    assert_eq!(LateralAccelerometer::from_parameters(&off, false), Ok(None));
    let mut learner = LateralAccelerometer::from_parameters(&v, false)
        .expect("valid parameters")
        .expect("the offset is learned");
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    feed(
        &mut learner,
        &mut rng,
        30_000,
        (0.0, 0.0, SPEED),
        (0.2, 0.12),
    );
    feed(&mut learner, &mut rng, 300, (0.03, 0.3, SPEED), (0.2, 0.12));
    let [offset, gain] = [learner.estimate[0], learner.estimate[1]];
    assert!((offset - 0.2).abs() < 0.05, "{learner:?}");
    assert_eq!(gain, 0.0);
}

/// `ay_meas` reading `1 + gain` times the truth, with `ay_gain_std` `std` (learned by the grip
/// filter's own state) and the offset's learner off.
fn gained_accelerometer(gain: f64, std: f64) -> SensorOffset {
    SensorOffset {
        sensor: vr::AY_MEAS,
        offset: 0.0,
        gain,
        learner_std: Some((vr::AY_GAIN_STD, std)),
        learned_output: vr::AY_GAIN_EST,
    }
}

/// The body-fixed accelerometer's gain error (the roll's gravity) on the grip model: learned by
/// its filter, its sideslip error after a step steer stays near the clean sensor's.
#[test]
fn the_grip_filter_learns_the_accelerometer_gain() {
    let (clean, _, _) = largest_sideslip_error(&gained_accelerometer(0.0, 0.1));
    let (ignored, _, none) = largest_sideslip_error(&gained_accelerometer(0.12, 0.0));
    let (learned, _, gain) = largest_sideslip_error(&gained_accelerometer(0.12, 0.1));
    println!(
        "largest sideslip error after the step: clean ay {clean}, gain ignored {ignored}, \
         gain learned {learned} rad; ay_gain_est at the end {gain}"
    );
    assert_eq!(none, 0.0);
    assert!((gain - 0.12).abs() < 0.03, "{gain}");
    assert_learning_restores([clean, ignored, learned], 2.0, 0.3);
}

/// `ay_meas` with `offset` and the learner's offset std `std` (its default where `None`).
fn accelerometer(offset: f64, std: Option<f64>) -> SensorOffset {
    SensorOffset {
        sensor: vr::AY_MEAS,
        offset,
        gain: 0.0,
        learner_std: std.map(|std| (vr::AY_OFFSET_STD, std)),
        learned_output: vr::AY_OFFSET_EST,
    }
}

#[test]
fn the_grip_model_s_sideslip_survives_an_offset_accelerometer() {
    let (clean, _, _) = largest_sideslip_error(&accelerometer(0.0, None));
    let (ignored, none, _) = largest_sideslip_error(&accelerometer(0.3, Some(0.0)));
    let (learned, offset, _) = largest_sideslip_error(&accelerometer(0.3, None));
    println!(
        "largest sideslip error after the step: clean ay {clean}, offset ignored {ignored}, \
         offset learned {learned} rad; ay_offset_est at the step {offset} m/s²"
    );
    assert_eq!(none, 0.0);
    assert!((offset - 0.3).abs() < 0.1, "{offset}");
    assert_learning_restores([clean, ignored, learned], 2.0, 0.3);
}
