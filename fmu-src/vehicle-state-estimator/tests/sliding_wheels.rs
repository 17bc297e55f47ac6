//! The grip model's rule for sliding tyres (`model_grip::sliding_axles`): an axle's grip factor
//! gets the prior's variance `grip_std²` per sample on top of its noise while its wheels slide
//! longitudinally with the torques unknown (estimated slip beyond 10 %; not when the torques are
//! told, the model's combined slip then accounts for it) or its side force passes 80 % of its
//! friction potential; not otherwise.

use estimation::models::single_track::{ANCHORED_INPUT_DIM, AX_VALID_INPUT};
use estimation::models::single_track_grip::{extend_state, GripState, GRIP_FACTORS};
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

/// The extra process noise of the front and rear grip factors.
fn grip_noise(model: &ModelGrip, state: &GripState, input: &InputVector) -> [f64; 2] {
    // With `ax` measured (`ax_valid` 1), as the grip factors' noise does not depend on it.
    let mut filter_input = SVector::<f64, ANCHORED_INPUT_DIM>::zeros();
    filter_input.fixed_rows_mut::<4>(0).copy_from(input);
    filter_input[AX_VALID_INPUT] = 1.0;
    let noise = model
        .extra_process_noise(state, input, &filter_input, &Variables::default())
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
