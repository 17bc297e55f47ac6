//! The VehicleStateEstimator through its C ABI, fed by a model-A truth with the seed-000 noise
//! (SPEC §7) generated here: tracking, sample timing, missing data, FMU state round trips,
//! determinism and parameter errors.

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::{Fmi2Api, Slave};
use nalgebra::SVector;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use vehicle_models::single_track::{SingleTrackState, MEASUREMENT_DIM, STATE_DIM};
use vehicle_models::{DriverInputVector, Integrator, SingleTrackHsri};
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel, GUID};
use VehicleStateEstimator::status;

fn api() -> Fmi2Api {
    fmi2_api_of!(VehicleStateEstimator)
}

/// An instance running the seeds' filters: these tests check seed 000's behaviour, so the
/// robustness defaults (speed rows, start from the measurements, gate) is off; its own tests
/// are in robustness.rs.
fn slave() -> Slave {
    let mut s = Slave::instantiate(api(), "estimator", GUID).expect("instantiate");
    seed_settings(&mut s);
    s
}

/// Seed 000's filter: model A, its Q and R (SPEC §7, the truth's noise below), none of the
/// robustness settings, the linear filters linearised once (no gain scheduling) and the sensors taken
/// as they come (no learned offsets: the seed's have none).
fn seed_settings(s: &mut Slave) {
    assert_eq!(
        s.set_integer(vr::MODEL, EstimatorModel::SingleTrack5State as i32),
        Fmi2Status::Ok
    );
    for zero in [
        vr::SCHEDULE_THRESHOLD,
        vr::OBSERVER_SCHEDULE_THRESHOLD,
        vr::YAW_RATE_OFFSET_STD,
        vr::AY_OFFSET_STD,
    ] {
        assert_eq!(s.set_real(zero, 0.0), Fmi2Status::Ok);
    }
    for flag in [
        vr::USE_SPEED_MEASUREMENTS,
        vr::START_FROM_MEASUREMENTS,
        vr::GATE_MEASUREMENTS,
    ] {
        assert_eq!(s.set_boolean(flag, false), Fmi2Status::Ok);
    }
    let process = [
        vr::PROCESS_NOISE_STD_VX,
        vr::PROCESS_NOISE_STD_VY,
        vr::PROCESS_NOISE_STD_YAW_RATE,
        vr::PROCESS_NOISE_STD_OMEGA_FRONT,
        vr::PROCESS_NOISE_STD_OMEGA_REAR,
    ];
    for (reference, std) in process.into_iter().zip(Truth::PROCESS_STD) {
        assert_eq!(s.set_real(reference, std), Fmi2Status::Ok);
    }
    for reference in [
        vr::MEASUREMENT_NOISE_STD_YAW_RATE,
        vr::MEASUREMENT_NOISE_STD_AY,
        vr::MEASUREMENT_NOISE_STD_OMEGA_FRONT,
        vr::MEASUREMENT_NOISE_STD_OMEGA_REAR,
    ] {
        assert_eq!(s.set_real(reference, Truth::SENSOR_STD), Fmi2Status::Ok);
    }
}

const SENSORS: [u32; 4] = [
    vr::YAW_RATE_MEAS,
    vr::AY_MEAS,
    vr::OMEGA_FRONT_MEAS,
    vr::OMEGA_REAR_MEAS,
];
const ESTIMATES: [u32; 18] = [
    vr::VX_EST,
    vr::VY_EST,
    vr::YAW_RATE_EST,
    vr::OMEGA_FRONT_EST,
    vr::OMEGA_REAR_EST,
    vr::SIDESLIP_EST,
    vr::AY_EST,
    vr::SLIP_ANGLE_FRONT_EST,
    vr::SLIP_ANGLE_REAR_EST,
    vr::SLIP_FRONT_EST,
    vr::SLIP_REAR_EST,
    vr::VX_STD,
    vr::VY_STD,
    vr::YAW_RATE_STD,
    vr::OMEGA_FRONT_STD,
    vr::OMEGA_REAR_STD,
    vr::SIDESLIP_STD,
    vr::NIS,
];

/// Seed-000 high ramp: 0 until 4 s, then 0.07 rad/s up to 0.122 rad.
fn high_ramp(t: f64) -> f64 {
    (0.07 * (t - 4.0)).clamp(0.0, 0.122)
}

/// Model A at 1 ms with the seed-000 process and measurement noise (SPEC §7).
struct Truth {
    model: SingleTrackHsri,
    state: SingleTrackState,
    rng: ChaCha20Rng,
}

impl Truth {
    const PROCESS_STD: [f64; STATE_DIM] = [1e-3, 1e-4, 1e-4, 1e-3, 1e-3];
    const SENSOR_STD: f64 = 1e-4;

    fn new(seed: u64) -> Self {
        let model = SingleTrackHsri::default();
        let state = model.straight_rolling_state(18.0);
        Self {
            model,
            state,
            rng: ChaCha20Rng::seed_from_u64(seed),
        }
    }

    fn measure(&mut self, input: &DriverInputVector) -> SVector<f64, MEASUREMENT_DIM> {
        let clean = self.model.measurement(&self.state, input);
        clean.map(|v| {
            let draw: f64 = StandardNormal.sample(&mut self.rng);
            v + Self::SENSOR_STD * draw
        })
    }

    fn step(&mut self, input: &DriverInputVector, dt: f64) {
        self.state = self
            .model
            .step(&self.state, input, dt, Integrator::SemiImplicitEuler);
        for (value, std) in self.state.iter_mut().zip(Self::PROCESS_STD) {
            let draw: f64 = StandardNormal.sample(&mut self.rng);
            *value += std * draw;
        }
    }
}

/// Runs the high ramp for `duration` with communication step = sample time = 1 ms; returns the
/// RMSE of vy_est against the truth and the largest status seen.
fn track(estimator: i32, duration: f64) -> (f64, i32) {
    track_scheduled(estimator, duration, 0.0)
}

/// [`track`] with the linear estimators (LKF and observer) gain-scheduled at
/// `schedule_threshold`.
fn track_scheduled(estimator: i32, duration: f64, schedule_threshold: f64) -> (f64, i32) {
    let mut s = slave();
    for threshold in [vr::SCHEDULE_THRESHOLD, vr::OBSERVER_SCHEDULE_THRESHOLD] {
        assert_eq!(s.set_real(threshold, schedule_threshold), Fmi2Status::Ok);
    }
    assert_eq!(s.set_integer(vr::ESTIMATOR, estimator), Fmi2Status::Ok);
    assert_eq!(s.set_integer(vr::PARTICLE_COUNT, 100), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    let mut truth = Truth::new(11);
    let h = 0.001;
    let steps = (duration / h).round() as usize;
    let mut squared = 0.0;
    let mut worst_status = 0;
    for k in 0..steps {
        let t = k as f64 * h;
        let input = DriverInputVector::new(high_ramp(t), 0.0, 0.0);
        let y = truth.measure(&input);
        assert_eq!(s.set_real(vr::STEERING_ANGLE, input[0]), Fmi2Status::Ok);
        assert_eq!(s.set_reals(&SENSORS, y.as_slice()), Fmi2Status::Ok);
        assert_eq!(s.do_step(t, h), Fmi2Status::Ok, "{:?}", s.log.last());
        truth.step(&input, h);
        let estimate = s.reals(&ESTIMATES);
        assert!(
            estimate.iter().all(|v| v.is_finite()),
            "k = {k}: {estimate:?}"
        );
        squared += (estimate[1] - truth.state[1]).powi(2);
        worst_status = worst_status.max(s.get_integer(vr::STATUS).1);
    }
    ((squared / steps as f64).sqrt(), worst_status)
}

#[test]
fn ekf_and_ukf_track_the_high_ramp_and_the_lkf_does_not() {
    // 8 s: the ramp reaches 0.122 rad at 5.74 s and is held (a shorter run keeps debug tests fast).
    let (ekf, ekf_status) = track(EstimatorKind::Ekf as i32, 8.0);
    let (ukf, _) = track(EstimatorKind::Ukf as i32, 8.0);
    let (lkf, _) = track(EstimatorKind::Lkf as i32, 8.0);
    assert_eq!(ekf_status, 0);
    // SPEC §7: EKF ≈ UKF ≈ truth (vy RMSE below 1e-3 m/s); the LKF far off.
    assert!(ekf < 1e-3, "EKF vy RMSE {ekf}");
    assert!(ukf < 1e-3, "UKF vy RMSE {ukf}");
    assert!(
        lkf > 1e-2,
        "LKF vy RMSE {lkf} should be far off on the high ramp"
    );
}

#[test]
fn the_gain_scheduled_lkf_tracks_the_high_ramp_as_the_ekf_does() {
    // Linearised once about straight driving (seed 000) the LKF is off by more than 1e-2 m/s
    // (above); re-linearised about its estimate whenever the linear model errs there by more
    // than one noise std (schedule_threshold 1, coarser than the default 0.001), it follows the
    // tyres into the nonlinear range and stays a linear filter in between. Measured:
    // 2.2e-4 m/s, as the EKF.
    let (scheduled, status) = track_scheduled(EstimatorKind::Lkf as i32, 8.0, 1.0);
    let (ekf, _) = track(EstimatorKind::Ekf as i32, 8.0);
    assert_eq!(status, 0);
    assert!(
        scheduled < 1e-3 && scheduled < 2.0 * ekf,
        "scheduled LKF vy RMSE {scheduled}, EKF {ekf}"
    );
}

#[test]
fn the_other_estimators_run_and_stay_finite() {
    for estimator in [
        EstimatorKind::UkfScaled as i32,
        EstimatorKind::Luenberger as i32,
        EstimatorKind::ParticleFilter as i32,
    ] {
        let (rmse, _) = track(estimator, 0.5);
        // Straight driving for the first half second: every estimator keeps vy near zero.
        assert!(rmse < 1e-2, "estimator {estimator}: vy RMSE {rmse}");
    }
}

#[test]
fn initial_outputs_are_the_initial_estimate() {
    let mut s = slave();
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let e = s.reals(&ESTIMATES);
    assert_eq!(e[0], 18.0);
    assert_eq!(e[3], 60.0);
    assert_eq!(e[12], 0.01, "vy_std = initial_std_vy");
    assert_eq!(s.get_integer(vr::STATUS), (Fmi2Status::Ok, 0));
}

/// Counts the doSteps after which the outputs changed.
fn changes(sample_time: f64, h: f64, steps: usize) -> usize {
    let mut s = slave();
    assert_eq!(s.set_real(vr::SAMPLE_TIME, sample_time), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::STEERING_ANGLE, 0.05), Fmi2Status::Ok);
    s.initialize(0.0);
    let mut previous = s.reals(&ESTIMATES);
    let mut count = 0;
    for k in 0..steps {
        // Measurements consistent with a left turn keep the estimate moving.
        s.set_reals(&SENSORS, &[0.1, 1.5, 60.0, 60.0]);
        assert_eq!(s.do_step(k as f64 * h, h), Fmi2Status::Ok);
        let now = s.reals(&ESTIMATES);
        if now != previous {
            count += 1;
        }
        previous = now;
    }
    count
}

#[test]
fn the_filter_runs_on_its_own_sample_grid() {
    // T = 10 ms, h = 1 ms: a new estimate every tenth doStep (samples at 0, 10, 20 ms …).
    assert_eq!(changes(0.01, 0.001, 100), 10);
    // T = 10 ms, h = 25 ms: every doStep contains two or three samples.
    assert_eq!(changes(0.01, 0.025, 8), 8);
    // What masters send: h = 0.009999999999999998 against T = 0.01, one sample per doStep.
    let mut s = slave();
    s.set_real(vr::SAMPLE_TIME, 0.01);
    s.initialize(0.0);
    let h = 0.009999999999999998;
    for k in 0..200 {
        s.set_reals(&SENSORS, &[0.0, 0.0, 60.0, 60.0]);
        assert_eq!(s.do_step(k as f64 * 0.01, h), Fmi2Status::Ok);
    }
    assert_eq!(s.get_integer(vr::ROWS_USED), (Fmi2Status::Ok, 4));
}

#[test]
fn missing_sensor_samples_skip_their_rows_and_never_produce_nan() {
    let mut s = slave();
    s.initialize(0.0);
    s.set_reals(&SENSORS, &[0.0, f64::NAN, 60.0, f64::INFINITY]);
    // ay_meas and omega_rear_meas have had no finite value: the first doStep logs that they are
    // treated as missing and answers fmi2OK (tests/unconnected_sensors.rs).
    assert_eq!(s.do_step(0.0, 0.001), Fmi2Status::Ok);
    assert_eq!(
        s.get_integer(vr::STATUS).1 & status::ROW_SKIPPED,
        status::ROW_SKIPPED
    );
    assert_eq!(s.get_integer(vr::ROWS_USED).1, 2);
    assert!(s.reals(&ESTIMATES).iter().all(|v| v.is_finite()));
    // Everything missing: no update, still finite.
    s.set_reals(&SENSORS, &[f64::NAN; 4]);
    assert_eq!(s.do_step(0.001, 0.001), Fmi2Status::Ok);
    assert_eq!(s.get_integer(vr::ROWS_USED).1, 0);
    assert!(s.reals(&ESTIMATES).iter().all(|v| v.is_finite()));
    // A non-finite driver input keeps the last finite one.
    s.set_reals(&SENSORS, &[0.0, 0.0, 60.0, 60.0]);
    s.set_real(vr::STEERING_ANGLE, f64::NAN);
    assert_eq!(s.do_step(0.002, 0.001), Fmi2Status::Ok);
    assert_eq!(s.get_integer(vr::STATUS).1, status::INPUT_HELD);
    assert!(s.reals(&ESTIMATES).iter().all(|v| v.is_finite()));
}

#[test]
fn below_min_speed_the_filter_holds_until_the_wheels_show_speed() {
    let mut s = slave();
    s.set_real(vr::VX_INITIAL, 0.5);
    s.initialize(0.0);
    let before = s.reals(&ESTIMATES);
    // Wheels at 1.5 rad/s · 0.3 m = 0.45 m/s, below min_speed: hold.
    s.set_reals(&SENSORS, &[0.0, 0.0, 1.5, 1.5]);
    assert_eq!(s.do_step(0.0, 0.001), Fmi2Status::Ok);
    assert_eq!(s.get_integer(vr::STATUS).1, status::BELOW_MIN_SPEED);
    // Held: the filter's state stands; the outputs are the sensors':
    // vx_est the wheels' measured speed, vy the steering geometry's (straight: 0), the
    // measured yaw rate and wheel speeds, not the state's.
    let held = s.reals(&ESTIMATES);
    assert!((held[0] - 0.45).abs() < 1e-12, "{}", held[0]);
    assert_eq!(held[1..5], [0.0, 0.0, 1.5, 1.5]);
    assert_ne!(held[3..5], before[3..5]);
    // The wheels report 18 m/s: re-seeded from them, then filtered as usual.
    s.set_reals(&SENSORS, &[0.0, 0.0, 60.0, 60.0]);
    assert_eq!(s.do_step(0.001, 0.001), Fmi2Status::Ok);
    assert_eq!(
        s.get_integer(vr::STATUS).1,
        status::BELOW_MIN_SPEED | status::STATE_RESET
    );
    assert!((s.get_real(vr::VX_EST).1 - 18.0).abs() < 0.05);
}

#[test]
fn the_ekf_recovers_after_zero_sensor_signals() {
    // Sensors read 0 for the first 10 ms (a bus not yet up, or a master that starts
    // connections at 0); afterwards the true signals. The estimate must find the vehicle again.
    let mut s = slave();
    s.initialize(0.0);
    let mut truth = Truth::new(3);
    let h = 0.001;
    let mut late_error: f64 = 0.0;
    for k in 0..1500 {
        let t = k as f64 * h;
        let input = DriverInputVector::new(0.0, 0.0, 0.0);
        let y = truth.measure(&input);
        let y = if k < 10 {
            [0.0; 4]
        } else {
            [y[0], y[1], y[2], y[3]]
        };
        s.set_reals(&SENSORS, &y);
        assert_eq!(s.do_step(t, h), Fmi2Status::Ok);
        truth.step(&input, h);
        let estimate = s.reals(&ESTIMATES);
        assert!(estimate.iter().all(|v| v.is_finite()));
        if k >= 1000 {
            late_error = late_error.max((estimate[0] - truth.state[0]).abs());
        }
    }
    assert!(late_error < 0.1, "max |vx_est - vx| = {late_error}");
}

#[test]
fn invalid_parameters_are_named_at_initialisation() {
    let mut s = slave();
    assert_eq!(s.set_real(vr::PROCESS_NOISE_STD_VX, 0.0), Fmi2Status::Ok);
    let status = s.initialize(0.0);
    assert_eq!(status, Fmi2Status::Error);
    let line = s.log.last().unwrap();
    assert_eq!(line.format, "%s");
    assert!(
        line.message.contains("process_noise_std_vx = 0"),
        "{}",
        line.message
    );
    let mut s = slave();
    let status = s.set_integer(vr::ESTIMATOR, 9);
    assert_eq!(status, Fmi2Status::Warning, "ignored with a warning");
    assert!(s.log.last().unwrap().message.contains("not an item"));
    let mut s = slave();
    let status = s.set_integer(vr::PARTICLE_COUNT, 1);
    assert_eq!(status, Fmi2Status::Warning, "clamped with a warning");
}

#[test]
fn wrong_guid_unknown_reference_and_bad_step_are_errors_with_a_log_line() {
    assert!(Slave::instantiate(api(), "x", "{wrong}").is_err());
    let mut s = slave();
    s.initialize(0.0);
    assert_eq!(s.get_real(4242).0, Fmi2Status::Error);
    assert!(s.log.last().unwrap().message.contains("4242"));
    let mut s = slave();
    s.initialize(0.0);
    assert_eq!(s.do_step(0.0, -1.0), Fmi2Status::Error);
    assert!(s
        .log
        .last()
        .unwrap()
        .message
        .contains("communicationStepSize"));
}

/// A run of `steps` doSteps of 1 ms from sample `first`, returning every output bitwise.
fn trace(s: &mut Slave, truth: &mut Truth, first: usize, steps: usize) -> Vec<u64> {
    let mut out = Vec::new();
    for k in first..first + steps {
        let t = k as f64 * 0.001;
        let input = DriverInputVector::new(high_ramp(t), 0.0, 0.0);
        let y = truth.measure(&input);
        s.set_real(vr::STEERING_ANGLE, input[0]);
        s.set_reals(&SENSORS, y.as_slice());
        assert_eq!(s.do_step(t, 0.001), Fmi2Status::Ok);
        truth.step(&input, 0.001);
        out.extend(s.reals(&ESTIMATES).iter().map(|v| v.to_bits()));
        out.push(s.get_integer(vr::STATUS).1 as u64);
    }
    out
}

#[test]
fn fmu_states_continue_bit_identically_for_every_estimator() {
    // Every estimator as seed 000 runs it, and the linear ones (LKF 1, Luenberger 6) also
    // gain-scheduled: their operating point has moved by 4.3 s and is part of the state.
    let cases = (1..=6).map(|e| (e, 0.0)).chain([(1, 1.0), (6, 1.0)]);
    for (estimator, schedule_threshold) in cases {
        let mut s = slave();
        s.set_integer(vr::ESTIMATOR, estimator);
        s.set_real(vr::SCHEDULE_THRESHOLD, schedule_threshold);
        s.set_real(vr::OBSERVER_SCHEDULE_THRESHOLD, schedule_threshold);
        s.set_integer(vr::PARTICLE_COUNT, 100);
        // Start at 4.3 s, on the ramp: the state is stored mid-manoeuvre.
        assert_eq!(s.initialize(4.3), Fmi2Status::Ok);
        let mut truth = Truth::new(5);
        trace(&mut s, &mut truth, 4300, 200);
        let (status, mut state) = s.get_state();
        assert_eq!(status, Fmi2Status::Ok);
        let truth_at_state = (truth.state, truth.rng.clone());
        let reference = trace(&mut s, &mut truth, 4500, 100);

        let rewind = |truth: &mut Truth| {
            truth.state = truth_at_state.0;
            truth.rng = truth_at_state.1.clone();
        };
        assert_eq!(s.set_state(&state), Fmi2Status::Ok);
        rewind(&mut truth);
        assert_eq!(
            trace(&mut s, &mut truth, 4500, 100),
            reference,
            "estimator {estimator}: fmi2SetFMUstate"
        );

        let bytes = s.serialize(&state).expect("serialize");
        let mut fresh = slave();
        let (status, mut restored) = fresh.deserialize(&bytes);
        assert_eq!(status, Fmi2Status::Ok, "{:?}", fresh.log.last());
        assert_eq!(fresh.set_state(&restored), Fmi2Status::Ok);
        rewind(&mut truth);
        assert_eq!(
            trace(&mut fresh, &mut truth, 4500, 100),
            reference,
            "estimator {estimator}: deserialized"
        );
        fresh.free_state(&mut restored);

        // A truncated serialization is refused with a message, never a crash.
        let mut cut = slave();
        let (status, _) = cut.deserialize(&bytes[..bytes.len() - 9]);
        assert_eq!(
            status,
            Fmi2Status::Error,
            "estimator {estimator}: truncated"
        );
        assert!(
            cut.log.last().is_some(),
            "estimator {estimator}: no log line"
        );
        s.free_state(&mut state);
    }
}

fn seeded_run(estimator: i32, seed: i32) -> Vec<u64> {
    let mut s = slave();
    s.set_integer(vr::ESTIMATOR, estimator);
    s.set_integer(vr::SEED, seed);
    s.set_integer(vr::PARTICLE_COUNT, 100);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let mut truth = Truth::new(9);
    trace(&mut s, &mut truth, 0, 200)
}

#[test]
fn outputs_are_bit_identical_in_any_thread() {
    for estimator in [
        EstimatorKind::Ekf as i32,
        EstimatorKind::ParticleFilter as i32,
    ] {
        let reference = seeded_run(estimator, 4);
        let handles: Vec<_> = (0..3)
            .map(|_| std::thread::spawn(move || seeded_run(estimator, 4)))
            .collect();
        for handle in handles {
            assert_eq!(handle.join().unwrap(), reference, "estimator {estimator}");
        }
    }
    assert_ne!(
        seeded_run(EstimatorKind::ParticleFilter as i32, 5),
        seeded_run(EstimatorKind::ParticleFilter as i32, 4),
        "the particle filter's seed matters"
    );
}

#[test]
fn many_instances_in_one_thread_are_independent() {
    let alone = seeded_run(EstimatorKind::Ukf as i32, 1);
    let mut slaves: Vec<Slave> = (0..32).map(|_| slave()).collect();
    let mut truths: Vec<Truth> = (0..32).map(|_| Truth::new(9)).collect();
    for s in slaves.iter_mut() {
        s.set_integer(vr::ESTIMATOR, EstimatorKind::Ukf as i32);
        s.set_integer(vr::PARTICLE_COUNT, 100);
        s.initialize(0.0);
    }
    let mut traces = vec![Vec::new(); 32];
    for k in 0..200 {
        for ((s, truth), out) in slaves
            .iter_mut()
            .zip(truths.iter_mut())
            .zip(traces.iter_mut())
        {
            out.extend(trace(s, truth, k, 1));
        }
    }
    for out in traces {
        assert_eq!(out, alone);
    }
}

/// One observation of an instance: every real output, status and rows_used as bits, and the
/// serialized FMU state.
fn observe(s: &mut Slave) -> (Vec<u64>, Vec<u8>) {
    let mut seen: Vec<u64> = s.reals(&ESTIMATES).iter().map(|v| v.to_bits()).collect();
    seen.push(s.get_integer(vr::STATUS).1 as u64);
    seen.push(s.get_integer(vr::ROWS_USED).1 as u64);
    let (status, mut state) = s.get_state();
    assert_eq!(status, Fmi2Status::Ok);
    let bytes = s.serialize(&state).expect("serialize");
    assert_eq!(s.free_state(&mut state), Fmi2Status::Ok);
    (seen, bytes)
}

/// The outputs are computed lazily (at the first read after a doStep with a sample): reading
/// them after every doStep, or only every `read_every` doSteps (more than the pending samples
/// kept, and with doSteps of half a sample, so some process no sample while the steering
/// changes), gives bit-identical outputs, status and serialized FMU states.
#[test]
fn lazily_computed_outputs_do_not_depend_on_when_they_are_read() {
    for estimator in [EstimatorKind::Ekf as i32, EstimatorKind::Lkf as i32] {
        for read_every in [3, 13, 40] {
            let mut every_step = slave();
            let mut sparse = slave();
            for s in [&mut every_step, &mut sparse] {
                s.set_integer(vr::ESTIMATOR, estimator);
                assert_eq!(s.initialize(4.0), Fmi2Status::Ok);
            }
            let mut truth = Truth::new(3);
            let h = 0.0005;
            let mut compared = 0;
            for k in 0..400 {
                let t = 4.0 + k as f64 * h;
                let input = DriverInputVector::new(high_ramp(t), 0.0, 0.0);
                let y = truth.measure(&input);
                for s in [&mut every_step, &mut sparse] {
                    s.set_real(vr::STEERING_ANGLE, input[0]);
                    s.set_reals(&SENSORS, y.as_slice());
                    assert_eq!(s.do_step(t, h), Fmi2Status::Ok);
                }
                truth.step(&input, h);
                let eager = observe(&mut every_step);
                if k % read_every == read_every - 1 {
                    assert_eq!(
                        observe(&mut sparse),
                        eager,
                        "estimator {estimator}, read every {read_every}, k = {k}"
                    );
                    compared += 1;
                }
            }
            assert!(compared >= 10);
        }
    }
}

/// vy RMSE of an EKF with the cornering-stiffness scales `estimator_scales` on the first 8 s of
/// the high ramp, driven by a model-A truth whose tyres have the scales `truth_scales`; plus
/// every output bitwise.
fn ekf_with_scales(truth_scales: [f64; 2], estimator_scales: Option<[f64; 2]>) -> (f64, Vec<u64>) {
    let mut s = slave();
    s.set_integer(vr::ESTIMATOR, EstimatorKind::Ekf as i32);
    if let Some([front, rear]) = estimator_scales {
        assert_eq!(
            s.set_real(vr::CORNERING_STIFFNESS_SCALE_FRONT, front),
            Fmi2Status::Ok
        );
        assert_eq!(
            s.set_real(vr::CORNERING_STIFFNESS_SCALE_REAR, rear),
            Fmi2Status::Ok
        );
    }
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    let mut truth = Truth::new(12);
    truth.model.vehicle.cornering_stiffness_scale_front = truth_scales[0];
    truth.model.vehicle.cornering_stiffness_scale_rear = truth_scales[1];
    let (h, steps) = (0.001, 8000);
    let (mut squared, mut outputs) = (0.0, Vec::new());
    for k in 0..steps {
        let t = k as f64 * h;
        let input = DriverInputVector::new(high_ramp(t), 0.0, 0.0);
        let y = truth.measure(&input);
        s.set_real(vr::STEERING_ANGLE, input[0]);
        s.set_reals(&SENSORS, y.as_slice());
        assert_eq!(s.do_step(t, h), Fmi2Status::Ok, "{:?}", s.log.last());
        truth.step(&input, h);
        let estimate = s.reals(&ESTIMATES);
        squared += (estimate[1] - truth.state[1]).powi(2);
        outputs.extend(estimate.iter().map(|v| v.to_bits()));
    }
    ((squared / steps as f64).sqrt(), outputs)
}

/// The cornering-stiffness scales reach model A: with the truth's scales the EKF tracks a car
/// with a softer front axle far better than with the seed's tyre; scale 1 set explicitly is
/// bit-identical to the default; values outside [0.05, 20] are clamped (a NaN ignored) with
/// fmi2Warning, as for every out-of-range parameter, and a message.
#[test]
fn cornering_stiffness_scales_act_on_model_a() {
    let car = [0.8, 0.95];
    let (seed_tyre, _) = ekf_with_scales(car, None);
    let (matched, _) = ekf_with_scales(car, Some(car));
    eprintln!("vy RMSE: scales of the car {matched:.3e} m/s, scale 1 {seed_tyre:.3e} m/s");
    assert!(
        matched < 0.2 * seed_tyre,
        "vy RMSE with the car's scales {matched:.3e}, with scale 1 {seed_tyre:.3e}"
    );
    assert_eq!(
        ekf_with_scales([1.0; 2], Some([1.0; 2])).1,
        ekf_with_scales([1.0; 2], None).1
    );
    for bad in [0.0, -1.0, 25.0, f64::NAN] {
        let mut s = slave();
        assert_eq!(
            s.set_real(vr::CORNERING_STIFFNESS_SCALE_FRONT, bad),
            Fmi2Status::Warning,
            "{bad}"
        );
        assert!(s.log.last().is_some(), "{bad}: no log line");
    }
}

/// The particle filter's FMU state is compact: per particle its 5 states, log weight and weight
/// (f64) and its ancestor (u32), 60 bytes per particle on model A with the bootstrap proposal;
/// the linearised optimal proposal keeps each particle's prediction (5 f64 more) while its draw
/// waits for the next sample's measurement, as it does between doSteps. Model A has no
/// conditionally linear state, so the marginalised proposal stores what the linearised optimal
/// one does.
#[test]
fn particle_filter_states_take_60_bytes_per_particle() {
    for (proposal, bytes) in [(1, 60), (2, 100), (3, 100)] {
        let serialized_size = |particles: i32| {
            let mut s = slave();
            s.set_integer(vr::ESTIMATOR, EstimatorKind::ParticleFilter as i32);
            s.set_integer(vr::PARTICLE_COUNT, particles);
            s.set_integer(vr::PARTICLE_PROPOSAL, proposal);
            assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
            let mut truth = Truth::new(3);
            trace(&mut s, &mut truth, 0, 20);
            let (status, mut state) = s.get_state();
            assert_eq!(status, Fmi2Status::Ok);
            let serialized = s.serialize(&state).expect("serialize");
            s.free_state(&mut state);
            serialized.len()
        };
        assert_eq!(
            serialized_size(200) - serialized_size(100),
            100 * bytes,
            "particle_proposal {proposal}"
        );
    }
}

#[test]
fn a_communication_step_of_a_million_seconds_is_discarded_at_once() {
    // One doStep with h = 1e6 s ran 1e9 filter steps; fmi-export bounds the samples
    // of one call (the estimator's internal step is its sample time).
    let mut s = slave();
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    assert_eq!(s.do_step(0.0, 1e6), Fmi2Status::Discard);
    let line = s.log.last().expect("a log line");
    assert!(line.message.contains("internal steps"), "{}", line.message);
}

#[test]
fn a_clamped_input_sets_status_bit_1024_for_that_step() {
    // The FMI layer clamps an out-of-range input with fmi2Warning; the estimator's status says
    // so for the doStep that consumes it, so a master that drops warnings still sees it.
    let mut s = slave();
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    s.set_reals(&SENSORS, &[0.0, 0.0, 60.0, 60.0]);
    assert_eq!(s.set_real(vr::STEERING_ANGLE, 2.0), Fmi2Status::Warning);
    assert_eq!(s.do_step(0.0, 0.001), Fmi2Status::Ok, "{:?}", s.log.last());
    let status_bits = s.get_integer(vr::STATUS).1;
    assert_eq!(status_bits & status::INPUT_CLAMPED, status::INPUT_CLAMPED);
    // A value inside the range: the bit is gone with the next step.
    assert_eq!(s.set_real(vr::STEERING_ANGLE, 0.1), Fmi2Status::Ok);
    assert_eq!(
        s.do_step(0.001, 0.001),
        Fmi2Status::Ok,
        "{:?}",
        s.log.last()
    );
    assert_eq!(s.get_integer(vr::STATUS).1 & status::INPUT_CLAMPED, 0);
}
