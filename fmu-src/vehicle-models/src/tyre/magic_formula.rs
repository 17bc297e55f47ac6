//! Pacejka Magic Formula tyre (001: eq 3) with degressive load dependence, parametrised for the
//! same tyre as the HSRI model of seed 000.

use serde::{Deserialize, Serialize};

use super::{AxleTyreScaling, HsriParams, TyreForce, TyreKinematics, TyreModel};
use crate::scalar::Scalar;

/// Magic Formula coefficients as functions of the wheel load.
///
/// Seed 001 gives no numbers, so the tyre is matched to the seed-000 HSRI tyre (SPEC §4):
/// - peak force `D(Fz) = f0(Fz) · Fz` with `f0 = f00 − f01 Fz/FZref` (000: 5.67): the peak
///   friction equals model A's `f0` at every load, and `D` grows **degressively** with `Fz`
///   (001: "degressive Abhängigkeit der Seitenkraft von der Aufstandskraft");
/// - stiffness `B·C·D = Cα(Fz) = (Cα1 + Cα2 Fz/FZref) Fz` (000: 5.70) laterally and
///   `B·C·D = Cs(Fz)` (000: 5.71) longitudinally, so at the nominal loads of model A
///   (3492 N front, 3374 N rear) the cornering stiffness equals model A's 6.61e4 / 6.46e4 N/rad;
///   since `Cα2 < 0` the stiffness is degressive in the load as well (`B` falls with load);
/// - shape factors `C_y = 1.3` (lateral) and `C_x = 1.65` (longitudinal), the classic values of
///   the 1987 Magic Formula the seed cites (001: ref. 7); curvature `E_y = −1` puts the lateral peak
///   near 8.5° slip angle at nominal load, `E_x = 0` the longitudinal peak near 9 % slip. These
///   three are the project's choice, not seed values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MagicFormulaParams {
    /// Reference wheel load, N.
    pub reference_load: f64,
    /// Peak friction, base value (`f00`).
    pub friction_base: f64,
    /// Peak friction, wheel-load influence (`f01`).
    pub friction_load: f64,
    /// Cornering coefficient, base value, 1/rad (`Cα1`).
    pub cornering_base: f64,
    /// Cornering coefficient, wheel-load influence, 1/rad (`Cα2`).
    pub cornering_load: f64,
    /// Longitudinal coefficient, base value (`Cs1`).
    pub longitudinal_base: f64,
    /// Longitudinal coefficient, wheel-load influence (`Cs2`).
    pub longitudinal_load: f64,
    /// Lateral shape factor `C_y`.
    pub lateral_shape: f64,
    /// Lateral curvature factor `E_y` (must be ≤ 1).
    pub lateral_curvature: f64,
    /// Longitudinal shape factor `C_x`.
    pub longitudinal_shape: f64,
    /// Longitudinal curvature factor `E_x` (must be ≤ 1).
    pub longitudinal_curvature: f64,
    /// Smallest `1 + s` used to form the theoretical slips `s/(1+s)`, `tan α/(1+s)`; a locked
    /// wheel (`1 + s → 0`) is thereby treated as fully sliding instead of dividing by zero.
    pub min_rolling_ratio: f64,
}

impl MagicFormulaParams {
    /// Magic Formula tyre with the same stiffnesses and peak friction as the given HSRI tyre.
    pub fn matching_hsri(hsri: &HsriParams) -> Self {
        Self {
            reference_load: hsri.reference_load,
            friction_base: hsri.friction_base,
            friction_load: hsri.friction_load,
            cornering_base: hsri.cornering_base,
            cornering_load: hsri.cornering_load,
            longitudinal_base: hsri.longitudinal_base,
            longitudinal_load: hsri.longitudinal_load,
            lateral_shape: 1.3,
            lateral_curvature: -1.0,
            longitudinal_shape: 1.65,
            longitudinal_curvature: 0.0,
            min_rolling_ratio: 0.01,
        }
    }

    /// Peak force `D = f0(Fz) Fz`, N.
    pub fn peak_force(&self, vertical_load: f64) -> f64 {
        (self.friction_base - self.friction_load * vertical_load / self.reference_load)
            * vertical_load
    }
}

impl Default for MagicFormulaParams {
    /// Matched to the seed-000 HSRI tyre (table 5.2).
    fn default() -> Self {
        Self::matching_hsri(&HsriParams::default())
    }
}

/// Magic Formula tyre; pure-slip curves `F = D sin(C atan(Bσ − E(Bσ − atan Bσ)))` (001: eq 3,
/// the seed's `|…|` is a typesetting artefact), combined by Pacejka's similarity method:
/// with theoretical slips `σx = s/(1+s)`, `σy = tan α/(1+s)` and `σ = |(σx, σy)|`,
/// `Fx = σx/σ · F_x(σ)` and `Fy = σy/σ · F_y(σ)`. For pure slip this is exactly eq 3; at small
/// slip it is `Fx = Cs σx`, `Fy = Cα σy` like the HSRI tyre.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct MagicFormulaTyre {
    pub params: MagicFormulaParams,
}

impl MagicFormulaTyre {
    pub fn new(params: MagicFormulaParams) -> Self {
        Self { params }
    }
}

/// Below this combined theoretical slip the secant stiffness `F(σ)/σ` is replaced by its limit
/// `B C D` (the quotient would be 0/0 at σ = 0; the error of the limit is O(σ²)).
const SMALL_SLIP: f64 = 1e-12;

/// `F(σ)/σ` of one Magic Formula curve (001: eq 3) with `B = stiffness/(C D)`, for σ ≥ 0; the
/// limit `B C D` as σ → 0.
#[inline(always)]
fn secant_stiffness<S: Scalar>(
    combined_slip: S,
    stiffness: S,
    peak: S,
    shape: f64,
    curvature: f64,
) -> S {
    if combined_slip.value() < SMALL_SLIP {
        return stiffness;
    }
    let stiffness_factor = stiffness / (peak * shape); // B
    let x = stiffness_factor * combined_slip;
    let argument = x - (x - x.atan()) * curvature;
    // (001: eq 3)
    peak * (argument.atan() * shape).sin() / combined_slip
}

impl TyreModel for MagicFormulaTyre {
    #[inline]
    fn force_scaled<S: Scalar>(
        &self,
        k: &TyreKinematics<S>,
        scaling: &AxleTyreScaling,
    ) -> TyreForce<S> {
        let p = &self.params;
        let load = k.vertical_load;
        if load.value() <= 0.0 {
            return TyreForce::zero();
        }
        // Fz / FZref with the axle's λFz0 on FZref (1 = the seed car's tyre)
        let relative_load = load / (p.reference_load * scaling.reference_load);
        // degressive peak force D = λμ f0(Fz) Fz (000: 5.67 applied to 001: eq 3)
        let peak = (-(relative_load * p.friction_load) + p.friction_base) * load * scaling.friction;
        // B C D = Cα(Fz), Cs(Fz) (000: 5.70, 5.71), Cα times the axle's λKyα
        let cornering = (relative_load * p.cornering_load + p.cornering_base)
            * load
            * scaling.cornering_stiffness;
        let longitudinal = (relative_load * p.longitudinal_load + p.longitudinal_base) * load;
        let mut rolling_ratio = k.slip + 1.0;
        if rolling_ratio.value() < p.min_rolling_ratio {
            rolling_ratio = S::constant(p.min_rolling_ratio);
        }
        let slip_x = k.slip / rolling_ratio;
        let slip_y = k.tan_slip_angle / rolling_ratio;
        let combined = (slip_x.square() + slip_y.square()).sqrt();
        let secant_x = secant_stiffness(
            combined,
            longitudinal,
            peak,
            p.longitudinal_shape,
            p.longitudinal_curvature,
        );
        let secant_y = secant_stiffness(
            combined,
            cornering,
            peak,
            p.lateral_shape,
            p.lateral_curvature,
        );
        TyreForce {
            longitudinal: slip_x * secant_x,
            lateral: slip_y * secant_y,
        }
    }

    fn cornering_stiffness(&self, vertical_load: f64) -> f64 {
        let p = &self.params;
        (p.cornering_base + p.cornering_load * vertical_load / p.reference_load) * vertical_load
    }

    fn longitudinal_stiffness(&self, vertical_load: f64) -> f64 {
        let p = &self.params;
        (p.longitudinal_base + p.longitudinal_load * vertical_load / p.reference_load)
            * vertical_load
    }
}
