//! Faults of real sensors and loggers: the accelerometers' band-limited vibration, time stamps
//! jittered by a few milliseconds and samples lost in gaps. Each at the level asked for, off by
//! default (bit-identical runs), and deterministic from the seed.

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use ReferenceVehicle::model_description::{vr, GUID};

const STEP: f64 = 0.01;

/// A model-1 car at 15 m/s on a slow sine of steering, run for `seconds` at 10 ms
/// communication steps with `setup` applied before initialisation; the recorded
/// `[ay, ay_meas, ax, ax_meas, yaw_rate, yaw_rate_meas]` per step.
fn run(seconds: f64, setup: impl Fn(&mut Slave)) -> Vec<[f64; 6]> {
    let mut s = Slave::instantiate(fmi2_api_of!(ReferenceVehicle), "rv", GUID).expect("instance");
    assert_eq!(s.set_real(vr::VX0, 15.0), Fmi2Status::Ok);
    setup(&mut s);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let outputs = [
        vr::AY,
        vr::AY_MEAS,
        vr::AX,
        vr::AX_MEAS,
        vr::YAW_RATE,
        vr::YAW_RATE_MEAS,
    ];
    let mut rows = Vec::new();
    for k in 0..(seconds / STEP).round() as usize {
        let t = k as f64 * STEP;
        let steering = 0.03 * (0.5 * t).sin();
        assert_eq!(s.set_real(vr::STEERING_ANGLE, steering), Fmi2Status::Ok);
        assert_eq!(s.set_real(vr::DRIVE_TORQUE, 150.0), Fmi2Status::Ok);
        assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok, "{:?}", s.log.last());
        let values = s.reals(&outputs);
        rows.push(std::array::from_fn(|i| values[i]));
    }
    rows
}

fn vibrating(s: &mut Slave) {
    assert_eq!(s.set_real(vr::VIBRATION_STD_AY_MEAS, 3.0), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::VIBRATION_STD_AX_MEAS, 2.0), Fmi2Status::Ok);
}

/// RMS of `x` minus its moving average over `window` samples (what is left above
/// ~1/(window · STEP) Hz).
fn rms_above(x: &[f64], window: usize) -> f64 {
    let half = window / 2;
    let n = x.len() - 2 * half;
    let sum: f64 = (half..x.len() - half)
        .map(|k| {
            let mean = x[k - half..=k + half].iter().sum::<f64>() / (2 * half + 1) as f64;
            (x[k] - mean).powi(2)
        })
        .sum();
    (sum / n as f64).sqrt()
}

#[test]
fn the_vibration_has_the_rms_asked_for_above_2_hz_and_leaves_the_truth_alone() {
    let clean = run(60.0, |_| {});
    let noisy = run(60.0, vibrating);
    // noise = false by default: the measurement is the truth plus the vibration alone
    let vibration: Vec<f64> = noisy.iter().map(|r| r[1] - r[0]).collect();
    let rms = (vibration.iter().map(|v| v * v).sum::<f64>() / vibration.len() as f64).sqrt();
    assert!((2.6..3.4).contains(&rms), "ay vibration RMS {rms}");
    // most of it above 2 Hz: a 0.5 s moving average (about 1 Hz) removes little of it
    let high = rms_above(&vibration, 50);
    assert!(high > 0.9 * rms, "above 2 Hz {high} of {rms}");
    // its low-frequency part is small: the 0.5 s means stay near zero
    let slow: Vec<f64> = vibration
        .chunks(50)
        .map(|c| c.iter().sum::<f64>() / 50.0)
        .collect();
    let slow_rms = (slow.iter().map(|v| v * v).sum::<f64>() / slow.len() as f64).sqrt();
    assert!(slow_rms < 0.25 * rms, "below 1 Hz {slow_rms}");
    let ax: Vec<f64> = noisy.iter().map(|r| r[3] - r[2]).collect();
    let ax_rms = (ax.iter().map(|v| v * v).sum::<f64>() / ax.len() as f64).sqrt();
    assert!((1.7..2.3).contains(&ax_rms), "ax vibration RMS {ax_rms}");
    // the truth, the gyro and the car are untouched
    for (a, b) in clean.iter().zip(&noisy) {
        assert_eq!(a[0].to_bits(), b[0].to_bits());
        assert_eq!(a[5].to_bits(), b[5].to_bits());
    }
}

#[test]
fn the_faults_are_deterministic_from_the_seed_and_change_with_it() {
    let all = |seed: i32| {
        move |s: &mut Slave| {
            vibrating(s);
            assert_eq!(s.set_integer(vr::SEED, seed), Fmi2Status::Ok);
            assert_eq!(s.set_boolean(vr::NOISE, true), Fmi2Status::Ok);
            assert_eq!(s.set_real(vr::SENSOR_LATENCY, 0.002), Fmi2Status::Ok);
            assert_eq!(s.set_real(vr::SAMPLE_JITTER, 0.002), Fmi2Status::Ok);
            assert_eq!(s.set_real(vr::SAMPLE_DROP_FRACTION, 0.01), Fmi2Status::Ok);
        }
    };
    let bits =
        |rows: &[[f64; 6]]| -> Vec<u64> { rows.iter().flatten().map(|v| v.to_bits()).collect() };
    let a = run(10.0, all(3));
    let b = run(10.0, all(3));
    let c = run(10.0, all(4));
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&c));
}

#[test]
fn one_percent_of_the_samples_drop_in_gaps_of_at_most_60_ms() {
    let rows = run(600.0, |s| {
        assert_eq!(s.set_real(vr::SAMPLE_DROP_FRACTION, 0.01), Fmi2Status::Ok);
        assert_eq!(s.set_real(vr::SAMPLE_DROP_MAX_GAP, 0.06), Fmi2Status::Ok);
    });
    let dropped: Vec<bool> = rows.iter().map(|r| r[1].is_nan()).collect();
    // every channel together
    for r in &rows {
        assert_eq!(r[1].is_nan(), r[5].is_nan());
        assert!(r[0].is_finite());
    }
    let share = dropped.iter().filter(|d| **d).count() as f64 / dropped.len() as f64;
    assert!((0.007..0.013).contains(&share), "dropped share {share}");
    let mut longest = 0;
    let mut run_length = 0;
    for d in &dropped {
        run_length = if *d { run_length + 1 } else { 0 };
        longest = longest.max(run_length);
    }
    // gaps up to 60 ms: at most 6 samples of 10 ms
    assert!((3..=6).contains(&longest), "longest gap {longest} samples");
}

#[test]
fn jittered_samples_come_from_within_the_jitter_of_their_latency() {
    // 2 ms latency and 2 ms jitter, sampled every step: each ay_meas is the true ay of 0-4 ms ago.
    let setup = |jitter: f64| {
        move |s: &mut Slave| {
            assert_eq!(s.set_boolean(vr::NOISE, true), Fmi2Status::Ok);
            for level in [vr::NOISE_STD_AY_MEAS, vr::NOISE_STD_YAW_RATE_MEAS] {
                assert_eq!(s.set_real(level, 0.0), Fmi2Status::Ok);
            }
            for level in [
                vr::PROCESS_NOISE_STD_VX,
                vr::PROCESS_NOISE_STD_VY,
                vr::PROCESS_NOISE_STD_YAW_RATE,
                vr::PROCESS_NOISE_STD_OMEGA_FRONT,
                vr::PROCESS_NOISE_STD_OMEGA_REAR,
            ] {
                assert_eq!(s.set_real(level, 0.0), Fmi2Status::Ok);
            }
            assert_eq!(s.set_real(vr::QUANTUM_AY_MEAS, 0.0), Fmi2Status::Ok);
            assert_eq!(s.set_real(vr::SENSOR_SAMPLE_PERIOD, 0.0), Fmi2Status::Ok);
            assert_eq!(s.set_real(vr::SENSOR_LATENCY, 0.002), Fmi2Status::Ok);
            assert_eq!(s.set_real(vr::SAMPLE_JITTER, jitter), Fmi2Status::Ok);
        }
    };
    let steady = run(20.0, setup(0.0));
    let jittered = run(20.0, setup(0.002));
    let differing = steady
        .iter()
        .zip(&jittered)
        .filter(|(a, b)| a[1].to_bits() != b[1].to_bits())
        .count();
    assert!(
        differing > steady.len() / 2,
        "{differing} of {}",
        steady.len()
    );
    // The jittered samples are off by what 2 ms of the signal's 10 ms change allow: a fifth of it
    // at most, on average, and never more than a whole one.
    let (mut errors, mut changes, mut largest_change) = (0.0, 0.0, 0.0f64);
    for k in 1..steady.len() {
        let change = (steady[k][0] - steady[k - 1][0]).abs();
        errors += (jittered[k][1] - steady[k][1]).abs();
        changes += change;
        largest_change = largest_change.max(change);
    }
    assert!(errors <= 0.3 * changes, "{errors} vs {changes}");
    for k in 1..steady.len() {
        let error = (jittered[k][1] - steady[k][1]).abs();
        assert!(error <= largest_change, "k = {k}: {error}");
    }
}

/// With every fault on, a state taken mid-run continues bit-identically after
/// fmi2SetFMUstate: the faults' filters, gap and generator are part of the FMU state.
#[test]
fn a_restored_state_continues_the_faults_bit_identically() {
    let mut s = Slave::instantiate(fmi2_api_of!(ReferenceVehicle), "rv", GUID).expect("instance");
    assert_eq!(s.set_real(vr::VX0, 15.0), Fmi2Status::Ok);
    vibrating(&mut s);
    assert_eq!(s.set_real(vr::SENSOR_LATENCY, 0.002), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::SAMPLE_JITTER, 0.002), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::SAMPLE_DROP_FRACTION, 0.05), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let outputs = [vr::AY_MEAS, vr::AX_MEAS, vr::YAW_RATE_MEAS, vr::VX_MEAS];
    let steps = |s: &mut Slave, from: usize, count: usize| -> Vec<u64> {
        let mut bits = Vec::new();
        for k in from..from + count {
            let t = k as f64 * STEP;
            assert_eq!(s.set_real(vr::STEERING_ANGLE, 0.02), Fmi2Status::Ok);
            assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok);
            bits.extend(s.reals(&outputs).iter().map(|v| v.to_bits()));
        }
        bits
    };
    steps(&mut s, 0, 450);
    let (status, mut state) = s.get_state();
    assert_eq!(status, Fmi2Status::Ok);
    let reference = steps(&mut s, 450, 200);
    assert_eq!(s.set_state(&state), Fmi2Status::Ok);
    assert_eq!(steps(&mut s, 450, 200), reference);
    assert_eq!(s.free_state(&mut state), Fmi2Status::Ok);
}
