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
//! around the equations (process noise, sensor chain, outputs).

use std::cell::Cell;

use divan::Bencher;
use fmi_export::testing::Slave;
use fmi_export::{CoSimulationModel, InstantiationContext};
use vehicle_models::{
    DriverInputVector, Integrator, ReferenceModelKind, ReferenceVehicle as VehicleModel,
    ReferenceVehicleParams, SingleTrackHsri,
};
use ReferenceVehicle::model_description::{vr, GUID};
use ReferenceVehicle::ReferenceVehicle as Fmu;

fn main() {
    divan::main();
}

const STEP: f64 = 0.001;

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
    let mut fmu = Fmu::instantiate(&InstantiationContext {
        instance_name: String::from("bench"),
        resource_location: None,
    });
    fmu.variables_mut().steering_angle = 0.05;
    fmu.initialize(0.0).expect("initialise");
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let outcome = fmu.do_step(t, STEP);
        time.set(t + STEP);
        divan::black_box(outcome)
    });
}

#[divan::bench(sample_count = 1000, sample_size = 200)]
fn fmi2_do_step(bencher: Bencher) {
    let mut slave = Slave::instantiate(fmi_export::fmi2_api_of!(ReferenceVehicle), "bench", GUID)
        .expect("instantiate");
    slave.set_real(vr::STEERING_ANGLE, 0.05);
    slave.initialize(0.0);
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let status = slave.do_step(t, STEP);
        time.set(t + STEP);
        divan::black_box(status)
    });
}

/// The same doStep with model B (two-track, Magic Formula, 7 states).
#[divan::bench(sample_count = 1000, sample_size = 200)]
fn fmi2_do_step_model_b(bencher: Bencher) {
    let mut slave = Slave::instantiate(fmi_export::fmi2_api_of!(ReferenceVehicle), "bench", GUID)
        .expect("instantiate");
    slave.set_integer(vr::MODEL, 2);
    slave.set_real(vr::STEERING_ANGLE, 0.05);
    slave.initialize(0.0);
    let time = Cell::new(0.0);
    bencher.bench_local(|| {
        let t = time.get();
        let status = slave.do_step(t, STEP);
        time.set(t + STEP);
        divan::black_box(status)
    });
}

/// The bare model-B step (vehicle-models' switchable reference vehicle), to compare with
/// `fmi2_do_step_model_b`.
#[divan::bench(sample_count = 1000, sample_size = 200)]
fn bare_vehicle_step_model_b(bencher: Bencher) {
    let params = ReferenceVehicleParams {
        model: ReferenceModelKind::TwoTrack,
        ..ReferenceVehicleParams::default()
    };
    let mut vehicle = VehicleModel::new(&params, 18.0);
    let input = DriverInputVector::new(0.05, 0.0, 0.0);
    bencher.bench_local(|| divan::black_box(vehicle.step(divan::black_box(&input), STEP)));
}
