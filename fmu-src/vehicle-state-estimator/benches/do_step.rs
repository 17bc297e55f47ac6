//! One doStep of the VehicleStateEstimator (communication step = sample time = 1 ms, so exactly
//! one filter sample per doStep) through the C ABI, next to the same step on the model struct
//! without the FMI layer and the bare filter step (measurement update + time update of the
//! `estimation` crate's filter). Run with:
//!
//! ```text
//! CARGO_TARGET_DIR=target/bench cargo bench -p vehicle-state-estimator --bench do_step
//! ```
//!
//! `model_b_*` are the same for model B (the 3-state seed-001 form) and its Kalman estimators.
//! On a shared, loaded machine compare the `fastest` and `median` columns; the `mean` is
//! dominated by preemptions.
//!
//! `fmi2_do_step` − `model_do_step` is what the FMI layer (state machine, argument and time
//! checks, catch_unwind) adds; `model_do_step` − `bare_filter_step` is the FMU's own work around
//! the filter (sample clock, input checks, copying the estimate for the outputs).
//!
//! The derived outputs (slip quantities, ay, standard deviations, sideslip) are computed lazily,
//! at the first output read after a doStep with a sample. `*_fmi2_do_step_get_outputs` is the
//! full cost a master pays per step: fmi2DoStep plus fmi2GetReal of all 18 real outputs.

use std::cell::Cell;

use divan::Bencher;
use fmi_export::ffi::Fmi2Status;
use fmi_export::testing::Slave;
use fmi_export::{CoSimulationModel, InstantiationContext};
use nalgebra::SVector;
use VehicleStateEstimator::model_description::estimator_model;
use VehicleStateEstimator::model_description::{estimator_kind, vr, Variables, GUID};
use VehicleStateEstimator::{
    filter_a, filter_b, initial_estimate_a, initial_estimate_b, model_a, model_b,
    VehicleStateEstimator as Fmu,
};

fn main() {
    divan::main();
}

const STEP: f64 = 0.001;
const ESTIMATORS: [(&str, i32); 6] = [
    ("lkf", estimator_kind::LKF),
    ("ekf", estimator_kind::EKF),
    ("ukf", estimator_kind::UKF),
    ("ukf_scaled", estimator_kind::UKF_SCALED),
    ("luenberger", estimator_kind::LUENBERGER),
    ("particle_filter_500", estimator_kind::PARTICLE_FILTER),
];
const NAMES: [&str; 6] = [
    "lkf",
    "ekf",
    "ukf",
    "ukf_scaled",
    "luenberger",
    "particle_filter_500",
];
/// A left turn at 18 m/s as the sensors see it.
const MEASUREMENT: [f64; 4] = [0.1, 1.8, 60.0, 60.0];

fn estimator(name: &str) -> i32 {
    ESTIMATORS
        .iter()
        .find(|(n, _)| *n == name)
        .expect("known")
        .1
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn bare_filter_step(bencher: Bencher, name: &str) {
    let variables = Variables {
        estimator: estimator(name),
        ..Variables::default()
    };
    let model = model_a(&variables).expect("model");
    let initial = initial_estimate_a(&variables).expect("initial");
    let mut filter = filter_a(&variables, model, &initial).expect("filter");
    let input = SVector::<f64, 3>::new(0.05, 0.0, 0.0);
    let measurement = SVector::<f64, 4>::from(MEASUREMENT);
    bencher.bench_local(|| {
        let estimator = filter.estimator_mut();
        let report = estimator.update(divan::black_box(&measurement), &input, &[true; 4]);
        let predicted = estimator.predict(&input);
        divan::black_box((report.is_ok(), predicted.is_ok()))
    });
}

fn with_inputs(variables: &mut Variables) {
    variables.steering_angle = 0.05;
    variables.yaw_rate_meas = MEASUREMENT[0];
    variables.ay_meas = MEASUREMENT[1];
    variables.omega_front_meas = MEASUREMENT[2];
    variables.omega_rear_meas = MEASUREMENT[3];
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn model_do_step(bencher: Bencher, name: &str) {
    let mut fmu = Fmu::instantiate(&InstantiationContext {
        instance_name: String::from("bench"),
        resource_location: None,
    });
    fmu.variables_mut().estimator = estimator(name);
    with_inputs(fmu.variables_mut());
    fmu.initialize(0.0).expect("initialise");
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let outcome = fmu.do_step(t, STEP);
        time.set(t + STEP);
        divan::black_box(outcome)
    });
}

/// The 18 real outputs.
const OUTPUTS: [u32; 18] = [
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

/// One master step: fmi2DoStep, then fmi2GetReal of every real output (into a stack array).
fn do_step_and_get_outputs(slave: &mut Slave, t: f64) -> (Fmi2Status, Fmi2Status, [f64; 18]) {
    let status = slave.do_step(t, STEP);
    let mut values = [0.0; 18];
    // SAFETY: OUTPUTS and values both hold 18 elements.
    let read = unsafe {
        (slave.api.get_real)(
            slave.component,
            OUTPUTS.as_ptr(),
            OUTPUTS.len(),
            values.as_mut_ptr(),
        )
    };
    (status, read, values)
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn fmi2_do_step(bencher: Bencher, name: &str) {
    let mut slave = slave_a(name);
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let status = slave.do_step(t, STEP);
        time.set(t + STEP);
        divan::black_box(status)
    });
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn fmi2_do_step_get_outputs(bencher: Bencher, name: &str) {
    let mut slave = slave_a(name);
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let result = do_step_and_get_outputs(&mut slave, t);
        time.set(t + STEP);
        divan::black_box(result)
    });
}

fn slave_a(name: &str) -> Slave {
    let mut slave = Slave::instantiate(
        fmi_export::fmi2_api_of!(VehicleStateEstimator),
        "bench",
        GUID,
    )
    .expect("instantiate");
    slave.set_integer(vr::ESTIMATOR, estimator(name));
    slave.set_real(vr::STEERING_ANGLE, 0.05);
    slave.set_reals(
        &[
            vr::YAW_RATE_MEAS,
            vr::AY_MEAS,
            vr::OMEGA_FRONT_MEAS,
            vr::OMEGA_REAR_MEAS,
        ],
        &MEASUREMENT,
    );
    slave.initialize(0.0);
    slave
}

/// Model B (3-state seed-001 form): the Kalman estimators it supports.
const NAMES_B: [&str; 4] = ["lkf", "ekf", "ukf", "ukf_scaled"];
/// `[yaw_rate, ay, omega_front, omega_rear, vx]` of a left turn at 18 m/s.
const SENSORS_B: [f64; 5] = [0.1, 1.8, 60.0, 60.0, 18.0];

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_bare_filter_step(bencher: Bencher, name: &str) {
    let variables = Variables {
        model: estimator_model::TWO_TRACK_3_STATE,
        estimator: estimator(name),
        ..Variables::default()
    };
    let model = model_b(&variables).expect("model");
    let initial = initial_estimate_b(&variables).expect("initial");
    let mut filter = filter_b(&variables, model, &initial).expect("filter");
    let input = SVector::<f64, 2>::new(0.05, SENSORS_B[4]);
    let measurement = SVector::<f64, 2>::new(SENSORS_B[1], SENSORS_B[0]);
    bencher.bench_local(|| {
        let estimator = filter.estimator_mut();
        let report = estimator.update(divan::black_box(&measurement), &input, &[true; 2]);
        let predicted = estimator.predict(&input);
        divan::black_box((report.is_ok(), predicted.is_ok()))
    });
}

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_fmi2_do_step(bencher: Bencher, name: &str) {
    let mut slave = slave_b(name);
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let status = slave.do_step(t, STEP);
        time.set(t + STEP);
        divan::black_box(status)
    });
}

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_fmi2_do_step_get_outputs(bencher: Bencher, name: &str) {
    let mut slave = slave_b(name);
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let result = do_step_and_get_outputs(&mut slave, t);
        time.set(t + STEP);
        divan::black_box(result)
    });
}

fn slave_b(name: &str) -> Slave {
    let mut slave = Slave::instantiate(
        fmi_export::fmi2_api_of!(VehicleStateEstimator),
        "bench",
        GUID,
    )
    .expect("instantiate");
    slave.set_integer(vr::MODEL, estimator_model::TWO_TRACK_3_STATE);
    slave.set_integer(vr::ESTIMATOR, estimator(name));
    slave.set_real(vr::STEERING_ANGLE, 0.05);
    slave.set_reals(
        &[
            vr::YAW_RATE_MEAS,
            vr::AY_MEAS,
            vr::OMEGA_FRONT_MEAS,
            vr::OMEGA_REAR_MEAS,
            vr::VX_MEAS,
        ],
        &SENSORS_B,
    );
    slave.initialize(0.0);
    slave
}

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_model_do_step(bencher: Bencher, name: &str) {
    let mut fmu = Fmu::instantiate(&InstantiationContext {
        instance_name: String::from("bench"),
        resource_location: None,
    });
    let v = fmu.variables_mut();
    v.model = estimator_model::TWO_TRACK_3_STATE;
    v.estimator = estimator(name);
    v.steering_angle = 0.05;
    v.yaw_rate_meas = SENSORS_B[0];
    v.ay_meas = SENSORS_B[1];
    v.omega_front_meas = SENSORS_B[2];
    v.omega_rear_meas = SENSORS_B[3];
    v.vx_meas = SENSORS_B[4];
    fmu.initialize(0.0).expect("initialise");
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let outcome = fmu.do_step(t, STEP);
        time.set(t + STEP);
        divan::black_box(outcome)
    });
}
