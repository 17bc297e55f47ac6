//! The gyro's offset (`yaw_rate_offset`, parameter `yaw_rate_offset_std`): learned standing
//! still within a second and driving straight within minutes (a straight road's bends hide it
//! for seconds), held in a corner, untouched by a
//! glitch, an all-zero row or a steering geometry too far from a single track's; through the
//! FMU, the yaw rate a standing car reports and the grip model's sideslip on a step steer whose
//! gyro reads 0.005 rad/s high.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use vehicle_models::{
    DriverInputVector, ReferenceModelKind, ReferenceVehicle, ReferenceVehicleParams,
};
use VehicleStateEstimator::model_description::{vr, EstimatorKind, Variables, GUID};

use crate::model_grip::set_sensors;
use VehicleStateEstimator::yaw_rate_offset::{
    OffsetSample, YawRateOffset, YAW_RATE_OFFSET_TIME_CONSTANT,
};

const T: f64 = 0.01;
/// The gyro's offset, rad/s (0.29°/s), and its noise, one sigma (0.2°/s: the campaigns').
const OFFSET: f64 = 0.005;
const GYRO_NOISE: f64 = 0.0035;
/// The measured speed's standard deviation, m/s.
const SPEED_STD: f64 = 0.05;

fn learner() -> YawRateOffset {
    let v = Variables {
        sample_time: T,
        measurement_noise_std_yaw_rate: GYRO_NOISE,
        ..Variables::default()
    };
    YawRateOffset::from_parameters(&v)
        .expect("valid parameters")
        .expect("on by default")
}

fn sample(yaw_rate: f64, ay: f64, speed: f64, steering: f64) -> OffsetSample {
    OffsetSample {
        yaw_rate,
        ay,
        all_zero: false,
        steering,
        speed: Some((speed, SPEED_STD)),
    }
}

/// `samples` samples of a gyro reading `yaw_rate + OFFSET` with noise, at `speed` with the
/// road-wheel angle `steering` and lateral acceleration `ay`.
fn feed(
    learner: &mut YawRateOffset,
    rng: &mut ChaCha8Rng,
    samples: usize,
    (yaw_rate, ay, speed, steering): (f64, f64, f64, f64),
) {
    let noise = Normal::new(0.0, GYRO_NOISE).unwrap();
    for _ in 0..samples {
        let gyro = yaw_rate + OFFSET + noise.sample(rng);
        learner.step(&sample(gyro, ay, speed, steering));
    }
}

/// Asserts that `offset` is `learned` decayed over `samples` samples without an update (to
/// rounding: the learner decays sample by sample).
fn assert_only_decayed(offset: f64, learned: f64, samples: usize) {
    let decayed = learned * (-(samples as f64) * T / YAW_RATE_OFFSET_TIME_CONSTANT).exp();
    assert!(
        (offset - decayed).abs() <= 1e-12 * decayed.abs(),
        "{offset} vs {decayed}"
    );
}

#[test]
fn standing_still_the_offset_is_learned_within_a_second() {
    let mut learner = learner();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    // parked with the wheels turned: at a stop the yaw rate is 0 whatever the steering
    feed(&mut learner, &mut rng, 100, (0.0, 0.05, 0.0, 0.4));
    let std = learner.variance.sqrt();
    println!("standing 1 s: offset {} rad/s, std {std}", learner.offset);
    assert!((learner.offset - OFFSET).abs() < 3.0 * std, "{learner:?}");
    // the measured speed's noise (0.05 m/s) times tan δ / l is most of the reference's error
    assert!(std < 0.001, "{learner:?}");
}

/// Through the FMU, standing still with a gyro that reads `OFFSET`: the held sample reports the
/// yaw rate with the learned offset taken off once (a standing car's 0), not twice.
#[test]
fn standing_still_the_reported_yaw_rate_is_the_gyro_less_its_offset() {
    let mut s = Slave::instantiate(fmi2_api_of!(VehicleStateEstimator), "standing", GUID)
        .expect("instantiate");
    assert_eq!(s.set_real(vr::SAMPLE_TIME, T), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    for (reference, value) in [
        (vr::STEERING_ANGLE, 0.0),
        (vr::YAW_RATE_MEAS, OFFSET),
        (vr::AY_MEAS, 0.0),
        (vr::OMEGA_FRONT_MEAS, 0.0),
        (vr::OMEGA_REAR_MEAS, 0.0),
        (vr::VX_MEAS, 0.0),
        (vr::AX_MEAS, 0.0),
    ] {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
    }
    for k in 0..200 {
        assert_eq!(s.do_step(f64::from(k) * T, T), Fmi2Status::Ok);
    }
    let [yaw_rate, offset] = s.reals(&[vr::YAW_RATE_EST, vr::YAW_RATE_OFFSET_EST])[..] else {
        unreachable!("two values asked for")
    };
    println!("standing 2 s: yaw_rate_est {yaw_rate}, yaw_rate_offset_est {offset} rad/s");
    assert!((offset - OFFSET).abs() < 0.2 * OFFSET, "offset {offset}");
    assert!(
        (yaw_rate - (OFFSET - offset)).abs() < 1e-12,
        "{yaw_rate} against {}",
        OFFSET - offset
    );
}

#[test]
fn driving_straight_it_is_learned_within_minutes_and_in_a_corner_held() {
    let mut learner = learner();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    feed(&mut learner, &mut rng, 6_000, (0.0, 0.1, 20.0, 0.0));
    let after_one_minute = learner.offset;
    feed(&mut learner, &mut rng, 24_000, (0.0, 0.1, 20.0, 0.0));
    let straight = learner;
    let std = straight.variance.sqrt();
    println!(
        "straight 1 min: {after_one_minute}, 5 min: {} rad/s, std {std}",
        straight.offset,
    );
    assert!(after_one_minute > 0.5 * OFFSET, "{after_one_minute}");
    assert!((straight.offset - OFFSET).abs() < 3.0 * std, "{straight:?}");
    // about half the prior's 0.005 rad/s: an offset that drifts over 600 s, told from bends
    // that last 5 s (measured 0.0028 rad/s)
    assert!(std < 0.6 * OFFSET, "{straight:?}");
    // a corner at 4 m/s² (the gyro reads the car's 0.2 rad/s and the offset): held
    feed(&mut learner, &mut rng, 500, (0.2, 4.0, 20.0, 0.03));
    assert_only_decayed(learner.offset, straight.offset, 500);
    assert!(learner.variance > straight.variance);
}

#[test]
fn a_glitch_an_all_zero_row_or_a_full_lock_teaches_nothing() {
    let mut learner = learner();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    feed(&mut learner, &mut rng, 100, (0.0, 0.05, 0.0, 0.0));
    let learned = learner.offset;
    // one sample of 1 rad/s standing still
    learner.step(&sample(1.0, 0.0, 0.0, 0.0));
    assert_only_decayed(learner.offset, learned, 1);
    // one all-zero row (a CAN dropout), which also reads as a stop
    learner.step(&OffsetSample {
        all_zero: true,
        ..sample(0.0, 0.0, 0.0, 0.0)
    });
    assert_only_decayed(learner.offset, learned, 2);
    // creeping at full lock: the steering geometry's 0.26 rad/s is no reference
    feed(&mut learner, &mut rng, 100, (0.24, 0.2, 0.8, 0.7));
    assert_only_decayed(learner.offset, learned, 102);
}

#[test]
fn a_negative_standard_deviation_is_refused_and_zero_switches_the_learner_off() {
    let with_std = |std: f64| {
        YawRateOffset::from_parameters(&Variables {
            yaw_rate_offset_std: std,
            ..Variables::default()
        })
    };
    let refused = with_std(-0.1).unwrap_err();
    assert!(refused.contains("yaw_rate_offset_std"), "{refused}");
    assert_eq!(with_std(0.0), Ok(None));
}

const SPEED: f64 = 65.0 / 3.6;

/// A sensor offset (and gain error) and the learner that takes it off: the sensor, its offset
/// and gain error, the learner's std parameter (its default where `None`) and the output that
/// reports what it learned.
pub(crate) struct SensorOffset {
    pub sensor: u32,
    pub offset: f64,
    /// The sensor reads `(1 + gain)` times the truth, plus `offset`.
    pub gain: f64,
    pub learner_std: Option<(u32, f64)>,
    pub learned_output: u32,
}

/// How long the reference vehicle drives straight before the step, s: the learners tell an
/// offset from a road's bends and crossfall over minutes.
const STRAIGHT_TIME: f64 = 300.0;

/// The grip model's EKF at its defaults but for `case.learner_std` on the two-track reference
/// vehicle driving straight for [`STRAIGHT_TIME`] and then through a 2.5° road-wheel step; `case.sensor`
/// reads `(1 + case.gain)` times the truth plus `case.offset`, the other sensors the truth.
/// Returns the largest sideslip error after the step, rad, and `case.learned_output` at the
/// step and at the end (3 s later).
pub(crate) fn largest_sideslip_error(case: &SensorOffset) -> (f64, f64, f64) {
    let mut s = Slave::instantiate(fmi2_api_of!(VehicleStateEstimator), "offset", GUID)
        .expect("instantiate");
    assert_eq!(
        s.set_integer(vr::ESTIMATOR, EstimatorKind::Ekf as i32),
        Fmi2Status::Ok
    );
    assert_eq!(s.set_real(vr::SAMPLE_TIME, T), Fmi2Status::Ok);
    if let Some((parameter, std)) = case.learner_std {
        assert_eq!(s.set_real(parameter, std), Fmi2Status::Ok);
    }
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    let params = ReferenceVehicleParams {
        model: ReferenceModelKind::TwoTrack,
        ..ReferenceVehicleParams::default()
    };
    let mut truth = ReferenceVehicle::new(&params, SPEED);
    let mut worst: f64 = 0.0;
    let mut learned = f64::NAN;
    let step = (STRAIGHT_TIME / T).round() as usize;
    for k in 0..step + 300 {
        let t = k as f64 * T;
        let steering = 2.5_f64.to_radians() * ((t - STRAIGHT_TIME) / 0.1).clamp(0.0, 1.0);
        let input = DriverInputVector::new(steering, 0.0, 0.0);
        let x = truth.truth(&input);
        set_sensors(&mut s, steering, &x);
        let measured = match case.sensor {
            vr::YAW_RATE_MEAS => x.yaw_rate,
            vr::AY_MEAS => x.lateral_acceleration,
            other => panic!("no offset case for value reference {other}"),
        };
        assert_eq!(
            s.set_real(case.sensor, (1.0 + case.gain) * measured + case.offset),
            Fmi2Status::Ok
        );
        assert_eq!(s.do_step(t, T), Fmi2Status::Ok, "{:?}", s.log.last());
        for _ in 0..10 {
            truth.step(&input, 0.001).expect("reference step");
        }
        let [sideslip, output] = s.reals(&[vr::SIDESLIP_EST, case.learned_output])[..] else {
            unreachable!("two values asked for")
        };
        if k == step {
            learned = output;
        }
        if k >= step {
            worst = worst.max((sideslip - truth.truth(&input).sideslip).abs());
        }
    }
    let [at_end] = s.reals(&[case.learned_output])[..] else {
        unreachable!("one value asked for")
    };
    (worst, learned, at_end)
}

/// The largest sideslip errors `[clean, ignored, learned]` (a clean sensor, its error ignored,
/// its error learned): ignoring the error multiplies the clean one by more than `worse`, and
/// learning leaves less than the share `left` of what the error added.
pub(crate) fn assert_learning_restores([clean, ignored, learned]: [f64; 3], worse: f64, left: f64) {
    assert!(ignored > worse * clean, "{ignored} vs {clean}");
    assert!(
        learned - clean < left * (ignored - clean),
        "{learned} vs {clean} and {ignored}"
    );
}

/// The gyro with `offset` and the learner's std `std` (its default where `None`).
fn gyro(offset: f64, std: Option<f64>) -> SensorOffset {
    SensorOffset {
        sensor: vr::YAW_RATE_MEAS,
        offset,
        gain: 0.0,
        learner_std: std.map(|std| (vr::YAW_RATE_OFFSET_STD, std)),
        learned_output: vr::YAW_RATE_OFFSET_EST,
    }
}

#[test]
fn the_grip_model_s_sideslip_survives_an_offset_gyro() {
    let (clean, _, _) = largest_sideslip_error(&gyro(0.0, None));
    let (ignored, none, _) = largest_sideslip_error(&gyro(OFFSET, Some(0.0)));
    let (learned, offset, _) = largest_sideslip_error(&gyro(OFFSET, None));
    println!(
        "largest sideslip error after the step: clean gyro {clean}, offset ignored {ignored}, \
         offset learned {learned} rad; yaw_rate_offset_est at the step {offset} rad/s"
    );
    assert_eq!(none, 0.0);
    // 5 min of straight driving with a noise-free gyro: 30 000 samples, each with the straight
    // reference's error of 0.32 rad/s (the driver's corrections and the road's bends), against
    // the prior's std of 0.005 rad/s weigh about 80 % of the way to the offset (measured
    // 0.0040 rad/s)
    assert!((offset - OFFSET).abs() < 0.3 * OFFSET, "{offset}");
    // measured 1.31e-3 / 1.80e-3 / 1.26e-3 rad (the offset ignored also misleads the lateral
    // accelerometer's learner, whose reference is r vx): the learner takes all of its effect
    assert_learning_restores([clean, ignored, learned], 1.2, 0.2);
}
