//! Tunable parameters through the C ABI: the noise levels, gates and tyre scales are `tunable`
//! parameters. A value set during the run takes effect at the next filter sample (not at a doStep
//! that processes no sample), and a `fixed` parameter set during the run is refused with
//! fmi2Error naming it.

use crate::car;

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use VehicleStateEstimator::model_description::{vr, GUID};

/// Filter sample time; each doStep is half of it, so every other doStep processes a sample.
const SAMPLE_TIME: f64 = 0.01;
const STEP: f64 = 0.005;

fn estimator() -> Slave {
    let mut s = Slave::instantiate(fmi2_api_of!(VehicleStateEstimator), "tunable", GUID)
        .expect("instantiate");
    assert_eq!(s.set_real(vr::SAMPLE_TIME, SAMPLE_TIME), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    s
}

/// Straight driving at 20 m/s with a lateral acceleration the model does not explain, so the
/// weight of the ay row shows in the estimate.
fn sensors(t: f64) -> [f64; 6] {
    let wheel = 20.0 / 0.3;
    [
        0.05 * t.sin(),
        0.8 * (3.0 * t).sin(),
        wheel,
        wheel,
        0.0,
        20.0,
    ]
}

fn step(s: &mut Slave, k: usize) -> Vec<f64> {
    let t = k as f64 * STEP;
    assert_eq!(s.set_reals(&car::SENSORS, &sensors(t)), Fmi2Status::Ok);
    assert_eq!(s.do_step(t, STEP), Fmi2Status::Ok, "{:?}", s.log.last());
    s.reals(&[vr::VY_EST, vr::YAW_RATE_EST, vr::AY_EST, vr::NIS])
}

#[test]
fn a_tuned_noise_level_takes_effect_at_the_next_sample() {
    let (mut plain, mut tuned) = (estimator(), estimator());
    // doStep k processes a sample when k is even (t = k STEP is on the sample grid).
    let change_after = 201;
    for k in 0..=change_after {
        assert_eq!(step(&mut plain, k), step(&mut tuned, k), "k = {k}");
    }
    assert_eq!(
        tuned.set_real(vr::MEASUREMENT_NOISE_STD_AY, 5.0),
        Fmi2Status::Ok,
        "{:?}",
        tuned.log.last()
    );
    // The next doStep (k = 202) processes the sample at 1.01 s with R of ay = 25.
    let (before, after) = (
        step(&mut plain, change_after + 1),
        step(&mut tuned, change_after + 1),
    );
    assert_ne!(before, after);
    // A weaker ay row lowers the NIS of that sample.
    assert!(after[3] < before[3], "NIS {} -> {}", before[3], after[3]);
}

#[test]
fn a_tuned_value_set_between_samples_leaves_the_held_outputs_alone() {
    let (mut plain, mut tuned) = (estimator(), estimator());
    for k in 0..=200 {
        step(&mut plain, k);
        step(&mut tuned, k);
    }
    assert_eq!(
        tuned.set_real(vr::MEASUREMENT_NOISE_STD_AY, 5.0),
        Fmi2Status::Ok
    );
    // k = 201 holds the outputs of the sample at 1.0 s: nothing changes before the next sample.
    assert_eq!(step(&mut plain, 201), step(&mut tuned, 201));
    assert_ne!(step(&mut plain, 202), step(&mut tuned, 202));
}

#[test]
fn a_fixed_parameter_set_during_the_run_is_refused() {
    let mut s = estimator();
    step(&mut s, 0);
    assert_eq!(s.set_real(vr::MASS, 1600.0), Fmi2Status::Error);
    let message = format!("{:?}", s.log.last());
    assert!(
        message.contains("'mass'") && message.contains("Fixed parameter"),
        "{message}"
    );
}
