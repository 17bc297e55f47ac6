//! Yardsticks an estimator must beat: answers that need no filter at all.
//!
//! - **Zero sideslip**: answering β = 0 at every sample.
//! - **The steady-state linear single-track sideslip** from the road-wheel angle and the measured
//!   speed (Mitschke and Wallentowitz, "Dynamik der Kraftfahrzeuge", ch. on the linear
//!   single-track model; Rajamani, "Vehicle Dynamics and Control", 3.3): with the understeer
//!   gradient `K = m (lr/C_f − lf/C_r) / L²`, the steady yaw rate is
//!   `r_ss = vx δ / (L (1 + K vx²))` and the sideslip `β_ss = (lr − m lf vx² / (L C_r)) · r_ss / vx`.
//!
//! The master knows no vehicle model: these need only the car's basic data, which a scenario or a
//! log's map gives. A yardstick may know the car's true cornering stiffness; the estimator FMU
//! knows only what its parameters give it.

/// The linear single-track data the steady-state formula needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingleTrackData {
    /// Mass [kg].
    pub mass: f64,
    /// CoG to front axle [m].
    pub lf: f64,
    /// CoG to rear axle [m].
    pub lr: f64,
    /// Front axle cornering stiffness, both tyres together [N/rad].
    pub cf: f64,
    /// Rear axle cornering stiffness, both tyres together [N/rad].
    pub cr: f64,
}

impl SingleTrackData {
    /// Wheelbase [m].
    pub fn wheelbase(&self) -> f64 {
        self.lf + self.lr
    }

    /// Understeer gradient `K = m (lr/C_f − lf/C_r) / L²` [s²/m²].
    pub fn understeer_gradient(&self) -> f64 {
        let l = self.wheelbase();
        self.mass * (self.lr / self.cf - self.lf / self.cr) / (l * l)
    }

    /// Steady-state sideslip [rad] at speed `vx` [m/s] and road-wheel angle `delta` [rad].
    ///
    /// Below `min_speed` (and for a non-finite input) the formula's `r_ss / vx` is taken at its
    /// limit `δ / L`, so the answer tends to the kinematic `lr δ / L` at standstill instead of
    /// dividing by zero. A negative speed is taken by its magnitude (the formula is even in vx
    /// for the speed-dependent terms and the yaw rate's sign follows the travel direction).
    pub fn steady_state_sideslip(&self, vx: f64, delta: f64) -> f64 {
        let l = self.wheelbase();
        let v = if vx.is_finite() { vx.abs() } else { 0.0 };
        // r_ss / vx = δ / (L (1 + K vx²)); finite at vx = 0.
        let r_over_v = delta / (l * (1.0 + self.understeer_gradient() * v * v));
        (self.lr - self.mass * self.lf * v * v / (l * self.cr)) * r_over_v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The MBDS car with the stiffnesses of its repository (70 / 120 kN/rad).
    fn mbds() -> SingleTrackData {
        SingleTrackData {
            mass: 982.0,
            lf: 1.33,
            lr: 1.07,
            cf: 70e3,
            cr: 120e3,
        }
    }

    #[test]
    fn at_standstill_it_is_the_kinematic_sideslip_of_small_angles() {
        let car = mbds();
        let delta = 0.05;
        assert_relative_eq!(
            car.steady_state_sideslip(0.0, delta),
            car.lr * delta / car.wheelbase(),
            epsilon = 1e-15
        );
    }

    #[test]
    fn it_follows_the_formula_and_changes_sign_past_the_tangent_speed() {
        let car = mbds();
        let (vx, delta) = (20.0, 0.02);
        let l = car.wheelbase();
        let k = car.mass * (car.lr / car.cf - car.lf / car.cr) / (l * l);
        let r = vx * delta / (l * (1.0 + k * vx * vx));
        let beta = (car.lr - car.mass * car.lf * vx * vx / (l * car.cr)) * r / vx;
        assert_relative_eq!(car.steady_state_sideslip(vx, delta), beta, epsilon = 1e-15);
        // The sideslip of a left turn is negative above sqrt(lr L C_r / (m lf)).
        let tangent = (car.lr * l * car.cr / (car.mass * car.lf)).sqrt();
        assert!(car.steady_state_sideslip(tangent * 0.9, delta) > 0.0);
        assert!(car.steady_state_sideslip(tangent * 1.1, delta) < 0.0);
    }

    #[test]
    fn a_missing_speed_gives_the_kinematic_answer_not_nan() {
        let car = mbds();
        assert!(car.steady_state_sideslip(f64::NAN, 0.1).is_finite());
    }
}
