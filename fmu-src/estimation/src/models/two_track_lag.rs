//! Model B with tyres that lag by their relaxation length, as a [`StateSpaceModel<5, 2, 3>`]:
//! the 3-state form of seed 001 ([`TwoTrackEstimationModel`]) and per axle the tyres' transient
//! slip angle.
//!
//! - state `x = [sideslip, yaw_rate, ay, transient_slip_front, transient_slip_rear]`: model B's
//!   three states and `tan α'` of the front and rear tyres, at which the Magic Formula is
//!   evaluated instead of the kinematic slip angles of 001: eqs 4-5;
//! - measurement `y = [ay, yaw_rate]` and input `u = [steering_angle, vx, ax]` as model B's.
//!
//! The lag is the grip model's (`single_track_grip`, "Tyre lag"; Pacejka, Tyre and Vehicle
//! Dynamics, 3rd ed., §7.2.1, `σ dα'/dt + |Vcx| α' = |Vcx| α`), per sample
//! `α'(k+1) = α'(k) + min(T |vx| / σ, 1) (α(k) − α'(k))` with `α(k)` the kinematic slip angle at
//! `x(k)`; `β` and `r` advance with the forces at `α'(k)`, and `ay(k+1)` is the force sum at
//! `α'(k+1)`, so the `ay` state keeps meaning the lateral acceleration the tyres carry
//! ([`TwoTrackLateralModel::step_with_transient_slip`]). Model B has no lag state of its own
//! because seed 001 fixes its state vector; this is a model of its own (FMU `model = 4`).

use nalgebra::{SMatrix, SVector};
use vehicle_models::two_track_lateral::{
    input_index, state_index, TransientSlip, INPUT_DIM, MEASUREMENT_DIM, STATE_DIM,
};
use vehicle_models::{MagicFormulaTyre, Scalar, TwoTrackLateralModel, TyreModel};

use super::dual_passes::{input_pass, state_pass};
use super::two_track::TwoTrackEstimationModel;
use crate::kalman::{InitialEstimate, SettingsError};
use crate::StateSpaceModel;

/// Number of states of the lagged model B.
pub const LAG_STATE_DIM: usize = STATE_DIM + 2;

/// Index of the front tyres' transient slip angle `tan α'`.
pub const TRANSIENT_SLIP_FRONT: usize = STATE_DIM;

/// Index of the rear tyres' transient slip angle `tan α'`.
pub const TRANSIENT_SLIP_REAR: usize = STATE_DIM + 1;

/// Standard deviation of each transient slip angle at the start, rad (as the grip model's).
pub const TRANSIENT_SLIP_START_STD: f64 = 0.02;

/// Process noise of each transient slip angle, rad²/s (as the grip model's: 0.2 mrad per 10 ms).
const TRANSIENT_SLIP_NOISE_DENSITY: f64 = 4e-6;

/// The lagged model's state.
pub type LagState = SVector<f64, LAG_STATE_DIM>;

/// Model B with lagging tyres (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct TwoTrackLagModel<T: TyreModel = MagicFormulaTyre> {
    model: TwoTrackEstimationModel<T>,
    /// The tyres' relaxation length `σ`, m; 0: no lag.
    relaxation_length: f64,
}

impl<T: TyreModel> TwoTrackLagModel<T> {
    /// `model` with tyres that relax over `relaxation_length` m, finite and at least 0.
    pub fn new(
        model: TwoTrackEstimationModel<T>,
        relaxation_length: f64,
    ) -> Result<Self, SettingsError> {
        if relaxation_length.is_finite() && relaxation_length >= 0.0 {
            Ok(Self {
                model,
                relaxation_length,
            })
        } else {
            Err(SettingsError(format!(
                "the tyres' relaxation length must be at least 0 m, got {relaxation_length}"
            )))
        }
    }

    /// Model B without the lag states.
    pub fn two_track(&self) -> &TwoTrackEstimationModel<T> {
        &self.model
    }

    /// The vehicle model.
    pub fn vehicle(&self) -> &TwoTrackLateralModel<T> {
        self.model.vehicle()
    }

    /// The tyres' relaxation length, m.
    pub fn relaxation_length(&self) -> f64 {
        self.relaxation_length
    }

    /// Model B's Gaussian extended by the transient slip angles: the kinematic ones of its state
    /// at `input` (straight running: 0), std [`TRANSIENT_SLIP_START_STD`], uncorrelated.
    pub fn extend_initial(
        &self,
        start: &InitialEstimate<STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> InitialEstimate<LAG_STATE_DIM> {
        let mut covariance = SMatrix::<f64, LAG_STATE_DIM, LAG_STATE_DIM>::zeros();
        covariance
            .fixed_view_mut::<STATE_DIM, STATE_DIM>(0, 0)
            .copy_from(&start.covariance);
        for i in [TRANSIENT_SLIP_FRONT, TRANSIENT_SLIP_REAR] {
            covariance[(i, i)] = TRANSIENT_SLIP_START_STD * TRANSIENT_SLIP_START_STD;
        }
        InitialEstimate {
            state: self.extend_state(&start.state, input),
            covariance,
        }
    }

    /// Model B's state with the kinematic slip angles at `input` as the transient ones.
    pub fn extend_state(
        &self,
        state: &SVector<f64, STATE_DIM>,
        input: &SVector<f64, INPUT_DIM>,
    ) -> LagState {
        let kinematic = self.kinematic_slip(&state.data.0[0], &input.data.0[0]);
        LagState::from_fn(|i, _| match i {
            _ if i < STATE_DIM => state[i],
            TRANSIENT_SLIP_FRONT => kinematic[0],
            _ => kinematic[1],
        })
    }

    /// `[tan αF, tan αR]` at `(x, u)` (001: eqs 4-5).
    fn kinematic_slip<S: Scalar>(&self, x: &[S], u: &[S; INPUT_DIM]) -> [S; 2] {
        let (front, rear) = self.vehicle().tan_slip_angles(
            x[state_index::SIDESLIP],
            x[state_index::YAW_RATE],
            u[input_index::STEERING_ANGLE],
            u[input_index::LONGITUDINAL_VELOCITY],
        );
        [front, rear]
    }

    /// The transition, generic over the scalar (module docs).
    fn step<S: Scalar>(&self, x: &[S; LAG_STATE_DIM], u: &[S; INPUT_DIM]) -> [S; LAG_STATE_DIM] {
        let body: [S; STATE_DIM] = core::array::from_fn(|i| x[i]);
        let current = [x[TRANSIENT_SLIP_FRONT], x[TRANSIENT_SLIP_REAR]];
        let kinematic = self.kinematic_slip(x, u);
        let lagging = self.relaxation_length > 0.0;
        let next: [S; 2] = core::array::from_fn(|axle| {
            // (Pacejka §7.2.1) over one sample: α'(k+1) = α'(k) + min(T |vx| / σ, 1) (α − α'(k))
            let share = if lagging {
                u[input_index::LONGITUDINAL_VELOCITY].abs()
                    * (self.model.sample_time() / self.relaxation_length)
            } else {
                S::constant(1.0)
            };
            if share.value() < 1.0 {
                current[axle] + (kinematic[axle] - current[axle]) * share
            } else {
                kinematic[axle]
            }
        });
        let body = self.vehicle().step_with_transient_slip(
            &body,
            u,
            lagging.then_some(TransientSlip { current, next }),
            self.model.sample_time(),
            self.model.integrator(),
        );
        [body[0], body[1], body[2], next[0], next[1]]
    }

    /// The measurement `[ay, r]`: states (001: eq 9).
    fn observe<S: Scalar>(&self, x: &[S; LAG_STATE_DIM], _: &[S; INPUT_DIM]) -> [S; 2] {
        [
            x[state_index::LATERAL_ACCELERATION],
            x[state_index::YAW_RATE],
        ]
    }
}

impl<T: TyreModel> StateSpaceModel<LAG_STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>
    for TwoTrackLagModel<T>
{
    fn state_names(&self) -> [&'static str; LAG_STATE_DIM] {
        let [sideslip, yaw_rate, ay] = self.model.state_names();
        [
            sideslip,
            yaw_rate,
            ay,
            "transient_slip_front",
            "transient_slip_rear",
        ]
    }

    fn measurement_names(&self) -> [&'static str; MEASUREMENT_DIM] {
        self.model.measurement_names()
    }

    fn transition(&self, state: &LagState, input: &SVector<f64, INPUT_DIM>) -> LagState {
        SVector::from(self.step(&state.data.0[0], &input.data.0[0]))
    }

    fn transition_jacobian(
        &self,
        state: &LagState,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, LAG_STATE_DIM, LAG_STATE_DIM> {
        self.transition_and_jacobian(state, input).1
    }

    fn transition_and_jacobian(
        &self,
        state: &LagState,
        input: &SVector<f64, INPUT_DIM>,
    ) -> (LagState, SMatrix<f64, LAG_STATE_DIM, LAG_STATE_DIM>) {
        state_pass(state, input, |x, u| self.step(x, u))
    }

    fn transition_input_jacobian(
        &self,
        state: &LagState,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, LAG_STATE_DIM, INPUT_DIM> {
        input_pass(state, input, None, |x, u| self.step(x, u))
    }

    fn measurement(
        &self,
        state: &LagState,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SVector<f64, MEASUREMENT_DIM> {
        SVector::from(self.observe(&state.data.0[0], &input.data.0[0]))
    }

    fn measurement_jacobian(
        &self,
        state: &LagState,
        input: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, MEASUREMENT_DIM, LAG_STATE_DIM> {
        state_pass(state, input, |x, u| self.observe(x, u)).1
    }

    fn measurement_input_jacobian(
        &self,
        _: &LagState,
        _: &SVector<f64, INPUT_DIM>,
    ) -> SMatrix<f64, MEASUREMENT_DIM, INPUT_DIM> {
        SMatrix::zeros()
    }

    /// Model B's `Q` and per transient slip angle the density · `T`; uncorrelated.
    fn process_noise(&self) -> SMatrix<f64, LAG_STATE_DIM, LAG_STATE_DIM> {
        let mut noise = SMatrix::<f64, LAG_STATE_DIM, LAG_STATE_DIM>::zeros();
        noise
            .fixed_view_mut::<STATE_DIM, STATE_DIM>(0, 0)
            .copy_from(&self.model.process_noise());
        let variance = TRANSIENT_SLIP_NOISE_DENSITY * self.model.sample_time();
        for i in [TRANSIENT_SLIP_FRONT, TRANSIENT_SLIP_REAR] {
            noise[(i, i)] = variance;
        }
        noise
    }

    fn measurement_noise(&self) -> SMatrix<f64, MEASUREMENT_DIM, MEASUREMENT_DIM> {
        self.model.measurement_noise()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_oracle::central_difference;

    fn lagged(relaxation_length: f64) -> TwoTrackLagModel {
        TwoTrackLagModel::new(
            TwoTrackEstimationModel::seed_001(0.01).unwrap(),
            relaxation_length,
        )
        .unwrap()
    }

    #[test]
    fn jacobians_match_finite_differences_in_a_hard_turn() {
        let x = LagState::from([-0.02, 0.35, 6.0, 0.03, 0.04]);
        let u = SVector::<f64, INPUT_DIM>::from([0.05, 18.0, -1.0]);
        for model in [lagged(0.0), lagged(0.5)] {
            let numeric = central_difference(|x| model.transition(x, &u), &x);
            let analytic = model.transition_jacobian(&x, &u);
            assert!((analytic - numeric).amax() < 1e-5 * numeric.amax());
            let numeric = central_difference(|u| model.transition(&x, u), &u);
            let analytic = model.transition_input_jacobian(&x, &u);
            assert!((analytic - numeric).amax() < 1e-5 * numeric.amax());
        }
    }

    /// Settled (transient = kinematic slip angles), sideslip and yaw rate advance as model B's
    /// (its `ay(k+1)` is at the new kinematic slip angles, the lagged one at the transient
    /// ones); from straight running a sample closes `T vx / σ` of the gap and the tyres carry
    /// less force than model B's; without lag the states only track the kinematic ones.
    #[test]
    fn the_lag_follows_the_kinematic_slip_angles() {
        let plain = TwoTrackEstimationModel::seed_001(0.01).unwrap();
        let x3 = SVector::<f64, STATE_DIM>::from([-0.01, 0.25, 4.0]);
        let u = SVector::<f64, INPUT_DIM>::from([0.04, 18.0, 0.0]);
        let model = lagged(0.5);
        let settled = model.extend_state(&x3, &u);
        let next = model.transition(&settled, &u);
        let body = plain.transition(&x3, &u);
        assert_eq!(next.fixed_rows::<2>(0), body.fixed_rows::<2>(0));
        let mut straight = settled;
        straight[TRANSIENT_SLIP_FRONT] = 0.0;
        straight[TRANSIENT_SLIP_REAR] = 0.0;
        let next = model.transition(&straight, &u);
        let share = 0.01 * 18.0 / 0.5;
        assert!((next[TRANSIENT_SLIP_REAR] - share * settled[TRANSIENT_SLIP_REAR]).abs() < 1e-15);
        assert!(next[state_index::LATERAL_ACCELERATION] < body[state_index::LATERAL_ACCELERATION]);
        let unlagged = lagged(0.0);
        let next = unlagged.transition(&straight, &u);
        assert_eq!(next.fixed_rows::<STATE_DIM>(0), body);
        assert_eq!(next[TRANSIENT_SLIP_REAR], settled[TRANSIENT_SLIP_REAR]);
        assert!(TwoTrackLagModel::new(plain.clone(), -1.0).is_err());
    }
}
