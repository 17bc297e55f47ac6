//! Tyre models behind one interface: HSRI (seed 000), Magic Formula (seed 001) and linear.
//!
//! A tyre model maps the kinematics of one wheel (longitudinal slip, tangent of the slip angle,
//! longitudinal speed of the wheel centre, vertical load) to the longitudinal and lateral force of
//! that **one wheel** in the wheel frame. The single-track model A doubles them to axle forces
//! (000: text before table 5.2).
//!
//! Sign conventions (ISO 8855, as 000: 5.17, 5.22, 5.65):
//! - `slip = (ω r − v_x,wheel) / v_x,wheel`: positive when driving, negative when braking;
//! - `tan α = −v_y,wheel / v_x,wheel`: a positive slip angle produces a positive (leftward)
//!   lateral force;
//! - the longitudinal force is positive forward.

use serde::{Deserialize, Serialize};

use crate::scalar::{Dual, Scalar};

pub mod combined_slip;
mod hsri;
mod linear;
mod magic_formula;

pub use hsri::{HsriParams, HsriTyre};
pub use linear::{LinearTyre, LinearTyreParams};
pub use magic_formula::{MagicFormulaParams, MagicFormulaTyre};

/// Kinematic quantities of one wheel, the inputs of a tyre model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TyreKinematics<S: Scalar> {
    /// Longitudinal slip `s` (000: 5.65), dimensionless.
    pub slip: S,
    /// `tan α`, tangent of the slip angle (000: 5.17, 5.22).
    pub tan_slip_angle: S,
    /// Longitudinal velocity of the wheel centre in the wheel frame, m/s (for the sliding speed,
    /// 000: 5.66).
    pub wheel_velocity: S,
    /// Vertical load on this wheel, N.
    pub vertical_load: S,
}

/// Force of one tyre on the road plane, in the wheel frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TyreForce<S: Scalar> {
    /// Longitudinal (circumferential) force `U`, N, positive forward.
    pub longitudinal: S,
    /// Lateral force `S`, N, positive to the left.
    pub lateral: S,
}

impl<S: Scalar> TyreForce<S> {
    /// No force (wheel off the ground).
    #[inline(always)]
    pub fn zero() -> Self {
        Self {
            longitudinal: S::constant(0.0),
            lateral: S::constant(0.0),
        }
    }
}

/// Per-axle factors on a tyre law, so one tyre description serves a car whose front and rear
/// tyres differ: the user scaling factors of Pacejka's Magic Formula (Pacejka, *Tyre and Vehicle
/// Dynamics*, 3rd ed. 2012, §4.3.2: `λKyα` on the cornering stiffness, `λμy` on the friction
/// coefficient, `λFz0` on the nominal load), applied alike to the HSRI tyre (000: 5.67-5.73)
/// and to model B's Magic Formula tyre. Every factor 1 ([`Self::NONE`]) is the unscaled tyre,
/// bit-identically (`x · 1 = x` and `x / (y · 1) = x / y` in IEEE 754 arithmetic).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AxleTyreScaling {
    /// `λKyα`: factor on the cornering stiffness `Cα` (000: 5.70) wherever it enters the force
    /// law (for HSRI also the resultant slip, 000: 5.73).
    pub cornering_stiffness: f64,
    /// `λμy`: factor on the friction coefficient, its peak `f0` (000: 5.67) and, for HSRI, its
    /// decay `kR` with the sliding speed (000: 5.68-5.69), so `µ` at every sliding speed scales.
    pub friction: f64,
    /// `λFz0`: factor on the reference load `FZref` of the load influences `Fz/FZref`
    /// (000: 5.67-5.71): a factor above 1 weakens the load sensitivity of friction and
    /// stiffnesses (the tyre of a heavier rated load), below 1 strengthens it.
    pub reference_load: f64,
}

impl AxleTyreScaling {
    /// The unscaled tyre.
    pub const NONE: Self = Self {
        cornering_stiffness: 1.0,
        friction: 1.0,
        reference_load: 1.0,
    };
}

impl Default for AxleTyreScaling {
    fn default() -> Self {
        Self::NONE
    }
}

/// One interface for every tyre model, so the vehicle models are generic over it.
///
/// `force` is generic over [`Scalar`], which is what makes the vehicle Jacobians exact: the same
/// code runs on dual numbers.
pub trait TyreModel: Clone + std::fmt::Debug + Send + Sync {
    /// Force of one tyre for the given kinematics.
    #[inline(always)]
    fn force<S: Scalar>(&self, kinematics: &TyreKinematics<S>) -> TyreForce<S> {
        self.force_scaled(kinematics, &AxleTyreScaling::NONE)
    }

    /// The force of this tyre on an axle with the given [`AxleTyreScaling`]; with
    /// [`AxleTyreScaling::NONE`] bit-identical to [`Self::force`]. A tyre model without a
    /// friction limit (the linear tyre) applies the cornering-stiffness and load factors only.
    fn force_scaled<S: Scalar>(
        &self,
        kinematics: &TyreKinematics<S>,
        scaling: &AxleTyreScaling,
    ) -> TyreForce<S>;

    /// [`Self::force`] of a tyre whose cornering stiffness `Cα` (000: 5.70) is multiplied by
    /// `cornering_stiffness_scale`, wherever `Cα` enters the force law (for HSRI also the
    /// resultant slip, 000: 5.73). A scale of exactly 1 gives bit-identical forces (`x · 1 = x`
    /// in IEEE 754 arithmetic, for dual numbers component by component). Model A uses one scale
    /// per axle, e.g. identified from data of another vehicle (model mismatch).
    #[inline(always)]
    fn force_with_cornering_scale<S: Scalar>(
        &self,
        kinematics: &TyreKinematics<S>,
        cornering_stiffness_scale: f64,
    ) -> TyreForce<S> {
        self.force_scaled(
            kinematics,
            &AxleTyreScaling {
                cornering_stiffness: cornering_stiffness_scale,
                ..AxleTyreScaling::NONE
            },
        )
    }

    /// [`Self::force_scaled`] together with `∂F_x/∂s`, the longitudinal force's
    /// derivative with respect to the slip, which the semi-implicit wheel-speed step needs
    /// (000: 6.1, 6.2). The default differentiates the force law in one dual direction seeded
    /// in the slip (the force is the dual's value part, bit-identical to the plain call); a tyre
    /// may give the derivative in closed form instead, which must agree with the dual one.
    #[inline(always)]
    fn force_and_slip_derivative<S: Scalar>(
        &self,
        kinematics: &TyreKinematics<S>,
        scaling: &AxleTyreScaling,
    ) -> (TyreForce<S>, S) {
        let seeded = TyreKinematics {
            slip: Dual::<S, 1>::variable(kinematics.slip, 0),
            tan_slip_angle: Dual::from_value(kinematics.tan_slip_angle),
            wheel_velocity: Dual::from_value(kinematics.wheel_velocity),
            vertical_load: Dual::from_value(kinematics.vertical_load),
        };
        let force = self.force_scaled(&seeded, scaling);
        (
            TyreForce {
                longitudinal: force.longitudinal.value,
                lateral: force.lateral.value,
            },
            force.longitudinal.gradient[0],
        )
    }

    /// Cornering stiffness `∂F_y/∂tan α` at zero slip, N/rad, at the given vertical load.
    fn cornering_stiffness(&self, vertical_load: f64) -> f64;

    /// Longitudinal slip stiffness `∂F_x/∂s` at zero slip, N, at the given vertical load.
    fn longitudinal_stiffness(&self, vertical_load: f64) -> f64;
}
