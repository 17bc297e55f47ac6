//! The grip model's rule for sliding tyres (`model_grip::sliding_axles`): an axle's grip factor
//! gets the prior's variance `grip_std²` per sample on top of its noise while its wheels slide
//! longitudinally with the torques unknown (estimated slip beyond 10 %; not when the torques are
//! told, the model's combined slip then accounts for it) or its side force passes 80 % of its
//! friction potential; not otherwise. And its variance for a side force that changes fast
//! (`model_grip::transient_grip_variance`, `grip_transient_time`), which the sliding rule's
//! tests switch off so as to see the rule alone.

use estimation::models::single_track::{ANCHORED_INPUT_DIM, AX_VALID_INPUT};
use estimation::models::single_track_grip::{extend_state, GripState, GRIP_FACTORS};
use estimation::StateSpaceModel;
use nalgebra::{SMatrix, SVector};
use vehicle_models::driver_input::index as input_index;
use vehicle_models::single_track::state_index;
use VehicleStateEstimator::model_description::Variables;
use VehicleStateEstimator::model_grip::ModelGrip;
use VehicleStateEstimator::runner::{EstimationModel, InputVector};

const SPEED: f64 = 20.0;

fn model() -> ModelGrip {
    ModelGrip::from_parameters(&Variables::default()).expect("the defaults build model 3")
}

/// Straight driving at [`SPEED`] with the wheels' slips `[front, rear]` (000: 5.65).
fn driving(model: &ModelGrip, slips: [f64; 2]) -> GripState {
    let mut body = model.vehicle().straight_rolling_state(SPEED);
    for (index, slip) in [state_index::OMEGA_FRONT, state_index::OMEGA_REAR]
        .into_iter()
        .zip(slips)
    {
        body[index] *= 1.0 + slip;
    }
    extend_state(&body)
}

/// Cornering at [`SPEED`] with a sideslip of `sideslip` (rad) and no yaw rate, the wheels rolling.
fn sliding_sideways(model: &ModelGrip, sideslip: f64) -> GripState {
    let mut body = model.vehicle().straight_rolling_state(SPEED);
    body[state_index::VY] = SPEED * sideslip.tan();
    extend_state(&body)
}

/// The extra process noise of the front and rear grip factors, the sliding rule alone
/// (`grip_transient_time` 0).
fn grip_noise(model: &ModelGrip, state: &GripState, input: &InputVector) -> [f64; 2] {
    let variables = Variables {
        grip_transient_time: 0.0,
        ..Variables::default()
    };
    grip_noise_with(model, state, input, &variables)
}

/// The extra process noise of the front and rear grip factors with the parameters `v`.
fn grip_noise_with(
    model: &ModelGrip,
    state: &GripState,
    input: &InputVector,
    v: &Variables,
) -> [f64; 2] {
    // With `ax` measured (`ax_valid` 1), as the grip factors' noise does not depend on it.
    let mut filter_input = SVector::<f64, ANCHORED_INPUT_DIM>::zeros();
    filter_input.fixed_rows_mut::<4>(0).copy_from(input);
    filter_input[AX_VALID_INPUT] = 1.0;
    let noise = model
        .extra_process_noise(state, input, &filter_input, [true, true], v)
        .unwrap_or_else(SMatrix::zeros);
    GRIP_FACTORS.map(|i| noise[(i, i)])
}

#[test]
fn a_sliding_axle_relearns_its_grip_while_the_torques_are_unknown() {
    let model = model();
    let variance = Variables::default().grip_std.powi(2);
    let unknown = InputVector::zeros();
    // Rolling; a braked front and a driven rear wheel below 10 %; a locked inner rear wheel
    // halving its axle's mean wheel speed; a spinning driven front wheel at 12 %.
    let cases = [
        ([0.0, 0.0], [0.0, 0.0]),
        ([-0.05, 0.08], [0.0, 0.0]),
        ([0.0, -0.5], [0.0, variance]),
        ([0.12, 0.0], [variance, 0.0]),
    ];
    for (slips, expected) in cases {
        let noise = grip_noise(&model, &driving(&model, slips), &unknown);
        assert_eq!(noise, expected, "slips {slips:?}");
    }
    // Told the brake torque, the model's combined slip accounts for the sliding wheel.
    let mut braking = InputVector::zeros();
    braking[input_index::BRAKE_TORQUE] = 1500.0;
    let locked = driving(&model, [0.0, -0.5]);
    assert_eq!(grip_noise(&model, &locked, &braking), [0.0, 0.0]);
}

#[test]
fn a_saturated_axle_relearns_its_grip_whatever_the_torques() {
    let model = model();
    let variance = Variables::default().grip_std.powi(2);
    let mut told = InputVector::zeros();
    told[input_index::DRIVE_TORQUE] = 100.0;
    for input in [InputVector::zeros(), told] {
        // 1°: both axles in the linear range; 15°: both on the flat top of the curve.
        let linear = grip_noise(
            &model,
            &sliding_sideways(&model, 1_f64.to_radians()),
            &input,
        );
        assert_eq!(linear, [0.0, 0.0]);
        let saturated = grip_noise(
            &model,
            &sliding_sideways(&model, 15_f64.to_radians()),
            &input,
        );
        assert_eq!(saturated, [variance, variance]);
    }
}

/// The grip factors' transient variance: none driving straight, where no side force changes;
/// where one does (a sideslip of 1° without the yaw rate to hold it, 0.2 s on, when the tyres
/// have built their force over 4 m of rolling and it turns the car), proportional to
/// `grip_transient_time` and below the sliding rule's whole `grip_std²` (a sample's share of
/// the prior); none below 5 m/s.
#[test]
fn a_fast_changing_side_force_loosens_the_grip_in_proportion_to_the_transient_time() {
    let model = model();
    let with_time = |time: f64| Variables {
        grip_transient_time: time,
        ..Variables::default()
    };
    let unknown = InputVector::zeros();
    let straight = driving(&model, [0.0, 0.0]);
    assert_eq!(
        grip_noise_with(&model, &straight, &unknown, &with_time(0.5)),
        [0.0, 0.0]
    );
    let mut filter_input = SVector::<f64, ANCHORED_INPUT_DIM>::zeros();
    filter_input[AX_VALID_INPUT] = 1.0;
    let swerving = (0..200).fold(sliding_sideways(&model, 1_f64.to_radians()), |state, _| {
        StateSpaceModel::transition(&model, &state, &filter_input)
    });
    let off = grip_noise_with(&model, &swerving, &unknown, &with_time(0.0));
    let half = grip_noise_with(&model, &swerving, &unknown, &with_time(0.5));
    let one = grip_noise_with(&model, &swerving, &unknown, &with_time(1.0));
    let prior = Variables::default().grip_std.powi(2);
    assert_eq!(off, [0.0, 0.0]);
    for axle in 0..2 {
        assert!(half[axle] > 0.0 && half[axle] < prior, "{half:?}");
        assert!(
            (one[axle] / half[axle] - 2.0).abs() < 1e-12,
            "{one:?} {half:?}"
        );
    }
    // Off below 5 m/s (`model_grip::TRANSIENT_MIN_SPEED`): the same state at a fifth of the
    // speed, 4 m/s.
    let mut slow = swerving;
    for index in [
        state_index::VX,
        state_index::VY,
        state_index::YAW_RATE,
        state_index::OMEGA_FRONT,
        state_index::OMEGA_REAR,
    ] {
        slow[index] *= 0.2;
    }
    assert_eq!(
        grip_noise_with(&model, &slow, &unknown, &with_time(1.0)),
        [0.0, 0.0]
    );
    // Refused: a negative or non-finite time.
    for bad in [-0.1, f64::NAN, f64::INFINITY] {
        let error = ModelGrip::from_parameters(&with_time(bad)).unwrap_err();
        assert!(error.contains("grip_transient_time"), "{error}");
    }
}
