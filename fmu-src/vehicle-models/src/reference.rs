//! A reference vehicle that is either model A or model B, driven by the same input
//! `[steering_angle, drive_torque, brake_torque]` and reporting the same [`VehicleTruth`], so the
//! ReferenceVehicle FMU can switch between them with one parameter.

use serde::{Deserialize, Serialize};

use crate::driver_input::{index as input_index, DriverInputVector};
use crate::integrator::Integrator;
use crate::single_track::{self, SingleTrackHsri, SingleTrackParams, SingleTrackState};
use crate::truth::VehicleTruth;
use crate::two_track::{self, TwoTrackMagicFormula, TwoTrackParams, TwoTrackState};
use crate::tyre::{HsriParams, HsriTyre, MagicFormulaParams, MagicFormulaTyre};

/// Which vehicle model drives the reference vehicle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ReferenceModelKind {
    /// Model A: single-track, HSRI tyres (seed 000) — the estimators' own model.
    #[default]
    SingleTrack,
    /// Model B: two-track, load transfer, Magic Formula tyres (seed 001) — model mismatch.
    TwoTrack,
}

/// Everything that defines a reference vehicle; `Default` is model A with the seed-000 data.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceVehicleParams {
    pub model: ReferenceModelKind,
    pub integrator: Integrator,
    pub single_track: SingleTrackParams,
    pub hsri: HsriParams,
    pub two_track: TwoTrackParams,
    pub magic_formula: MagicFormulaParams,
}

/// Why a reference-vehicle step was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ReferenceVehicleError {
    #[error("input `{name}` must be a finite number, got {value}")]
    NonFiniteInput { name: &'static str, value: f64 },
    #[error("brake_torque must be a magnitude >= 0 N·m (the seed's M_B = -brake_torque), got {0}")]
    NegativeBrakeTorque(f64),
    #[error("step size must be finite and > 0 s, got {0}")]
    InvalidStepSize(f64),
    #[error("state `{name}` became non-finite; the step was not applied")]
    NonFiniteState { name: &'static str },
}

/// Largest state dimension of the models (model B).
pub const MAX_STATE_DIM: usize = two_track::STATE_DIM;

const SINGLE_TRACK_STATE_NAMES: [&str; single_track::STATE_DIM] =
    ["vx", "vy", "yaw_rate", "omega_front", "omega_rear"];
const TWO_TRACK_STATE_NAMES: [&str; two_track::STATE_DIM] = [
    "vx",
    "vy",
    "yaw_rate",
    "omega_front_left",
    "omega_front_right",
    "omega_rear_left",
    "omega_rear_right",
];
const INPUT_NAMES: [&str; 3] = ["steering_angle", "drive_torque", "brake_torque"];

/// Model A or B with its state; no heap allocation in [`ReferenceVehicle::step`].
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceVehicle {
    kind: ReferenceModelKind,
    integrator: Integrator,
    single_track: SingleTrackHsri,
    two_track: TwoTrackMagicFormula,
    /// The first 5 (model A) or 7 (model B) entries are the state.
    state: [f64; MAX_STATE_DIM],
}

impl ReferenceVehicle {
    /// A reference vehicle driving straight at `initial_speed` (m/s) with freely rolling wheels.
    pub fn new(params: &ReferenceVehicleParams, initial_speed: f64) -> Self {
        let mut vehicle = Self {
            kind: params.model,
            integrator: params.integrator,
            single_track: SingleTrackHsri::new(
                params.single_track.clone(),
                HsriTyre::new(params.hsri.clone()),
            ),
            two_track: TwoTrackMagicFormula::new(
                params.two_track.clone(),
                MagicFormulaTyre::new(params.magic_formula.clone()),
            ),
            state: [0.0; MAX_STATE_DIM],
        };
        vehicle.reset(initial_speed);
        vehicle
    }

    /// Which model runs.
    pub fn kind(&self) -> ReferenceModelKind {
        self.kind
    }

    /// Back to straight driving at `speed` with freely rolling wheels.
    pub fn reset(&mut self, speed: f64) {
        self.state = [0.0; MAX_STATE_DIM];
        match self.kind {
            ReferenceModelKind::SingleTrack => {
                let x = self.single_track.straight_rolling_state(speed);
                self.state[..single_track::STATE_DIM].copy_from_slice(x.as_slice());
            }
            ReferenceModelKind::TwoTrack => {
                let x = self.two_track.straight_rolling_state(speed);
                self.state.copy_from_slice(x.as_slice());
            }
        }
    }

    /// Number of states of the running model (5 for A, 7 for B).
    pub fn state_dim(&self) -> usize {
        match self.kind {
            ReferenceModelKind::SingleTrack => single_track::STATE_DIM,
            ReferenceModelKind::TwoTrack => two_track::STATE_DIM,
        }
    }

    /// The state of the running model (model A: `[vx, vy, r, ωF, ωR]`; model B:
    /// `[vx, vy, r, ωFL, ωFR, ωRL, ωRR]`).
    pub fn state(&self) -> &[f64] {
        &self.state[..self.state_dim()]
    }

    /// Mutable state, e.g. to add process noise or restore a saved FMU state.
    pub fn state_mut(&mut self) -> &mut [f64] {
        let dim = self.state_dim();
        &mut self.state[..dim]
    }

    /// Names of the states, in order.
    pub fn state_names(&self) -> &'static [&'static str] {
        match self.kind {
            ReferenceModelKind::SingleTrack => &SINGLE_TRACK_STATE_NAMES,
            ReferenceModelKind::TwoTrack => &TWO_TRACK_STATE_NAMES,
        }
    }

    /// Model A as configured (also when model B runs).
    pub fn single_track_model(&self) -> &SingleTrackHsri {
        &self.single_track
    }

    /// Model B as configured (also when model A runs).
    pub fn two_track_model(&self) -> &TwoTrackMagicFormula {
        &self.two_track
    }

    fn check_input(input: &DriverInputVector) -> Result<(), ReferenceVehicleError> {
        for (value, name) in input.iter().zip(INPUT_NAMES) {
            if !value.is_finite() {
                return Err(ReferenceVehicleError::NonFiniteInput {
                    name,
                    value: *value,
                });
            }
        }
        let brake = input[input_index::BRAKE_TORQUE];
        if brake < 0.0 {
            return Err(ReferenceVehicleError::NegativeBrakeTorque(brake));
        }
        Ok(())
    }

    /// Advances by one step of `dt` seconds with the input held. On error the state is left
    /// unchanged.
    pub fn step(
        &mut self,
        input: &DriverInputVector,
        dt: f64,
    ) -> Result<(), ReferenceVehicleError> {
        Self::check_input(input)?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(ReferenceVehicleError::InvalidStepSize(dt));
        }
        let mut next = [0.0; MAX_STATE_DIM];
        match self.kind {
            ReferenceModelKind::SingleTrack => {
                let x = SingleTrackState::from_column_slice(self.state());
                let x = self.single_track.step(&x, input, dt, self.integrator);
                next[..single_track::STATE_DIM].copy_from_slice(x.as_slice());
            }
            ReferenceModelKind::TwoTrack => {
                let x = TwoTrackState::from_column_slice(self.state());
                let x = self.two_track.step(&x, input, dt, self.integrator);
                next.copy_from_slice(x.as_slice());
            }
        }
        let dim = self.state_dim();
        if let Some(index) = next[..dim].iter().position(|v| !v.is_finite()) {
            return Err(ReferenceVehicleError::NonFiniteState {
                name: self.state_names()[index],
            });
        }
        self.state = next;
        Ok(())
    }

    /// Truth quantities at the current state for the given input (accelerations depend on it).
    pub fn truth(&self, input: &DriverInputVector) -> VehicleTruth {
        match self.kind {
            ReferenceModelKind::SingleTrack => self
                .single_track
                .truth(&SingleTrackState::from_column_slice(self.state()), input),
            ReferenceModelKind::TwoTrack => self
                .two_track
                .truth(&TwoTrackState::from_column_slice(self.state()), input),
        }
    }
}
