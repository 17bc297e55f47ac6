//! Combined-slip Magic Formula tyre in the MF 5.2 / PAC2002 form of Pacejka, "Tire and Vehicle
//! Dynamics", 3rd ed. 2012, Sect. 4.3.2 (equation numbers `4.E..` below are that section's),
//! for the full reference vehicle ([`crate::full_vehicle`]).
//!
//! What is kept of the full MF 5.2 set, and why:
//! - pure slip `Fx0(κ)` (4.E9-4.E16) and `Fy0(α)` (4.E19-4.E26) with the load sensitivity of the
//!   peak (`p_dx2`, `p_dy2`), of the curvature (`p_ex2`, `p_ey2`), of the slip stiffness
//!   (`p_kx2`, `p_kx3`) and the degressive cornering stiffness `K_yα(Fz)` (`p_ky1`, `p_ky2`);
//! - the combined-slip weighting functions `G_xα` (4.E51) and `G_yκ` (4.E59);
//! - the road friction as the scaling factor `λ_μ` of the peaks `μx`, `μy` (4.E13, 4.E23), an
//!   input of the vehicle, so a manoeuvre can cross from dry to wet or ice;
//! - **left out**: camber (the vehicle model has none), inflation pressure, the turn-slip factors
//!   `ζ`, and every shift (`S_Hx`, `S_Vx`, `S_Hy`, `S_Vy`, `S_Hxα`, `S_Hyκ`, `S_Vyκ`, `r_By3`):
//!   the shifts model conicity and ply-steer, which give a force at zero slip and break the
//!   left/right mirror symmetry the reference vehicle is tested for.
//!
//! Sign convention ISO 8855 as the rest of the crate ([`super`]): `κ > 0` driving, a positive
//! `tan α` gives a positive (leftward) lateral force. `p_ky1` is therefore stored as a magnitude
//! (`.tir` files and the CommonRoad data write it negative, for their sign convention).
//!
//! The weighting functions are clamped at zero: with `r_Cx1`, `r_Cy1 > 1` the cosine of 4.E51 /
//! 4.E59 turns negative at very large slip, which would reverse a force against its slip (a
//! braked wheel sliding sideways would then push the car forward).

use serde::{Deserialize, Serialize};

use super::TyreForce;

/// Pacejka's `ε` that keeps `B = K/(C D + ε)` finite when the peak `D` vanishes (4.E16, 4.E26).
const STIFFNESS_EPSILON: f64 = 1e-6;

/// MF 5.2 coefficients of one tyre (names as in Pacejka 2012, Sect. 4.3.2, and `.tir` files),
/// plus its relaxation lengths for the transient slip of [`crate::full_vehicle`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CombinedSlipParams {
    /// `F_z0`, nominal load, N; `dfz = (Fz − Fz0)/Fz0` (4.E2a).
    pub nominal_load: f64,
    /// Shape factor `C_x` (4.E11).
    pub p_cx1: f64,
    /// Longitudinal friction `μx` at the nominal load (4.E13).
    pub p_dx1: f64,
    /// Variation of `μx` with load (4.E13).
    pub p_dx2: f64,
    /// Longitudinal curvature `E_x` at the nominal load (4.E14).
    pub p_ex1: f64,
    /// Variation of `E_x` with load (4.E14).
    pub p_ex2: f64,
    /// Slip stiffness `K_xκ/Fz` at the nominal load (4.E15).
    pub p_kx1: f64,
    /// Variation of the slip stiffness with load (4.E15).
    pub p_kx2: f64,
    /// Exponent of the slip stiffness's load variation (4.E15).
    pub p_kx3: f64,
    /// Shape factor `C_y` (4.E21).
    pub p_cy1: f64,
    /// Lateral friction `μy` at the nominal load (4.E23).
    pub p_dy1: f64,
    /// Variation of `μy` with load (4.E23).
    pub p_dy2: f64,
    /// Lateral curvature `E_y` at the nominal load (4.E24).
    pub p_ey1: f64,
    /// Variation of `E_y` with load (4.E24).
    pub p_ey2: f64,
    /// Maximum of the cornering stiffness `K_yα/F_z0` (4.E25), a magnitude.
    pub p_ky1: f64,
    /// Load, in units of `F_z0`, at which `K_yα` is largest (4.E25).
    pub p_ky2: f64,
    /// Slope factor of `G_xα` (4.E54).
    pub r_bx1: f64,
    /// Variation of that slope with `κ` (4.E54).
    pub r_bx2: f64,
    /// Shape factor of `G_xα` (4.E55).
    pub r_cx1: f64,
    /// Curvature factor of `G_xα` (4.E56).
    pub r_ex1: f64,
    /// Slope factor of `G_yκ` (4.E62).
    pub r_by1: f64,
    /// Variation of that slope with `α` (4.E62).
    pub r_by2: f64,
    /// Shape factor of `G_yκ` (4.E63).
    pub r_cy1: f64,
    /// Curvature factor of `G_yκ` (4.E64).
    pub r_ey1: f64,
    /// Longitudinal relaxation length `σκ`, m (Pacejka 2012, Sect. 7.2).
    pub relaxation_length_longitudinal: f64,
    /// Lateral relaxation length `σα`, m (Pacejka 2012, Sect. 7.2).
    pub relaxation_length_lateral: f64,
}

impl Default for CombinedSlipParams {
    /// The seed car's tyre (see [`CombinedSlipParams::seed_car`]).
    fn default() -> Self {
        Self::seed_car()
    }
}

impl CombinedSlipParams {
    /// A PAC2002 tyre matched to the seed-000 HSRI tyre (table 5.2) as far as the forms allow:
    /// - peak friction `f0 = 1.35 − 0.15 Fz/3000` (000: 5.67) exactly: `F_z0 = 3000 N`,
    ///   `p_dx1 = p_dy1 = 1.2`, `p_dx2 = p_dy2 = −0.15`;
    /// - slip stiffness `Cs = (10 + 20 Fz/3000) Fz` (000: 5.71) exactly: `p_kx1 = 30`,
    ///   `p_kx2 = 20`, `p_kx3 = 0`;
    /// - cornering stiffness `Cα = (25.6 − 5.73 Fz/3000) Fz` (000: 5.70) matched in the height
    ///   (85.8 kN/rad) and load (6702 N) of its maximum: `p_ky1 = 28.6`, `p_ky2 = 2.234`; at the
    ///   static loads 3492 / 3374 N the sine form of 4.E25 is 6.5 % / 6.8 % stiffer;
    /// - shapes and curvatures of model B's Magic Formula tyre (`C_x = 1.65`, `E_x = 0`,
    ///   `C_y = 1.3`, `E_y = −1`);
    /// - the combined-slip coefficients of the CommonRoad data set (see the cars' files, seed 000
    ///   has none) and relaxation lengths of 0.15 m and 0.5 m, the project's choice.
    pub fn seed_car() -> Self {
        Self {
            nominal_load: 3000.0,
            p_cx1: 1.65,
            p_dx1: 1.2,
            p_dx2: -0.15,
            p_ex1: 0.0,
            p_ex2: 0.0,
            p_kx1: 30.0,
            p_kx2: 20.0,
            p_kx3: 0.0,
            p_cy1: 1.3,
            p_dy1: 1.2,
            p_dy2: -0.15,
            p_ey1: -1.0,
            p_ey2: 0.0,
            p_ky1: 28.6,
            p_ky2: 2.234,
            r_bx1: 13.276,
            r_bx2: -13.778,
            r_cx1: 1.2568,
            r_ex1: 0.65225,
            r_by1: 7.1433,
            r_by2: 9.1916,
            r_cy1: 1.0719,
            r_ey1: -0.27572,
            relaxation_length_longitudinal: 0.15,
            relaxation_length_lateral: 0.5,
        }
    }
}

/// Force of one tyre together with the peaks it was limited by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CombinedSlipForce {
    /// The combined-slip force in the wheel frame.
    pub force: TyreForce<f64>,
    /// Longitudinal peak `D_x = μx Fz` (4.E12), N.
    pub peak_longitudinal: f64,
    /// Lateral peak `D_y = μy Fz` (4.E22), N.
    pub peak_lateral: f64,
}

/// The combined-slip MF 5.2 tyre (f64 only: the full vehicle is a truth model, no Jacobians).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct CombinedSlipTyre {
    pub params: CombinedSlipParams,
}

/// `D sin(C atan(B x − E (B x − atan(B x))))`, the Magic Formula (4.E9, 4.E19 without shifts).
#[inline(always)]
fn magic_formula(x: f64, stiffness_factor: f64, shape: f64, peak: f64, curvature: f64) -> f64 {
    let bx = stiffness_factor * x;
    peak * (shape * (bx - curvature * (bx - bx.atan())).atan()).sin()
}

/// `cos(C atan(B x − E (B x − atan(B x))))`, a combined-slip weighting function (4.E51, 4.E59;
/// without the shift its normalisation `G0` of 4.E52, 4.E60 is 1), clamped at zero (module docs).
#[inline(always)]
fn weighting(x: f64, stiffness_factor: f64, shape: f64, curvature: f64) -> f64 {
    let bx = stiffness_factor * x;
    (shape * (bx - curvature * (bx - bx.atan())).atan())
        .cos()
        .max(0.0)
}

/// `cos(atan(x)) = 1/√(1 + x²)`, the slope reduction of 4.E54 and 4.E62.
#[inline(always)]
fn cos_atan(x: f64) -> f64 {
    1.0 / (1.0 + x * x).sqrt()
}

impl CombinedSlipTyre {
    pub fn new(params: CombinedSlipParams) -> Self {
        Self { params }
    }

    /// Normalised load change `dfz` (4.E2a).
    #[inline(always)]
    fn load_change(&self, vertical_load: f64) -> f64 {
        (vertical_load - self.params.nominal_load) / self.params.nominal_load
    }

    /// Cornering stiffness `K_yα = p_Ky1 F_z0 sin(2 atan(Fz/(p_Ky2 F_z0)))` (4.E25 without camber
    /// and pressure, `p_Ky4 = 2` as in PAC2002), N/rad.
    pub fn cornering_stiffness(&self, vertical_load: f64) -> f64 {
        let p = &self.params;
        p.p_ky1 * p.nominal_load * (2.0 * (vertical_load / (p.p_ky2 * p.nominal_load)).atan()).sin()
    }

    /// Longitudinal slip stiffness `K_xκ = Fz (p_Kx1 + p_Kx2 dfz) exp(p_Kx3 dfz)` (4.E15), N.
    pub fn longitudinal_stiffness(&self, vertical_load: f64) -> f64 {
        let p = &self.params;
        let dfz = self.load_change(vertical_load);
        vertical_load * (p.p_kx1 + p.p_kx2 * dfz) * (p.p_kx3 * dfz).exp()
    }

    /// Combined-slip force for the longitudinal slip `κ`, `tan α` (4.E3: `α* = tan α`), the
    /// vertical load and the road friction `λ_μ` (1 = the tyre's own dry road). A wheel without
    /// load carries no force.
    pub fn force(
        &self,
        slip: f64,
        tan_slip_angle: f64,
        vertical_load: f64,
        road_friction: f64,
    ) -> CombinedSlipForce {
        let p = &self.params;
        if vertical_load <= 0.0 {
            return CombinedSlipForce {
                force: TyreForce::zero(),
                peak_longitudinal: 0.0,
                peak_lateral: 0.0,
            };
        }
        let friction_scale = road_friction.max(0.0);
        let dfz = self.load_change(vertical_load);
        // pure longitudinal slip (4.E9, 4.E11-4.E16)
        let peak_x = (p.p_dx1 + p.p_dx2 * dfz) * friction_scale * vertical_load;
        let curvature_x = (p.p_ex1 + p.p_ex2 * dfz).min(1.0);
        let stiffness_x =
            self.longitudinal_stiffness(vertical_load) / (p.p_cx1 * peak_x + STIFFNESS_EPSILON);
        let pure_x = magic_formula(slip, stiffness_x, p.p_cx1, peak_x, curvature_x);
        // pure side slip (4.E19, 4.E21-4.E26)
        let peak_y = (p.p_dy1 + p.p_dy2 * dfz) * friction_scale * vertical_load;
        let curvature_y = (p.p_ey1 + p.p_ey2 * dfz).min(1.0);
        let stiffness_y =
            self.cornering_stiffness(vertical_load) / (p.p_cy1 * peak_y + STIFFNESS_EPSILON);
        let pure_y = magic_formula(tan_slip_angle, stiffness_y, p.p_cy1, peak_y, curvature_y);
        // combined slip: Fx = G_xα Fx0 (4.E50, 4.E51, 4.E54), Fy = G_yκ Fy0 (4.E58, 4.E59, 4.E62)
        let slope_xa = p.r_bx1 * cos_atan(p.r_bx2 * slip);
        let slope_yk = p.r_by1 * cos_atan(p.r_by2 * tan_slip_angle);
        let weight_x = weighting(tan_slip_angle, slope_xa, p.r_cx1, p.r_ex1);
        let weight_y = weighting(slip, slope_yk, p.r_cy1, p.r_ey1);
        CombinedSlipForce {
            force: TyreForce {
                longitudinal: weight_x * pure_x,
                lateral: weight_y * pure_y,
            },
            peak_longitudinal: peak_x.max(0.0),
            peak_lateral: peak_y.max(0.0),
        }
    }
}
