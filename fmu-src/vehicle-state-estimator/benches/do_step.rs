//! One doStep of the VehicleStateEstimator (communication step = sample time = 1 ms, so exactly
//! one filter sample per doStep) through the C ABI, next to the same step on the model struct
//! without the FMI layer and the bare filter step (measurement update + time update of the
//! `estimation` crate's filter). Run with:
//!
//! ```text
//! CARGO_TARGET_DIR=target/bench cargo bench -p vehicle-state-estimator --bench do_step
//! ```
//!
//! The unprefixed benchmarks are model A's (`model = 1`); `model_b_*` are the same for model B
//! (the 3-state seed-001 form) and its Kalman estimators; `model_grip_fmi2_*` the FMI steps on
//! the grip model (`model = 3`), the FMU's default.
//! On a shared, loaded machine compare the `fastest` and `median` columns; the `mean` is
//! dominated by preemptions.
//!
//! `fmi2_do_step` − `model_do_step` is what the FMI layer (state machine, argument and time
//! checks, catch_unwind) adds; `model_do_step` − `bare_filter_step` is the FMU's own work around
//! the filter (sample clock, input checks, copying the estimate for the outputs).
//!
//! The derived outputs (slip quantities, ay, standard deviations, sideslip) are computed lazily,
//! at the first output read after a doStep with a sample. `*_fmi2_do_step_get_outputs` is the
//! full cost a master pays per step: fmi2DoStep plus fmi2GetReal of all 18 real outputs;
//! `*_model_do_step_outputs` is the same work on the model struct (do_step, the lazy output
//! computation, the 18 values copied out), so the difference of the two is what the FMI layer
//! adds to a step with its output read. `fmi2_get_outputs` and `fmi2_set_inputs` are one
//! batched fmi2GetReal (18 outputs) and fmi2SetReal (9 inputs) alone.

use divan::Bencher;
use estimation::models::single_track::{ANCHORED_INPUT_DIM, ANCHORED_MEASUREMENT_DIM};
use estimation::registry::{self, BoxedEstimator};
use fmi_export::ffi::Fmi2Status;
use fmi_export::testing::{references_of, stepping, variables_of, DoStepOverhead, Slave};
use fmi_export::{Causality, CoSimulationModel, InstantiationContext, ValueType};
use nalgebra::SVector;
use vehicle_models::single_track::STATE_DIM;
use VehicleStateEstimator::model_a::ModelA;
use VehicleStateEstimator::model_b::ModelB;
use VehicleStateEstimator::model_description::EstimatorModel;
use VehicleStateEstimator::model_description::{vr, EstimatorKind, Variables, GUID, VARIABLES};
use VehicleStateEstimator::parameters::estimator_choice;
use VehicleStateEstimator::runner::EstimationModel;
use VehicleStateEstimator::VehicleStateEstimator as Fmu;

fn main() {
    divan::main();
    if fmi_export::testing::benchmarking() {
        summary();
    }
}

const STEP: f64 = 0.001;
const ESTIMATORS: [(&str, i32); 6] = [
    ("lkf", EstimatorKind::Lkf as i32),
    ("ekf", EstimatorKind::Ekf as i32),
    ("ukf", EstimatorKind::Ukf as i32),
    ("ukf_scaled", EstimatorKind::UkfScaled as i32),
    ("luenberger", EstimatorKind::Luenberger as i32),
    ("particle_filter_500", EstimatorKind::ParticleFilter as i32),
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

/// Model B (3-state seed-001 form): the Kalman estimators it supports.
const NAMES_B: [&str; 4] = ["lkf", "ekf", "ukf", "ukf_scaled"];
/// `[yaw_rate, ay, omega_front, omega_rear, vx]` of a left turn at 18 m/s.
const SENSORS_B: [f64; 5] = [0.1, 1.8, 60.0, 60.0, 18.0];

/// The real variables of one causality (18 outputs, 9 inputs), from the generated table.
fn reals(causality: Causality) -> impl Iterator<Item = &'static fmi_export::VariableInfo> {
    variables_of(VARIABLES, ValueType::Real, causality)
}

fn real_outputs() -> Vec<u32> {
    references_of(VARIABLES, ValueType::Real, Causality::Output)
}

fn estimator(name: &str) -> i32 {
    ESTIMATORS
        .iter()
        .find(|(n, _)| *n == name)
        .expect("known")
        .1
}

/// The filter the FMU would run with these parameters, built as the FMU builds it.
fn bare_filter<Model, const N: usize, const M: usize, const U: usize>(
    variables: &Variables,
) -> BoxedEstimator<N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    let model = Model::from_parameters(variables).expect("model");
    let initial = Model::initial_estimate(variables).expect("initial");
    let settings = model.registry_settings(variables);
    let (_, choice) = estimator_choice(variables).expect("estimator");
    registry::build(model, choice, &settings, &initial).expect("filter")
}

// ---- Model A ----

/// One bare filter step of model A (update, then predict), as a benchmark body.
fn bare_step_a(name: &str) -> impl FnMut() -> (bool, bool) {
    let variables = Variables {
        estimator: estimator(name),
        ..Variables::default()
    };
    let mut filter =
        bare_filter::<ModelA, STATE_DIM, ANCHORED_MEASUREMENT_DIM, ANCHORED_INPUT_DIM>(&variables);
    // The seed's four rows; no speed measurement (ax_valid = 0, vx row masked out).
    let input = ModelA::extend_input(&SVector::<f64, 3>::new(0.05, 0.0, 0.0), 0.0, None);
    let [r, ay, front, rear] = MEASUREMENT;
    let measurement = SVector::<f64, 5>::from([r, ay, front, rear, f64::NAN]);
    move || {
        let mask = [true, true, true, true, false];
        let report = filter.update(divan::black_box(&measurement), &input, &mask);
        let predicted = filter.predict(&input);
        divan::black_box((report.is_ok(), predicted.is_ok()))
    }
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn bare_filter_step(bencher: Bencher, name: &str) {
    bencher.bench_local(bare_step_a(name));
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn model_do_step(bencher: Bencher, name: &str) {
    let mut fmu = model_a_struct(name);
    bencher.bench_local(stepping(STEP, |t| fmu.do_step(t, STEP)));
}

/// What `fmi2_do_step_get_outputs` does, without the FMI layer.
#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn model_do_step_outputs(bencher: Bencher, name: &str) {
    let mut fmu = model_a_struct(name);
    bencher.bench_local(stepping(STEP, |t| do_step_and_copy_outputs(&mut fmu, t)));
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn fmi2_do_step(bencher: Bencher, name: &str) {
    let mut slave = slave_a(name);
    bencher.bench_local(stepping(STEP, |t| slave.do_step(t, STEP)));
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn fmi2_do_step_get_outputs(bencher: Bencher, name: &str) {
    let mut slave = slave_a(name);
    let mut outputs = Outputs::new();
    bencher.bench_local(stepping(STEP, |t| {
        do_step_and_get_outputs(&mut slave, &mut outputs, t)
    }));
}

/// The model struct (no FMI layer) set up like [`slave_a`].
fn model_a_struct(name: &str) -> Fmu {
    let mut fmu = Fmu::instantiate(&InstantiationContext {
        instance_name: String::from("bench"),
        resource_location: None,
    });
    let v = fmu.variables_mut();
    v.model = EstimatorModel::SingleTrack5State as i32;
    v.estimator = estimator(name);
    v.steering_angle = 0.05;
    v.yaw_rate_meas = MEASUREMENT[0];
    v.ay_meas = MEASUREMENT[1];
    v.omega_front_meas = MEASUREMENT[2];
    v.omega_rear_meas = MEASUREMENT[3];
    fmu.initialize(0.0).expect("initialise");
    fmu
}

fn slave_a(name: &str) -> Slave {
    slave_on(EstimatorModel::SingleTrack5State, name)
}

/// The FMU on `model` (1 or 3, which share model A's sensors) in a left turn at 18 m/s.
fn slave_on(model: EstimatorModel, name: &str) -> Slave {
    let mut slave = Slave::instantiate(
        fmi_export::fmi2_api_of!(VehicleStateEstimator),
        "bench",
        GUID,
    )
    .expect("instantiate");
    slave.set_integer(vr::MODEL, model as i32);
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

// ---- The grip model (the FMU's default) ----

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn model_grip_fmi2_do_step(bencher: Bencher, name: &str) {
    let mut slave = slave_on(EstimatorModel::SingleTrackGrip, name);
    bencher.bench_local(stepping(STEP, |t| slave.do_step(t, STEP)));
}

#[divan::bench(args = NAMES, sample_count = 300, sample_size = 20)]
fn model_grip_fmi2_do_step_get_outputs(bencher: Bencher, name: &str) {
    let mut slave = slave_on(EstimatorModel::SingleTrackGrip, name);
    let mut outputs = Outputs::new();
    bencher.bench_local(stepping(STEP, |t| {
        do_step_and_get_outputs(&mut slave, &mut outputs, t)
    }));
}

// ---- Model B ----

/// One bare filter step of model B (update, then predict), as a benchmark body.
fn bare_step_b(name: &str) -> impl FnMut() -> (bool, bool) {
    let variables = Variables {
        model: EstimatorModel::TwoTrack3State as i32,
        estimator: estimator(name),
        ..Variables::default()
    };
    let mut filter = bare_filter::<ModelB, 3, 2, 3>(&variables);
    let input = SVector::<f64, 3>::new(0.05, SENSORS_B[4], 0.0);
    let measurement = SVector::<f64, 2>::new(SENSORS_B[1], SENSORS_B[0]);
    move || {
        let report = filter.update(divan::black_box(&measurement), &input, &[true; 2]);
        let predicted = filter.predict(&input);
        divan::black_box((report.is_ok(), predicted.is_ok()))
    }
}

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_bare_filter_step(bencher: Bencher, name: &str) {
    bencher.bench_local(bare_step_b(name));
}

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_model_do_step(bencher: Bencher, name: &str) {
    let mut fmu = model_b_struct(name);
    bencher.bench_local(stepping(STEP, |t| fmu.do_step(t, STEP)));
}

/// What `model_b_fmi2_do_step_get_outputs` does, without the FMI layer.
#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_model_do_step_outputs(bencher: Bencher, name: &str) {
    let mut fmu = model_b_struct(name);
    bencher.bench_local(stepping(STEP, |t| do_step_and_copy_outputs(&mut fmu, t)));
}

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_fmi2_do_step(bencher: Bencher, name: &str) {
    let mut slave = slave_b(name);
    bencher.bench_local(stepping(STEP, |t| slave.do_step(t, STEP)));
}

#[divan::bench(args = NAMES_B, sample_count = 300, sample_size = 20)]
fn model_b_fmi2_do_step_get_outputs(bencher: Bencher, name: &str) {
    let mut slave = slave_b(name);
    let mut outputs = Outputs::new();
    bencher.bench_local(stepping(STEP, |t| {
        do_step_and_get_outputs(&mut slave, &mut outputs, t)
    }));
}

/// The model struct (no FMI layer) set up like [`slave_b`].
fn model_b_struct(name: &str) -> Fmu {
    let mut fmu = Fmu::instantiate(&InstantiationContext {
        instance_name: String::from("bench"),
        resource_location: None,
    });
    let v = fmu.variables_mut();
    v.model = EstimatorModel::TwoTrack3State as i32;
    v.estimator = estimator(name);
    v.steering_angle = 0.05;
    v.yaw_rate_meas = SENSORS_B[0];
    v.ay_meas = SENSORS_B[1];
    v.omega_front_meas = SENSORS_B[2];
    v.omega_rear_meas = SENSORS_B[3];
    v.vx_meas = SENSORS_B[4];
    fmu.initialize(0.0).expect("initialise");
    fmu
}

fn slave_b(name: &str) -> Slave {
    let mut slave = Slave::instantiate(
        fmi_export::fmi2_api_of!(VehicleStateEstimator),
        "bench",
        GUID,
    )
    .expect("instantiate");
    slave.set_integer(vr::MODEL, EstimatorModel::TwoTrack3State as i32);
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

// ---- One master step, and the batched get / set alone ----

/// One master step: fmi2DoStep, then fmi2GetReal of every real output.
fn do_step_and_get_outputs(
    slave: &mut Slave,
    outputs: &mut Outputs,
    t: f64,
) -> (Fmi2Status, Fmi2Status) {
    let status = slave.do_step(t, STEP);
    (status, get_outputs(slave, outputs))
}

/// The real output references and room for their values.
struct Outputs {
    references: Vec<u32>,
    values: Vec<f64>,
}

impl Outputs {
    fn new() -> Self {
        let references = real_outputs();
        let values = vec![0.0; references.len()];
        Self { references, values }
    }
}

/// One batched fmi2GetReal of every real output.
fn get_outputs(slave: &mut Slave, outputs: &mut Outputs) -> Fmi2Status {
    slave.get_reals_into(divan::black_box(&outputs.references), &mut outputs.values)
}

/// The same on the model struct: do_step, the lazy output computation a read triggers, and the
/// 18 real outputs copied out of the fields.
fn do_step_and_copy_outputs(fmu: &mut Fmu, t: f64) -> (fmi_export::StepOutcome, [f64; 18]) {
    let outcome = fmu.do_step(t, STEP);
    fmu.refresh_outputs();
    let v = fmu.variables();
    let values = [
        v.vx_est,
        v.vy_est,
        v.yaw_rate_est,
        v.omega_front_est,
        v.omega_rear_est,
        v.sideslip_est,
        v.ay_est,
        v.slip_angle_front_est,
        v.slip_angle_rear_est,
        v.slip_front_est,
        v.slip_rear_est,
        v.vx_std,
        v.vy_std,
        v.yaw_rate_std,
        v.omega_front_std,
        v.omega_rear_std,
        v.sideslip_std,
        v.nis,
    ];
    (outcome, values)
}

/// fmi2GetReal of the 18 real outputs alone, between doSteps (the lazy outputs are already
/// computed after the first read): the FMI layer's cost of one batched read.
#[divan::bench(sample_count = 300, sample_size = 200)]
fn fmi2_get_outputs(bencher: Bencher) {
    let mut slave = slave_b("lkf");
    let mut outputs = Outputs::new();
    bencher.bench_local(|| get_outputs(&mut slave, &mut outputs));
}

/// fmi2SetReal of the nine real inputs (driver inputs and sensors) alone, each with a value
/// within its range: the FMI layer's cost of one batched write (reference and range checks of
/// every value, then the stores).
#[divan::bench(sample_count = 300, sample_size = 200)]
fn fmi2_set_inputs(bencher: Bencher) {
    let mut slave = slave_b("lkf");
    let inputs = references_of(VARIABLES, ValueType::Real, Causality::Input);
    let values: Vec<f64> = reals(Causality::Input)
        .map(|v| 0.0f64.clamp(v.min, v.max))
        .collect();
    bencher.bench_local(|| {
        divan::black_box(slave.set_reals(divan::black_box(&inputs), divan::black_box(&values)))
    });
}

// ---- Interleaved summary: what the FMI layer adds, per estimator ----

/// See [`fmi_export::testing::DoStepOverhead`].
fn summary() {
    let table = DoStepOverhead::header("one VehicleStateEstimator doStep (h = sample time = 1 ms)");
    for name in NAMES {
        let calls = if name.starts_with("particle") { 2 } else { 64 };
        let label = format!("model A {name}");
        overhead_row(
            &table,
            &label,
            calls,
            model_a_struct(name),
            slave_a(name),
            bare_step_a(name),
        );
    }
    for name in NAMES_B {
        let label = format!("model B {name}");
        overhead_row(
            &table,
            &label,
            64,
            model_b_struct(name),
            slave_b(name),
            bare_step_b(name),
        );
    }
}

/// One summary row: the model struct's do_step, fmi2DoStep and the bare filter step.
fn overhead_row(
    table: &DoStepOverhead,
    label: &str,
    calls: usize,
    mut fmu: Fmu,
    mut slave: Slave,
    mut bare: impl FnMut() -> (bool, bool),
) {
    table.row(
        label,
        calls,
        &mut stepping(STEP, |t| {
            divan::black_box(fmu.do_step(t, STEP));
        }),
        &mut stepping(STEP, |t| {
            divan::black_box(slave.do_step(t, STEP));
        }),
        &mut || {
            bare();
        },
    );
}
