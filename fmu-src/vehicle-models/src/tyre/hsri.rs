//! HSRI tyre model of seed 000 (000: 5.65-5.73, table 5.2).

use serde::{Deserialize, Serialize};

use super::{TyreForce, TyreKinematics, TyreModel};
use crate::scalar::Scalar;

/// Tyre data of seed 000, table 5.2 (185/70 HR 14 at 2.0 bar).
///
/// The contact-patch length and carcass stiffness rows of table 5.2 (`lL0`, `lL1`, `cy`) only feed
/// the aligning moment, which none of the models uses, so they are not carried here. The tyre
/// radius (0.3 m) is a vehicle parameter (`wheel_radius`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HsriParams {
    /// `FZref`, reference wheel load, N.
    pub reference_load: f64,
    /// `f00`, friction potential, base value.
    pub friction_base: f64,
    /// `f01`, friction potential, wheel-load influence.
    pub friction_load: f64,
    /// `kR0`, friction decay factor, base value.
    pub friction_decay_base: f64,
    /// `kR1`, friction decay factor, wheel-load influence.
    pub friction_decay_load: f64,
    /// `Cα1`, normalised cornering-stiffness coefficient, base value, 1/rad.
    pub cornering_base: f64,
    /// `Cα2`, normalised cornering-stiffness coefficient, wheel-load influence, 1/rad.
    pub cornering_load: f64,
    /// `Cs1`, normalised longitudinal-stiffness coefficient, base value.
    pub longitudinal_base: f64,
    /// `Cs2`, normalised longitudinal-stiffness coefficient, wheel-load influence.
    pub longitudinal_load: f64,
    /// `vµ`, reference sliding speed, m/s.
    pub reference_sliding_speed: f64,
    /// Resultant slip `sR` above which the contact patch partly slides (000: table after 5.73).
    pub sliding_threshold: f64,
    /// Offset in the sliding-branch factor `(sR − 0.25)/sR²` (000: table after 5.73).
    pub sliding_offset: f64,
}

impl Default for HsriParams {
    fn default() -> Self {
        // 000: table 5.2 and the case distinction after 5.73.
        Self {
            reference_load: 3000.0,
            friction_base: 1.35,
            friction_load: 0.15,
            friction_decay_base: 0.1,
            friction_decay_load: 0.03,
            cornering_base: 25.6,
            cornering_load: -5.73,
            longitudinal_base: 10.0,
            longitudinal_load: 20.0,
            reference_sliding_speed: 7.0,
            sliding_threshold: 0.5,
            sliding_offset: 0.25,
        }
    }
}

impl HsriParams {
    /// Friction potential `f0 = f00 − f01 Fz/FZref` (000: 5.67).
    pub fn friction_potential(&self, vertical_load: f64) -> f64 {
        self.friction_base - self.friction_load * vertical_load / self.reference_load
    }

    /// Cornering stiffness `Cα = (Cα1 + Cα2 Fz/FZref) Fz` (000: 5.70), N/rad.
    pub fn cornering_stiffness(&self, vertical_load: f64) -> f64 {
        (self.cornering_base + self.cornering_load * vertical_load / self.reference_load)
            * vertical_load
    }

    /// Longitudinal stiffness `Cs = (Cs1 + Cs2 Fz/FZref) Fz` (000: 5.71), N.
    pub fn longitudinal_stiffness(&self, vertical_load: f64) -> f64 {
        (self.longitudinal_base + self.longitudinal_load * vertical_load / self.reference_load)
            * vertical_load
    }
}

/// The HSRI tyre (000: 5.65-5.73), combined slip with a friction coefficient that falls with the
/// sliding speed.
///
/// The friction formula (000: 5.69) is garbled in the seed text; implemented is the HSRI reading
/// SPEC §3 gives, `µ = f0 − kR vG / sqrt(vG² + vµ²)` (friction falling from `f0` towards `f0 − kR`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct HsriTyre {
    pub params: HsriParams,
}

impl HsriTyre {
    pub fn new(params: HsriParams) -> Self {
        Self { params }
    }
}

impl TyreModel for HsriTyre {
    #[inline]
    fn force_with_cornering_scale<S: Scalar>(
        &self,
        k: &TyreKinematics<S>,
        cornering_stiffness_scale: f64,
    ) -> TyreForce<S> {
        let p = &self.params;
        let load = k.vertical_load;
        if load.value() <= 0.0 {
            return TyreForce::zero();
        }
        let relative_load = load / p.reference_load;
        // (000: 5.67)
        let friction_potential = -(relative_load * p.friction_load) + p.friction_base;
        // (000: 5.68)
        let friction_decay = relative_load * p.friction_decay_load + p.friction_decay_base;
        let slip = k.slip;
        let tan_alpha = k.tan_slip_angle;
        // (000: 5.66) sliding speed
        let sliding_speed = k.wheel_velocity.abs() * (slip.square() + tan_alpha.square()).sqrt();
        // (000: 5.69) friction coefficient
        let friction = friction_potential
            - friction_decay * sliding_speed
                / (sliding_speed.square() + p.reference_sliding_speed * p.reference_sliding_speed)
                    .sqrt();
        // (000: 5.70) Cα, times the caller's cornering-stiffness scale (1 = the seed's tyre);
        // (000: 5.71) Cs
        let cornering = (relative_load * p.cornering_load + p.cornering_base)
            * load
            * cornering_stiffness_scale;
        let longitudinal = (relative_load * p.longitudinal_load + p.longitudinal_base) * load;
        let lateral_demand = cornering * tan_alpha;
        let longitudinal_demand = longitudinal * slip;
        // (000: 5.73) sR = numerator / denominator
        let numerator = (longitudinal_demand.square() + lateral_demand.square()).sqrt();
        let one_plus_slip = slip + 1.0;
        let denominator = friction * one_plus_slip * load;
        if numerator.value() <= p.sliding_threshold * denominator.value() {
            // adhesion only (000: table after 5.73, sR ≤ 0.5)
            TyreForce {
                longitudinal: longitudinal_demand / one_plus_slip,
                lateral: lateral_demand / one_plus_slip,
            }
        } else {
            // adhesion and sliding (sR > 0.5): the seed's C·x/(1+s) · (sR − 0.25)/sR², rewritten
            // as C·x · µFz/N · (1 − 0.25/sR) so that a locked wheel (1 + s → 0) stays finite.
            // Here N > 0 because N ≤ 0.5·denominator fails and N ≥ 0.
            let factor =
                friction * load / numerator * (-(denominator / numerator * p.sliding_offset) + 1.0);
            TyreForce {
                longitudinal: longitudinal_demand * factor,
                lateral: lateral_demand * factor,
            }
        }
    }

    fn cornering_stiffness(&self, vertical_load: f64) -> f64 {
        self.params.cornering_stiffness(vertical_load)
    }

    fn longitudinal_stiffness(&self, vertical_load: f64) -> f64 {
        self.params.longitudinal_stiffness(vertical_load)
    }
}
