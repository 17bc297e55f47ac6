//! Linear tyre: forces proportional to slip and slip angle (000: 5.58-5.61), with the
//! load-dependent stiffnesses of the HSRI model (000: 5.70-5.71).

use serde::{Deserialize, Serialize};

use super::{AxleTyreScaling, HsriParams, TyreForce, TyreKinematics, TyreModel};
use crate::scalar::Scalar;

/// Stiffness coefficients of the linear tyre; `Cα = (c_α1 + c_α2 Fz/FZref) Fz` and likewise
/// `Cs`, so that it is the linearisation of the HSRI tyre at every load.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinearTyreParams {
    /// Reference wheel load, N.
    pub reference_load: f64,
    /// Cornering coefficient, base value, 1/rad.
    pub cornering_base: f64,
    /// Cornering coefficient, wheel-load influence, 1/rad.
    pub cornering_load: f64,
    /// Longitudinal coefficient, base value.
    pub longitudinal_base: f64,
    /// Longitudinal coefficient, wheel-load influence.
    pub longitudinal_load: f64,
}

impl LinearTyreParams {
    /// The linearisation of an HSRI tyre at zero slip.
    pub fn matching_hsri(hsri: &HsriParams) -> Self {
        Self {
            reference_load: hsri.reference_load,
            cornering_base: hsri.cornering_base,
            cornering_load: hsri.cornering_load,
            longitudinal_base: hsri.longitudinal_base,
            longitudinal_load: hsri.longitudinal_load,
        }
    }
}

impl Default for LinearTyreParams {
    /// The linearisation of the seed-000 HSRI tyre (table 5.2).
    fn default() -> Self {
        Self::matching_hsri(&HsriParams::default())
    }
}

/// `Fy = Cα tan α`, `Fx = Cs s` (000: 5.58-5.61; the seed writes `α` for `tan α`, equal to first
/// order). No saturation: this is the tyre of the linear single-track model.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct LinearTyre {
    pub params: LinearTyreParams,
}

impl LinearTyre {
    pub fn new(params: LinearTyreParams) -> Self {
        Self { params }
    }
}

impl TyreModel for LinearTyre {
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
        // no friction limit, so λμ does not apply; λFz0 on FZref, λKyα on Cα
        let relative_load = load / (p.reference_load * scaling.reference_load);
        // (000: 5.70), (000: 5.71)
        let cornering = (relative_load * p.cornering_load + p.cornering_base)
            * load
            * scaling.cornering_stiffness;
        let longitudinal = (relative_load * p.longitudinal_load + p.longitudinal_base) * load;
        // (000: 5.58-5.61)
        TyreForce {
            longitudinal: longitudinal * k.slip,
            lateral: cornering * k.tan_slip_angle,
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
