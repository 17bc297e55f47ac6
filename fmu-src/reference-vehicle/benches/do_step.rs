//! One doStep of the ReferenceVehicle (1 ms, one integration step, noise and sensor chain on)
//! through the C ABI, next to the same step on the model struct without the FMI layer and the
//! bare vehicle-model step. Run with:
//!
//! ```text
//! CARGO_TARGET_DIR=target/bench cargo bench -p reference-vehicle --bench do_step
//! ```
//!
//! `fmi2_do_step` − `model_do_step` is what the FMI layer (state machine, argument and time
//! checks, catch_unwind) adds; `model_do_step` − `bare_vehicle_step` is the FMU's own work
//! around the equations (process noise, sensor chain, outputs). The `*_model_b` entries are the
//! same for model B (two-track, Magic Formula, 7 states), the `*_model_3` entries for model 3
//! (the full vehicle, 18 states; its budget is one 1 ms step within 10 µs).
//! `fmi2_get_outputs` and `fmi2_set_inputs` are one batched fmi2GetReal of every real output and
//! fmi2SetReal of the real inputs (driver and road): a master's per-step traffic with this FMU.

use divan::Bencher;
use fmi_export::testing::{references_of, stepping, DoStepOverhead, Slave};
use fmi_export::{Causality, CoSimulationModel, InstantiationContext, ValueType};
use vehicle_models::full_vehicle::{FullVehicle, FullVehicleInput, FullVehicleParams};
use vehicle_models::{
    DriverInputVector, Integrator, ReferenceModelKind, ReferenceVehicle as VehicleModel,
    ReferenceVehicleParams, SingleTrackHsri,
};
use ReferenceVehicle::model_description::{vr, VehicleModel as ModelItem, GUID, VARIABLES};
use ReferenceVehicle::ReferenceVehicle as Fmu;

fn main() {
    divan::main();
    if fmi_export::testing::benchmarking() {
        summary();
    }
}

/// See [`fmi_export::testing::DoStepOverhead`].
fn summary() {
    let table = DoStepOverhead::header("one ReferenceVehicle doStep (h = 1 ms)");
    for (label, model) in [
        ("model A (HSRI)", ModelItem::SingleTrackHsri as i32),
        (
            "model B (Magic Formula)",
            ModelItem::TwoTrackMagicFormula as i32,
        ),
        ("model 3 (full vehicle)", ModelItem::FullVehicle as i32),
    ] {
        let (mut fmu, mut slave) = (model_struct(model), slave(model));
        let mut bare: Box<dyn FnMut()> = if model == ModelItem::FullVehicle as i32 {
            Box::new(bare_full_vehicle_step())
        } else {
            Box::new(bare_step(model))
        };
        table.row(
            label,
            256,
            &mut stepping(STEP, |t| {
                divan::black_box(fmu.do_step(t, STEP));
            }),
            &mut stepping(STEP, |t| {
                divan::black_box(slave.do_step(t, STEP));
            }),
            &mut bare,
        );
    }
}

/// The bare vehicle-model step of `model` (vehicle-models' switchable reference vehicle,
/// steering 0.05 rad from 18 m/s) as a benchmark body.
fn bare_step(model: i32) -> impl FnMut() {
    let params = ReferenceVehicleParams {
        model: if model == ModelItem::TwoTrackMagicFormula as i32 {
            ReferenceModelKind::TwoTrack
        } else {
            ReferenceModelKind::SingleTrack
        },
        ..ReferenceVehicleParams::default()
    };
    let mut vehicle = VehicleModel::new(&params, 18.0);
    let input = DriverInputVector::new(0.05, 0.0, 0.0);
    move || {
        drop(divan::black_box(
            vehicle.step(divan::black_box(&input), STEP),
        ))
    }
}

/// The bare full-vehicle step (the seed car, steering 0.05 rad from 18 m/s).
fn bare_full_vehicle_step() -> impl FnMut() {
    let mut vehicle = FullVehicle::rolling(FullVehicleParams::default(), 18.0);
    let input = FullVehicleInput {
        steering_angle: 0.05,
        ..FullVehicleInput::default()
    };
    move || vehicle.step(divan::black_box(&input), STEP)
}

const STEP: f64 = 0.001;

/// The model struct (no FMI layer), initialised with a small steering angle.
fn model_struct(model: i32) -> Fmu {
    let mut fmu = Fmu::instantiate(&InstantiationContext {
        instance_name: String::from("bench"),
        resource_location: None,
    });
    fmu.variables_mut().model = model;
    fmu.variables_mut().steering_angle = 0.05;
    fmu.initialize(0.0).expect("initialise");
    fmu
}

/// The same through the C ABI.
fn slave(model: i32) -> Slave {
    let mut slave = Slave::instantiate(fmi_export::fmi2_api_of!(ReferenceVehicle), "bench", GUID)
        .expect("instantiate");
    slave.set_integer(vr::MODEL, model);
    slave.set_real(vr::STEERING_ANGLE, 0.05);
    slave.initialize(0.0);
    slave
}

// ---- Model A ----

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn bare_vehicle_step(bencher: Bencher) {
    let model = SingleTrackHsri::default();
    let input = DriverInputVector::new(0.05, 0.0, 0.0);
    let mut state = model.straight_rolling_state(18.0);
    bencher.bench_local(|| {
        state = model.step(
            divan::black_box(&state),
            &input,
            STEP,
            Integrator::SemiImplicitEuler,
        );
    });
}

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn model_do_step(bencher: Bencher) {
    let mut fmu = model_struct(ModelItem::SingleTrackHsri as i32);
    bencher.bench_local(stepping(STEP, |t| fmu.do_step(t, STEP)));
}

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn fmi2_do_step(bencher: Bencher) {
    let mut slave = slave(ModelItem::SingleTrackHsri as i32);
    bencher.bench_local(stepping(STEP, |t| slave.do_step(t, STEP)));
}

// ---- Model B ----

/// The bare model-B step (vehicle-models' switchable reference vehicle).
#[divan::bench(sample_count = 1000, sample_size = 200)]
fn bare_vehicle_step_model_b(bencher: Bencher) {
    bencher.bench_local(bare_step(ModelItem::TwoTrackMagicFormula as i32));
}

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn model_do_step_model_b(bencher: Bencher) {
    let mut fmu = model_struct(ModelItem::TwoTrackMagicFormula as i32);
    bencher.bench_local(stepping(STEP, |t| fmu.do_step(t, STEP)));
}

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn fmi2_do_step_model_b(bencher: Bencher) {
    let mut slave = slave(ModelItem::TwoTrackMagicFormula as i32);
    bencher.bench_local(stepping(STEP, |t| slave.do_step(t, STEP)));
}

// ---- Model 3 ----

/// The bare full-vehicle step (vehicle-models' `FullVehicle`).
#[divan::bench(sample_count = 1000, sample_size = 200)]
fn bare_vehicle_step_model_3(bencher: Bencher) {
    bencher.bench_local(bare_full_vehicle_step());
}

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn model_do_step_model_3(bencher: Bencher) {
    let mut fmu = model_struct(ModelItem::FullVehicle as i32);
    bencher.bench_local(stepping(STEP, |t| fmu.do_step(t, STEP)));
}

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn fmi2_do_step_model_3(bencher: Bencher) {
    let mut slave = slave(ModelItem::FullVehicle as i32);
    bencher.bench_local(stepping(STEP, |t| slave.do_step(t, STEP)));
}

// ---- The batched get / set of a master step ----

fn reals(causality: Causality) -> Vec<u32> {
    references_of(VARIABLES, ValueType::Real, causality)
}

/// fmi2GetReal of every real output (truth and sensors) in one call.
#[divan::bench(sample_count = 1000, sample_size = 200)]
fn fmi2_get_outputs(bencher: Bencher) {
    let mut slave = slave(ModelItem::SingleTrackHsri as i32);
    let outputs = reals(Causality::Output);
    let mut values = vec![0.0; outputs.len()];
    bencher.bench_local(|| {
        let status = slave.get_reals_into(divan::black_box(&outputs), &mut values);
        divan::black_box((status, &values));
    });
}

/// fmi2SetReal of the real inputs in one call (0, within their ranges).
#[divan::bench(sample_count = 1000, sample_size = 200)]
fn fmi2_set_inputs(bencher: Bencher) {
    let mut slave = slave(ModelItem::SingleTrackHsri as i32);
    let inputs = reals(Causality::Input);
    let values = vec![0.0; inputs.len()];
    bencher.bench_local(|| {
        divan::black_box(slave.set_reals(divan::black_box(&inputs), divan::black_box(&values)))
    });
}
