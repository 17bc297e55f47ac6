//! The switchable reference vehicle drives model A or B with one input and one truth type.

use vehicle_models::driver_input::DriverInputVector;
use vehicle_models::manoeuvre::{SeedManoeuvre, SEED_INITIAL_SPEED};
use vehicle_models::{
    Integrator, ReferenceModelKind, ReferenceVehicle, ReferenceVehicleError,
    ReferenceVehicleParams, SingleTrackHsri, TwoTrackMagicFormula,
};

const SAMPLE_TIME: f64 = 1e-3;
const STEPS: usize = 6000;

#[test]
fn reference_vehicle_reproduces_the_models_it_wraps() {
    for kind in [
        ReferenceModelKind::SingleTrack,
        ReferenceModelKind::TwoTrack,
    ] {
        let params = ReferenceVehicleParams {
            model: kind,
            ..Default::default()
        };
        let mut vehicle = ReferenceVehicle::new(&params, SEED_INITIAL_SPEED);
        let model_a = SingleTrackHsri::default();
        let model_b = TwoTrackMagicFormula::default();
        let mut xa = model_a.straight_rolling_state(SEED_INITIAL_SPEED);
        let mut xb = model_b.straight_rolling_state(SEED_INITIAL_SPEED);
        let manoeuvre = SeedManoeuvre::StepSteer;
        for k in 0..STEPS {
            let u = manoeuvre.input_at(k as f64 * SAMPLE_TIME).to_vector();
            vehicle.step(&u, SAMPLE_TIME).expect("finite input");
            xa = model_a.step(&xa, &u, SAMPLE_TIME, Integrator::SemiImplicitEuler);
            xb = model_b.step(&xb, &u, SAMPLE_TIME, Integrator::SemiImplicitEuler);
        }
        let u = manoeuvre.input_at(STEPS as f64 * SAMPLE_TIME).to_vector();
        let expected = match kind {
            ReferenceModelKind::SingleTrack => {
                assert_eq!(vehicle.state(), xa.as_slice());
                model_a.truth(&xa, &u)
            }
            ReferenceModelKind::TwoTrack => {
                assert_eq!(vehicle.state(), xb.as_slice());
                model_b.truth(&xb, &u)
            }
        };
        assert_eq!(vehicle.truth(&u), expected);
        assert_eq!(vehicle.state_names().len(), vehicle.state().len());
        assert!(expected.yaw_rate > 0.1);
    }
}

#[test]
fn bad_inputs_are_refused_with_a_named_reason_and_leave_the_state() {
    let mut vehicle = ReferenceVehicle::new(&ReferenceVehicleParams::default(), 18.0);
    let before = vehicle.state().to_vec();
    let error = vehicle
        .step(&DriverInputVector::new(f64::NAN, 0.0, 0.0), SAMPLE_TIME)
        .unwrap_err();
    assert!(matches!(
        error,
        ReferenceVehicleError::NonFiniteInput {
            name: "steering_angle",
            ..
        }
    ));
    assert!(error.to_string().contains("steering_angle"));
    let error = vehicle
        .step(&DriverInputVector::new(0.0, 0.0, -10.0), SAMPLE_TIME)
        .unwrap_err();
    assert_eq!(error, ReferenceVehicleError::NegativeBrakeTorque(-10.0));
    let error = vehicle.step(&DriverInputVector::zeros(), 0.0).unwrap_err();
    assert_eq!(error, ReferenceVehicleError::InvalidStepSize(0.0));
    assert_eq!(vehicle.state(), before.as_slice());
}

#[test]
fn state_can_be_set_and_reset() {
    let mut vehicle = ReferenceVehicle::new(
        &ReferenceVehicleParams {
            model: ReferenceModelKind::TwoTrack,
            ..Default::default()
        },
        10.0,
    );
    assert_eq!(vehicle.state().len(), 7);
    vehicle.state_mut()[1] = 0.5;
    assert_eq!(vehicle.state()[1], 0.5);
    vehicle.reset(20.0);
    assert_eq!(vehicle.state()[0], 20.0);
    assert_eq!(vehicle.state()[1], 0.0);
    assert!((vehicle.state()[3] - 20.0 / 0.3).abs() < 1e-12);
}
