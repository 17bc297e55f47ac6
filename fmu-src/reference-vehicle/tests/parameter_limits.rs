//! Parameter bounds on the ReferenceVehicle: every parameter that physics or numerics bound has
//! `min` and `max` in the modelDescription, values that would make a step loop or allocate
//! without bound are refused at initialisation with a message naming the parameter, and the
//! noise levels are `tunable`, taking effect with the next doStep.

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use ReferenceVehicle::model_description::{vr, GUID};

use crate::common;
use common::NOISE_LEVELS;

const XML: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../modelDescription/ReferenceVehicle.xml"
);

/// Curve-fit coefficients of the tyres (HSRI of seed 000, MF 5.2 `p_*`/`r_*`): their physical
/// constraints hold for combinations (a positive peak `D`, a curvature `E <= 1` over the load
/// range), not for one coefficient, so they carry no bounds of their own.
fn is_tyre_fit_coefficient(name: &str) -> bool {
    let hsri = [
        "tyre_f01", "tyre_kr0", "tyre_kr1", "tyre_ca1", "tyre_ca2", "tyre_cs1", "tyre_cs2",
    ];
    let magic_formula = ["_p_", "_r_"].iter().any(|part| {
        (name.starts_with("tyre_front") || name.starts_with("tyre_rear")) && name.contains(part)
    });
    hsri.contains(&name) || magic_formula
}

#[test]
fn every_real_parameter_outside_the_tyre_fits_has_bounds() {
    let description = model_description::parse_file(XML).expect("ReferenceVehicle.xml parses");
    let unbounded: Vec<&str> = description
        .unbounded_parameters()
        .into_iter()
        .filter(|name| !is_tyre_fit_coefficient(name))
        // The noise seed: any i32 is a valid seed.
        .filter(|&name| name != "seed")
        .collect();
    assert!(
        unbounded.is_empty(),
        "parameters without min or max: {unbounded:?}"
    );
}

fn initialised_with(real: &[(u32, f64)]) -> (Slave, Fmi2Status) {
    let mut s = Slave::instantiate(fmi2_api_of!(ReferenceVehicle), "rv", GUID).expect("instance");
    for &(reference, value) in real {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
    }
    let status = s.initialize(0.0);
    (s, status)
}

#[test]
fn timing_that_would_loop_or_allocate_is_refused_at_initialisation() {
    let cases = [
        // a per-channel period inside its range [-1, 1] whose step would never end
        (vr::SAMPLE_PERIOD_AY_MEAS, 1e-300, "internal step"),
        // -1 means "the common value"; any other negative value has no meaning
        (vr::SAMPLE_PERIOD_VX_MEAS, -0.5, "sample_period_vx_meas"),
        (vr::LATENCY_AY_MEAS, -0.5, "latency_ay_meas"),
    ];
    for (reference, value, needle) in cases {
        let (s, status) = initialised_with(&[(reference, value)]);
        assert_eq!(status, Fmi2Status::Error, "{needle} = {value}");
        let message = s.log.last().expect("a log line").message;
        assert!(
            message.contains(needle),
            "expected '{needle}' in '{message}'"
        );
    }
    // The longest delay line the bounds allow (1 s at the shortest step) is accepted.
    let (_, status) = initialised_with(&[(vr::INTEGRATION_STEP, 1e-5), (vr::LATENCY_AY_MEAS, 1.0)]);
    assert_eq!(status, Fmi2Status::Ok);
}

#[test]
fn noise_levels_are_tunable_from_the_next_step_and_fixed_parameters_are_not() {
    let (mut s, status) = initialised_with(&[]);
    assert_eq!(status, Fmi2Status::Ok);
    for k in 0..10 {
        assert_eq!(s.do_step(k as f64 * 1e-3, 1e-3), Fmi2Status::Ok);
    }
    let noisy = s.reals(&[vr::AY_MEAS, vr::AY]);
    assert_ne!(noisy[0], noisy[1], "the seed's noise is on");
    assert_eq!(s.set_reals(&NOISE_LEVELS, &[0.0; 11]), Fmi2Status::Ok);
    assert_eq!(
        s.reals(&[vr::AY_MEAS])[0],
        noisy[0],
        "the sample already taken stays"
    );
    assert_eq!(s.do_step(0.01, 1e-3), Fmi2Status::Ok);
    let quiet = s.reals(&[vr::AY_MEAS, vr::AY]);
    assert_eq!(quiet[0], quiet[1], "no noise from the next step on");
    assert_eq!(
        s.set_real(vr::MASS, 1500.0),
        Fmi2Status::Error,
        "mass is fixed"
    );
}
