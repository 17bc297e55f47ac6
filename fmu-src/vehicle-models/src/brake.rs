//! The friction brake of models A and B: a brake torque that opposes the wheel's rotation and
//! holds a standing wheel, instead of the seed's torque that keeps acting at standstill.
//!
//! Seed 000 writes the brake as a torque `M_B` on the wheel (000: 5.45, 5.46); its manoeuvres brake
//! from speed and end before standstill. Held at standstill, that torque spins the wheels
//! backwards without bound and the tyres drag the car backwards. A real brake is Coulomb
//! friction: it delivers up to its torque against the rotation and, once the wheel stands, only
//! as much as holds it. Here this is regularised for time stepping (a Karnopp-type stick zone,
//! Karnopp, "Computer simulation of stick-slip friction in mechanical dynamic systems", ASME J.
//! Dyn. Sys. Meas. Control 107, 1985): the brake torque is the one that makes the wheel speed
//! decay as `ω̇ = −ω / τ` ([`BRAKE_HOLD_TIME`]) where that torque is within the brake's capacity,
//! and the full torque against the motion otherwise. The two meet continuously; outside the stick
//! zone the seed's expression is evaluated unchanged (bit for bit), so every manoeuvre that brakes
//! from speed without stopping a wheel gives the numbers it gave before.

use crate::driver_input::seed_brake_torque;
use crate::scalar::Scalar;

/// The time constant `τ`, s, with which a held wheel's speed decays to zero in the stick zone.
/// Short against the wheel's dynamics, and at least the longest integration step the
/// ReferenceVehicle allows (10 ms), so that Runge-Kutta 4 (stable to `dt/τ` = 2.78) and the
/// seed's semi-implicit scheme are stable in the zone.
pub const BRAKE_HOLD_TIME: f64 = 0.01;

/// A wheel's spin acceleration under the friction brake.
#[derive(Clone, Copy, Debug)]
pub struct BrakedSpin<S> {
    /// `ω̇`, rad/s².
    pub rate: S,
    /// Whether the brake holds the wheel (stick zone): `rate = −ω/τ`, `∂rate/∂ω = −1/τ`.
    pub held: bool,
}

impl<S: Scalar> BrakedSpin<S> {
    /// `∂ω̇/∂ω` for the semi-implicit scheme: `−1/τ` while held, else `free` (the tyre's).
    #[inline(always)]
    pub fn rate_derivative(&self, free: S) -> S {
        if self.held {
            S::constant(-1.0 / BRAKE_HOLD_TIME)
        } else {
            free
        }
    }
}

/// The spin acceleration of a wheel (or an axle's wheels together) of speed `omega` and inertia
/// `inertia`, on which the torques other than the brake sum to `other_torque` and whose brake
/// delivers up to `share` of the total brake torque `brake` (a magnitude ≥ 0).
///
/// `seed_rate(m_b)` is the seed's expression evaluated with the signed total brake torque `m_b`
/// (000: 5.45, 5.46 with `M_B = m_b`): it is called with `−brake` while the wheel turns forwards
/// (the seed's own case, so its bits are kept) and with `+brake` while it turns backwards.
#[inline(always)]
pub fn braked_spin<S: Scalar>(
    omega: S,
    other_torque: S,
    brake: S,
    share: f64,
    inertia: f64,
    seed_rate: impl Fn(S) -> S,
) -> BrakedSpin<S> {
    let capacity = brake.value() * share;
    if capacity <= 0.0 {
        return BrakedSpin {
            rate: seed_rate(seed_brake_torque(brake)),
            held: false,
        };
    }
    // The brake torque that makes ω̇ = −ω/τ.
    let holding = -(omega * (inertia / BRAKE_HOLD_TIME) + other_torque).value();
    if holding <= -capacity {
        BrakedSpin {
            rate: seed_rate(seed_brake_torque(brake)),
            held: false,
        }
    } else if holding >= capacity {
        BrakedSpin {
            rate: seed_rate(brake),
            held: false,
        }
    } else {
        BrakedSpin {
            rate: omega * (-1.0 / BRAKE_HOLD_TIME),
            held: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seed(other: f64, inertia: f64) -> impl Fn(f64) -> f64 {
        move |m_b| (other + m_b * 0.5) / inertia
    }

    #[test]
    fn a_fast_wheel_gets_the_seeds_torque_bit_for_bit() {
        let spin = braked_spin(50.0, -300.0, 2400.0, 0.5, 10.3, seed(-300.0, 10.3));
        assert!(!spin.held);
        assert_eq!(
            spin.rate.to_bits(),
            ((-300.0 + -2400.0 * 0.5) / 10.3f64).to_bits()
        );
    }

    #[test]
    fn a_standing_wheel_under_a_brake_stronger_than_the_drive_stays() {
        let spin = braked_spin(0.0, 800.0, 2400.0, 0.5, 10.3, seed(800.0, 10.3));
        assert!(spin.held);
        assert_eq!(spin.rate, 0.0);
    }

    #[test]
    fn a_drive_stronger_than_the_brake_turns_the_wheel() {
        let spin = braked_spin(0.0, 1500.0, 2400.0, 0.5, 10.3, seed(1500.0, 10.3));
        assert!(!spin.held);
        assert!((spin.rate - 300.0 / 10.3).abs() < 1e-12);
    }

    #[test]
    fn a_wheel_turning_backwards_is_braked_forwards() {
        let spin = braked_spin(-50.0, 0.0, 2400.0, 0.5, 10.3, seed(0.0, 10.3));
        assert!(!spin.held);
        assert!(spin.rate > 0.0);
    }

    #[test]
    fn the_stick_zone_meets_the_full_torque_continuously() {
        // At the zone's edge the held rate −ω/τ equals the full-torque rate.
        let (other, brake, inertia) = (200.0, 1200.0, 10.3);
        let edge = (brake - other) * BRAKE_HOLD_TIME / inertia;
        let total = 2.0 * brake;
        let inside = braked_spin(
            edge * 0.999_999,
            other,
            total,
            0.5,
            inertia,
            seed(other, inertia),
        );
        let outside = braked_spin(
            edge * 1.000_001,
            other,
            total,
            0.5,
            inertia,
            seed(other, inertia),
        );
        assert!(inside.held && !outside.held);
        assert!((inside.rate - outside.rate).abs() < 1e-3 * outside.rate.abs());
    }

    #[test]
    fn without_a_brake_nothing_changes() {
        let spin = braked_spin(0.0, -5.0, 0.0, 0.5, 3.0, seed(-5.0, 3.0));
        assert!(!spin.held);
        assert_eq!(
            spin.rate.to_bits(),
            ((-5.0 + -0.0 * 0.5) / 3.0f64).to_bits()
        );
    }
}
