//! HSRI tyre model of seed 000 (000: 5.65-5.73, table 5.2).

use serde::{Deserialize, Serialize};

use super::{AxleTyreScaling, TyreForce, TyreKinematics, TyreModel};
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

    /// The force, and `∂Fx/∂s` if `with_slip_derivative` (else zero).
    #[inline(always)]
    fn evaluate<S: Scalar>(
        &self,
        k: &TyreKinematics<S>,
        scaling: &AxleTyreScaling,
        with_slip_derivative: bool,
    ) -> (TyreForce<S>, S) {
        let zero = S::constant(0.0);
        let p = &self.params;
        let load = k.vertical_load;
        if load.value() <= 0.0 {
            return (TyreForce::zero(), zero);
        }
        // Fz / FZref with the axle's λFz0 on FZref (1 = the seed's tyre)
        let relative_load = load * (1.0 / (p.reference_load * scaling.reference_load));
        let slip = k.slip;
        let tan_alpha = k.tan_slip_angle;
        // (000: 5.70) Cα, times the axle's cornering-stiffness factor (1 = the seed's tyre);
        // (000: 5.71) Cs
        let cornering = (relative_load * p.cornering_load + p.cornering_base)
            * load
            * scaling.cornering_stiffness;
        let longitudinal = (relative_load * p.longitudinal_load + p.longitudinal_base) * load;
        let lateral_demand = cornering * tan_alpha;
        let longitudinal_demand = longitudinal * slip;
        // (000: 5.73) sR = numerator / denominator
        let numerator = (longitudinal_demand.square() + lateral_demand.square()).sqrt();
        let one_plus_slip = slip + 1.0;
        let adhesion = || {
            // adhesion only (000: table after 5.73, sR ≤ 0.5); one division for the quotients
            let inverse = S::constant(1.0) / one_plus_slip;
            let force = TyreForce {
                longitudinal: longitudinal_demand * inverse,
                lateral: lateral_demand * inverse,
            };
            // ∂/∂s of Cs·s/(1 + s) is Cs/(1 + s)²
            let slip_derivative = if with_slip_derivative {
                longitudinal * inverse * inverse
            } else {
                zero
            };
            (force, slip_derivative)
        };
        // (000: 5.67) friction potential f0, (000: 5.68) decay factor kR, both times the axle's
        // friction factor λμ, so µ of (000: 5.69) scales at every sliding speed
        let friction_potential =
            (-(relative_load * p.friction_load) + p.friction_base) * scaling.friction;
        let friction_decay =
            (relative_load * p.friction_decay_load + p.friction_decay_base) * scaling.friction;
        // The adhesion force does not depend on µ, only the case distinction does, and µ lies in
        // [f0 − max(kR, 0), f0 − min(kR, 0)] (000: 5.69). Most adhesion calls are settled by that
        // lowest µ, which skips the sliding speed's two square roots and a division. The
        // relative margin covers the few roundings by which the µ
        // computed below may undershoot the bound, so the case taken is always the one the full
        // test takes (tested against it).
        let lowest_friction = friction_potential.value() - friction_decay.value().max(0.0);
        if one_plus_slip.value() > 0.0
            && p.sliding_threshold >= 0.0
            && numerator.value()
                <= p.sliding_threshold
                    * (lowest_friction * one_plus_slip.value() * load.value())
                    * (1.0 - ADHESION_BOUND_MARGIN)
        {
            return adhesion();
        }
        // (000: 5.66) sliding speed
        let resultant_slip = (slip.square() + tan_alpha.square()).sqrt();
        let speed = k.wheel_velocity.abs();
        let sliding_speed = speed * resultant_slip;
        // (000: 5.69) friction coefficient
        let reference_squared = p.reference_sliding_speed * p.reference_sliding_speed;
        let friction_root = (sliding_speed.square() + reference_squared).sqrt();
        let friction = friction_potential - friction_decay * sliding_speed / friction_root;
        let denominator = friction * one_plus_slip * load;
        if numerator.value() <= p.sliding_threshold * denominator.value() {
            adhesion()
        } else {
            // adhesion and sliding (sR > 0.5): the seed's C·x/(1+s) · (sR − 0.25)/sR², rewritten
            // as C·x · µFz/N · (1 − 0.25/sR) so that a locked wheel (1 + s → 0) stays finite.
            // Here N > 0 because N ≤ 0.5·denominator fails and N ≥ 0.
            let inverse_numerator = S::constant(1.0) / numerator;
            let gain = friction * load * inverse_numerator;
            let ratio = denominator * inverse_numerator;
            let shape = -(ratio * p.sliding_offset) + 1.0;
            let factor = gain * shape;
            let force = TyreForce {
                longitudinal: longitudinal_demand * factor,
                lateral: lateral_demand * factor,
            };
            if !with_slip_derivative {
                return (force, zero);
            }
            // The chain rule, outermost last: vG = v·sqrt(s² + tan²α) (000: 5.66),
            // µ = f0 − kR·vG/sqrt(vG² + vµ²) (000: 5.69), N = sqrt((Cs s)² + (Cα tanα)²) and
            // the denominator µ(1 + s)Fz (000: 5.73), factor = µFz/N · (1 − 0.25·den/N).
            let sliding_speed_derivative = if resultant_slip.value() > 0.0 {
                speed * slip / resultant_slip
            } else {
                zero
            };
            let friction_derivative =
                -(friction_decay * reference_squared * sliding_speed_derivative
                    / (friction_root * friction_root * friction_root));
            let numerator_derivative = longitudinal_demand * longitudinal * inverse_numerator;
            let denominator_derivative = (friction_derivative * one_plus_slip + friction) * load;
            let gain_derivative =
                (friction_derivative * load - gain * numerator_derivative) * inverse_numerator;
            let ratio_derivative =
                (denominator_derivative - ratio * numerator_derivative) * inverse_numerator;
            let factor_derivative =
                gain_derivative * shape - gain * ratio_derivative * p.sliding_offset;
            (
                force,
                longitudinal * factor + longitudinal_demand * factor_derivative,
            )
        }
    }
}

/// Relative safety margin of the early adhesion test in [`HsriTyre`]'s force: far above the
/// few-ulp rounding of the friction coefficient, far below any physical tolerance.
const ADHESION_BOUND_MARGIN: f64 = 1e-12;

impl TyreModel for HsriTyre {
    #[inline]
    fn force_scaled<S: Scalar>(
        &self,
        k: &TyreKinematics<S>,
        scaling: &AxleTyreScaling,
    ) -> TyreForce<S> {
        self.evaluate(k, scaling, false).0
    }

    /// The force and `∂Fx/∂s` in closed form: the chain rule through (000: 5.66-5.73), about
    /// half the work of the dual-number default (tested against it).
    #[inline]
    fn force_and_slip_derivative<S: Scalar>(
        &self,
        k: &TyreKinematics<S>,
        scaling: &AxleTyreScaling,
    ) -> (TyreForce<S>, S) {
        self.evaluate(k, scaling, true)
    }

    fn cornering_stiffness(&self, vertical_load: f64) -> f64 {
        self.params.cornering_stiffness(vertical_load)
    }

    fn longitudinal_stiffness(&self, vertical_load: f64) -> f64 {
        self.params.longitudinal_stiffness(vertical_load)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Dual;

    /// The force with µ always computed first (the formula as the seed writes it), for checking
    /// that the early adhesion test changes no result.
    fn force_without_early_adhesion<S: Scalar>(
        p: &HsriParams,
        k: &TyreKinematics<S>,
        scale: f64,
    ) -> TyreForce<S> {
        let load = k.vertical_load;
        let relative_load = load * (1.0 / p.reference_load);
        let friction_potential = -(relative_load * p.friction_load) + p.friction_base;
        let friction_decay = relative_load * p.friction_decay_load + p.friction_decay_base;
        let (slip, tan_alpha) = (k.slip, k.tan_slip_angle);
        let sliding_speed = k.wheel_velocity.abs() * (slip.square() + tan_alpha.square()).sqrt();
        let friction = friction_potential
            - friction_decay * sliding_speed
                / (sliding_speed.square() + p.reference_sliding_speed * p.reference_sliding_speed)
                    .sqrt();
        let cornering = (relative_load * p.cornering_load + p.cornering_base) * load * scale;
        let longitudinal = (relative_load * p.longitudinal_load + p.longitudinal_base) * load;
        let lateral_demand = cornering * tan_alpha;
        let longitudinal_demand = longitudinal * slip;
        let numerator = (longitudinal_demand.square() + lateral_demand.square()).sqrt();
        let one_plus_slip = slip + 1.0;
        let denominator = friction * one_plus_slip * load;
        if numerator.value() <= p.sliding_threshold * denominator.value() {
            let inverse = S::constant(1.0) / one_plus_slip;
            TyreForce {
                longitudinal: longitudinal_demand * inverse,
                lateral: lateral_demand * inverse,
            }
        } else {
            let inverse_numerator = S::constant(1.0) / numerator;
            let factor = friction
                * load
                * inverse_numerator
                * (-(denominator * inverse_numerator * p.sliding_offset) + 1.0);
            TyreForce {
                longitudinal: longitudinal_demand * factor,
                lateral: lateral_demand * factor,
            }
        }
    }

    /// Slips and slip angles on a fine grid, densest around the adhesion/sliding boundary, at
    /// several loads and speeds, with negative and odd friction-decay parameters too: the early
    /// adhesion test must give the very same bits as the full case distinction.
    #[test]
    fn early_adhesion_test_changes_no_bit() {
        let seed = HsriParams::default();
        let negative_decay = HsriParams {
            friction_decay_base: -0.2,
            ..HsriParams::default()
        };
        let steep_decay_late_sliding = HsriParams {
            friction_decay_base: 0.9,
            reference_sliding_speed: 0.5,
            sliding_threshold: 0.8,
            ..HsriParams::default()
        };
        let mut shortcut_taken = 0;
        let mut sliding = 0;
        for params in [seed, negative_decay, steep_decay_late_sliding] {
            let tyre = HsriTyre::new(params.clone());
            for load in [500.0, 3000.0, 3519.5, 6000.0] {
                for speed in [0.3, 5.0, 18.0, 40.0, -10.0] {
                    for i in -200..=200 {
                        let slip = f64::from(i) * 5e-4;
                        for j in -150..=150 {
                            let tan_alpha = f64::from(j) * 4e-4;
                            let k = TyreKinematics {
                                slip,
                                tan_slip_angle: tan_alpha,
                                wheel_velocity: speed,
                                vertical_load: load,
                            };
                            let fast = tyre.force_with_cornering_scale(&k, 1.0);
                            let full = force_without_early_adhesion(&params, &k, 1.0);
                            assert_eq!(
                                (fast.longitudinal.to_bits(), fast.lateral.to_bits()),
                                (full.longitudinal.to_bits(), full.lateral.to_bits()),
                                "load {load}, speed {speed}, slip {slip}, tan α {tan_alpha}"
                            );
                            let lowest = params.friction_potential(load)
                                - (params.friction_decay_base
                                    + params.friction_decay_load * load / params.reference_load)
                                    .max(0.0);
                            let demand = (params.longitudinal_stiffness(load) * slip)
                                .hypot(params.cornering_stiffness(load) * tan_alpha);
                            if demand
                                < 0.99 * params.sliding_threshold * lowest * (1.0 + slip) * load
                            {
                                shortcut_taken += 1;
                            } else if demand
                                > params.sliding_threshold * params.friction_potential(load) * load
                            {
                                sliding += 1;
                            }
                        }
                    }
                }
            }
        }
        // The grid exercises both cases well.
        assert!(
            shortcut_taken > 30_000 && sliding > 30_000,
            "{shortcut_taken} {sliding}"
        );
    }

    /// The same with dual numbers (value and derivative, as the transition's ∂Fx/∂ω uses).
    #[test]
    fn early_adhesion_test_keeps_derivatives() {
        let params = HsriParams::default();
        let tyre = HsriTyre::new(params.clone());
        for i in -200..=200 {
            for j in -100..=100 {
                let k = TyreKinematics {
                    slip: Dual::<f64, 1>::variable(f64::from(i) * 5e-4, 0),
                    tan_slip_angle: Dual::from_value(f64::from(j) * 6e-4),
                    wheel_velocity: Dual::from_value(18.0),
                    vertical_load: Dual::from_value(3519.5),
                };
                let fast = tyre.force_with_cornering_scale(&k, 1.0);
                let full = force_without_early_adhesion(&params, &k, 1.0);
                assert_eq!(
                    fast.longitudinal.value.to_bits(),
                    full.longitudinal.value.to_bits()
                );
                assert_eq!(
                    fast.longitudinal.gradient[0].to_bits(),
                    full.longitudinal.gradient[0].to_bits()
                );
                assert_eq!(fast.lateral.value.to_bits(), full.lateral.value.to_bits());
                assert_eq!(
                    fast.lateral.gradient[0].to_bits(),
                    full.lateral.gradient[0].to_bits()
                );
            }
        }
    }
}

#[cfg(test)]
mod slip_derivative_tests {
    use super::*;

    /// The HSRI force law with the trait's default `force_and_slip_derivative` (dual numbers).
    #[derive(Clone, Debug)]
    struct DualDerivative(HsriTyre);

    impl TyreModel for DualDerivative {
        fn force_scaled<S: Scalar>(
            &self,
            k: &TyreKinematics<S>,
            scaling: &AxleTyreScaling,
        ) -> TyreForce<S> {
            self.0.force_scaled(k, scaling)
        }

        fn cornering_stiffness(&self, vertical_load: f64) -> f64 {
            self.0.cornering_stiffness(vertical_load)
        }

        fn longitudinal_stiffness(&self, vertical_load: f64) -> f64 {
            self.0.longitudinal_stiffness(vertical_load)
        }
    }

    /// The closed-form `∂Fx/∂s` equals the dual number's to rounding, in adhesion and sliding,
    /// driving and braking, at low and high speed, unscaled and with an axle's factors on µ,
    /// Cα and FZref, and the force is bit-identical.
    #[test]
    fn closed_form_slip_derivative_matches_dual_numbers() {
        let tyre = HsriTyre::default();
        let dual = DualDerivative(tyre.clone());
        let mut sliding = 0;
        let scaled = AxleTyreScaling {
            cornering_stiffness: 1.2,
            friction: 0.6,
            reference_load: 1.3,
        };
        for (load, scaling) in [
            (800.0, AxleTyreScaling::NONE),
            (3519.5, AxleTyreScaling::NONE),
            (6000.0, AxleTyreScaling::NONE),
            (3519.5, scaled),
        ] {
            for speed in [0.0, 0.5, 18.0, -12.0] {
                for i in -120..=120 {
                    for j in -60..=60 {
                        let k = TyreKinematics {
                            slip: f64::from(i) * 2.5e-3,
                            tan_slip_angle: f64::from(j) * 2.5e-3,
                            wheel_velocity: speed,
                            vertical_load: load,
                        };
                        let (force, derivative) = tyre.force_and_slip_derivative(&k, &scaling);
                        let (dual_force, dual_derivative) =
                            dual.force_and_slip_derivative(&k, &scaling);
                        assert_eq!(force, dual_force, "{k:?}");
                        // Near the force's peak ∂Fx/∂s is a difference of terms of the size of
                        // the slip stiffness Cs, so rounding is relative to Cs.
                        let scale = tyre.params.longitudinal_stiffness(load);
                        assert!(
                            (derivative - dual_derivative).abs() <= 1e-13 * scale,
                            "{k:?}: closed form {derivative}, dual {dual_derivative}"
                        );
                        let plain = tyre.force_with_cornering_scale(&k, 1.0);
                        if plain.longitudinal.hypot(plain.lateral)
                            < 0.99
                                * f64::hypot(
                                    tyre.params.longitudinal_stiffness(load) * k.slip,
                                    tyre.params.cornering_stiffness(load) * k.tan_slip_angle,
                                )
                                / (1.0 + k.slip)
                        {
                            sliding += 1;
                        }
                    }
                }
            }
        }
        assert!(
            sliding > 10_000,
            "the grid reaches the sliding branch ({sliding})"
        );
    }
}
