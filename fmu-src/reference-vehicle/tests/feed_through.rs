//! Direct feed-through: an output read after the master set new inputs at a
//! communication point is the output of those inputs, exactly for the outputs the
//! modelDescription's `<ModelStructure><Outputs>` says depend on them; reading or not reading
//! between setting the inputs and the next doStep does not change a single bit of the run.
//! Why the reference vehicle has these semantics: harness/scenarios/README.md, "Direct
//! feed-through".

use std::collections::{BTreeMap, BTreeSet};

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use model_description::{BaseType, Causality};
use ReferenceVehicle::model_description::{vr, GUID};

const XML: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../modelDescription/ReferenceVehicle.xml"
);

/// An input or output: (name, value reference, index in the model structure).
type Variable = (String, u32, usize);

/// The Real variables of `causality` (the Integer input `sensor_blanking` has its own test).
fn variables_of(causality: Causality) -> Vec<Variable> {
    let description = model_description::parse_file(XML).expect("ReferenceVehicle.xml parses");
    description
        .variables
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == causality && v.base_type() == BaseType::Real)
        .map(|(i, v)| (v.name.clone(), v.value_reference, i + 1))
        .collect()
}

/// The declared dependencies: output name -> input names.
fn declared() -> BTreeMap<String, BTreeSet<String>> {
    let description = model_description::parse_file(XML).expect("ReferenceVehicle.xml parses");
    let name = |index: usize| description.variables[index - 1].name.clone();
    description
        .model_structure
        .outputs
        .iter()
        .map(|unknown| {
            let inputs = unknown
                .dependencies
                .as_ref()
                .expect("explicit dependencies");
            (
                name(unknown.index),
                inputs.iter().map(|&i| name(i)).collect(),
            )
        })
        .collect()
}

/// A vehicle of `model` with noise and gravity in the accelerometers, after 0.3 s of a steering
/// ramp with drive torque on a banked, graded road: every input is away from a special value.
fn driven_vehicle(model: i32) -> Slave {
    let mut s = Slave::instantiate(fmi2_api_of!(ReferenceVehicle), "rv", GUID).expect("instance");
    assert_eq!(s.set_integer(vr::MODEL, model), Fmi2Status::Ok);
    assert_eq!(
        s.set_boolean(vr::GRAVITY_IN_ACCELEROMETERS, true),
        Fmi2Status::Ok
    );
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let inputs: Vec<u32> = variables_of(Causality::Input).iter().map(|v| v.1).collect();
    for k in 0..300 {
        let t = k as f64 * 1e-3;
        let values = [0.2 * t, 300.0, 0.0, 0.9, 0.02, 0.03];
        assert_eq!(s.set_reals(&inputs, &values), Fmi2Status::Ok);
        assert_eq!(s.do_step(t, 1e-3), Fmi2Status::Ok, "{:?}", s.log.last());
    }
    s
}

#[test]
fn outputs_depend_on_exactly_the_declared_inputs() {
    let inputs = variables_of(Causality::Input);
    let outputs = variables_of(Causality::Output);
    let output_refs: Vec<u32> = outputs.iter().map(|v| v.1).collect();
    let mut observed: BTreeMap<String, BTreeSet<String>> = outputs
        .iter()
        .map(|v| (v.0.clone(), BTreeSet::new()))
        .collect();
    for model in 1..=3 {
        let mut s = driven_vehicle(model);
        let before = s.reals(&output_refs);
        for (name, reference, _) in &inputs {
            let (_, value) = s.get_real(*reference);
            assert_eq!(s.set_real(*reference, value + 0.01), Fmi2Status::Ok);
            let after = s.reals(&output_refs);
            for (i, output) in outputs.iter().enumerate() {
                if after[i].to_bits() != before[i].to_bits() {
                    observed.get_mut(&output.0).unwrap().insert(name.clone());
                }
            }
            assert_eq!(s.set_real(*reference, value), Fmi2Status::Ok);
            assert_eq!(
                s.reals(&output_refs)
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                before.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "model {model}: setting {name} back must give the outputs back"
            );
        }
    }
    // The blanking input blanks every channel of its mask at once.
    for output in outputs
        .iter()
        .map(|v| &v.0)
        .filter(|n| n.ends_with("_meas"))
    {
        let dependency = blanking_dependency(output);
        observed.get_mut(output).unwrap().extend(dependency);
    }
    assert_eq!(
        observed,
        declared(),
        "observed (left, union of models 1-3) against declared (right) output dependencies"
    );
}

/// Runs a steering ramp, reading the outputs after the inputs are set (as the harness master
/// does) or not, and returns every output of every step, bitwise.
fn ramp_trace(model: i32, read_after_setting: bool) -> Vec<u64> {
    let mut s = Slave::instantiate(fmi2_api_of!(ReferenceVehicle), "rv", GUID).expect("instance");
    assert_eq!(s.set_integer(vr::MODEL, model), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::SENSOR_LATENCY, 0.003), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::SENSOR_SAMPLE_PERIOD, 0.002), Fmi2Status::Ok);
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok);
    let outputs: Vec<u32> = variables_of(Causality::Output)
        .iter()
        .map(|v| v.1)
        .collect();
    let mut trace = Vec::new();
    for k in 0..200 {
        let t = k as f64 * 1e-3;
        assert_eq!(s.set_real(vr::STEERING_ANGLE, 0.5 * t), Fmi2Status::Ok);
        if read_after_setting {
            s.reals(&outputs);
        }
        assert_eq!(s.do_step(t, 1e-3), Fmi2Status::Ok);
        trace.extend(s.reals(&outputs).iter().map(|v| v.to_bits()));
    }
    trace
}

#[test]
fn reading_between_setting_and_stepping_changes_nothing() {
    for model in 1..=2 {
        assert_eq!(
            ramp_trace(model, true),
            ramp_trace(model, false),
            "model {model}"
        );
    }
}

/// The measured lateral acceleration read after the steering angle of t_n was set is the truth
/// of t_n plus the same noise draw: the sensor samples the right limit at t_n, y(k) = h(x(k),
/// u(k)) (000: 4.99-4.102).
#[test]
fn the_sensor_sample_of_a_communication_point_follows_its_input() {
    let mut s = driven_vehicle(1);
    let ay_before = s.reals(&[vr::AY])[0];
    let error_before = s.reals(&[vr::AY_MEAS])[0] - ay_before;
    assert_eq!(s.set_real(vr::STEERING_ANGLE, 0.1), Fmi2Status::Ok);
    let ay_after = s.reals(&[vr::AY])[0];
    let error_after = s.reals(&[vr::AY_MEAS])[0] - ay_after;
    assert!(
        (ay_after - ay_before).abs() > 0.1,
        "ay follows the steering angle"
    );
    assert!(
        (error_after - error_before).abs() < 1e-9,
        "{error_before} {error_after}"
    );
}

/// `{"sensor_blanking"}` when blanking every channel turns `output` into NaN at once.
fn blanking_dependency(output: &str) -> BTreeSet<String> {
    let mut s = driven_vehicle(1);
    let reference = variables_of(Causality::Output)
        .into_iter()
        .find(|v| v.0 == output)
        .expect("a Real output")
        .1;
    let before = s.get_real(reference).1;
    assert_eq!(s.set_integer(vr::SENSOR_BLANKING, 63), Fmi2Status::Ok);
    let blanked = s.get_real(reference).1;
    assert_eq!(s.set_integer(vr::SENSOR_BLANKING, 0), Fmi2Status::Ok);
    assert_eq!(
        s.get_real(reference).1.to_bits(),
        before.to_bits(),
        "{output} comes back"
    );
    if before.is_finite() && blanked.is_nan() {
        BTreeSet::from([String::from("sensor_blanking")])
    } else {
        BTreeSet::new()
    }
}
