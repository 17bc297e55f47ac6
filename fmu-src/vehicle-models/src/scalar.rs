//! The number type the model equations are written in, so that each equation exists once.
//!
//! Every equation of models A, B and C is generic over [`Scalar`]. Evaluated with `f64` it is the
//! plain simulation; evaluated with [`Dual`] (forward-mode automatic differentiation) it yields the
//! exact Jacobians the EKF and the LKF need — exact to rounding, not finite differences.
//!
//! `Dual<S, K>` is itself generic over its scalar, so duals nest: the semi-implicit wheel step of
//! seed 000 (000: 6.1-6.2) needs `∂ω̇/∂ω` *inside* the transition, and the Jacobian of the
//! transition then needs that derivative differentiated once more. The model evaluates the tyre in
//! `Dual<S, 1>` (seeded in the wheel speed) for any outer `S`; with `S = Dual<f64, 8>` this gives
//! the exact second-order terms without any special code.

use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A real number the model equations can be evaluated in: `f64` or a dual number.
///
/// Branches in the equations (tyre adhesion/sliding, speed guards) decide on [`Scalar::value`];
/// the derivative returned is then that of the branch taken (a one-sided derivative exactly at a
/// switching point).
pub trait Scalar:
    Copy
    + Debug
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A constant (all derivatives zero).
    fn constant(value: f64) -> Self;
    /// The real value, without derivatives.
    fn value(&self) -> f64;
    /// Square root. At exactly zero the derivative is taken as zero instead of infinite: the
    /// models only take roots of sums of squares, whose gradient is zero there as well, and an
    /// infinite factor would turn `0 · ∞` into NaN (e.g. the sliding speed of a freely rolling,
    /// straight-running wheel, 000: 5.66).
    fn sqrt(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn atan(self) -> Self;
    /// `atan2(self, x)`, i.e. the angle of the vector `(x, self)`.
    fn atan2(self, x: Self) -> Self;
    /// `|self|`; derivative `sign(self)`, zero at zero.
    fn abs(self) -> Self;
    /// `e^self`.
    fn exp(self) -> Self;

    /// `self²`.
    #[inline(always)]
    fn square(self) -> Self {
        self * self
    }
    /// `1 / self`.
    #[inline(always)]
    fn recip(self) -> Self {
        Self::constant(1.0) / self
    }
}

impl Scalar for f64 {
    #[inline(always)]
    fn constant(value: f64) -> Self {
        value
    }
    #[inline(always)]
    fn value(&self) -> f64 {
        *self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline(always)]
    fn atan(self) -> Self {
        f64::atan(self)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        f64::exp(self)
    }
}

/// A dual number `value + Σ gradient[i] ε_i` with `K` independent directions, over any
/// [`Scalar`] `S` (so duals nest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<S: Scalar, const K: usize> {
    pub value: S,
    pub gradient: [S; K],
}

impl<S: Scalar, const K: usize> Dual<S, K> {
    /// The independent variable number `direction` with the given value.
    #[inline(always)]
    pub fn variable(value: S, direction: usize) -> Self {
        let mut gradient = [S::constant(0.0); K];
        gradient[direction] = S::constant(1.0);
        Self { value, gradient }
    }

    /// A constant with value `value` (all derivatives zero).
    #[inline(always)]
    pub fn from_value(value: S) -> Self {
        Self {
            value,
            gradient: [S::constant(0.0); K],
        }
    }

    /// Applies a scalar function with value `f` and derivative `df` at `self.value` (chain rule).
    #[inline(always)]
    fn chain(self, f: S, df: S) -> Self {
        let mut gradient = self.gradient;
        for g in gradient.iter_mut() {
            *g = *g * df;
        }
        Self { value: f, gradient }
    }
}

impl<S: Scalar, const K: usize> Add for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        let mut gradient = self.gradient;
        for (g, r) in gradient.iter_mut().zip(rhs.gradient.iter()) {
            *g = *g + *r;
        }
        Self {
            value: self.value + rhs.value,
            gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Sub for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, rhs: Self) -> Self {
        let mut gradient = self.gradient;
        for (g, r) in gradient.iter_mut().zip(rhs.gradient.iter()) {
            *g = *g - *r;
        }
        Self {
            value: self.value - rhs.value,
            gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Mul for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        let mut gradient = self.gradient;
        for (g, r) in gradient.iter_mut().zip(rhs.gradient.iter()) {
            *g = *g * rhs.value + self.value * *r;
        }
        Self {
            value: self.value * rhs.value,
            gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Div for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn div(self, rhs: Self) -> Self {
        // the value by true division, so a dual evaluation has bit-identical values to the
        // plain `f64` one
        let value = self.value / rhs.value;
        let inverse = rhs.value.recip();
        let mut gradient = self.gradient;
        for (g, r) in gradient.iter_mut().zip(rhs.gradient.iter()) {
            *g = (*g - value * *r) * inverse;
        }
        Self { value, gradient }
    }
}

impl<S: Scalar, const K: usize> Neg for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let mut gradient = self.gradient;
        for g in gradient.iter_mut() {
            *g = -*g;
        }
        Self {
            value: -self.value,
            gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Add<f64> for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn add(self, rhs: f64) -> Self {
        Self {
            value: self.value + rhs,
            gradient: self.gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Sub<f64> for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, rhs: f64) -> Self {
        Self {
            value: self.value - rhs,
            gradient: self.gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Mul<f64> for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, rhs: f64) -> Self {
        let mut gradient = self.gradient;
        for g in gradient.iter_mut() {
            *g = *g * rhs;
        }
        Self {
            value: self.value * rhs,
            gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Div<f64> for Dual<S, K> {
    type Output = Self;
    #[inline(always)]
    fn div(self, rhs: f64) -> Self {
        // The value is divided, not multiplied by the reciprocal, so that it equals the plain
        // f64 evaluation bit for bit (the EKF takes f(x) from the value part of its Jacobian
        // pass); the derivatives share one reciprocal.
        let inverse = 1.0 / rhs;
        let mut gradient = self.gradient;
        for g in gradient.iter_mut() {
            *g = *g * inverse;
        }
        Self {
            value: self.value / rhs,
            gradient,
        }
    }
}

impl<S: Scalar, const K: usize> Scalar for Dual<S, K> {
    #[inline(always)]
    fn constant(value: f64) -> Self {
        Self::from_value(S::constant(value))
    }
    #[inline(always)]
    fn value(&self) -> f64 {
        self.value.value()
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let root = self.value.sqrt();
        let derivative = if root.value() > 0.0 {
            (root * 2.0).recip()
        } else {
            S::constant(0.0)
        };
        self.chain(root, derivative)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        self.chain(self.value.sin(), self.value.cos())
    }
    #[inline(always)]
    fn cos(self) -> Self {
        self.chain(self.value.cos(), -self.value.sin())
    }
    #[inline(always)]
    fn atan(self) -> Self {
        let derivative = (self.value.square() + 1.0).recip();
        self.chain(self.value.atan(), derivative)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        // d atan2(y, x) = (x dy - y dx) / (x² + y²)
        let radius_squared = x.value.square() + self.value.square();
        let value = self.value.atan2(x.value);
        let mut gradient = self.gradient;
        if radius_squared.value() > 0.0 {
            let inverse = radius_squared.recip();
            for (g, gx) in gradient.iter_mut().zip(x.gradient.iter()) {
                *g = (x.value * *g - self.value * *gx) * inverse;
            }
        } else {
            gradient = [S::constant(0.0); K];
        }
        Self { value, gradient }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        let v = self.value.value();
        if v > 0.0 {
            self
        } else if v < 0.0 {
            -self
        } else {
            Self::from_value(self.value.abs())
        }
    }
    #[inline(always)]
    fn exp(self) -> Self {
        let value = self.value.exp();
        self.chain(value, value)
    }
}

/// Seeds `N + U` independent directions: the state first, then the input. Used to obtain the
/// state and input Jacobians of one function in one evaluation.
#[inline(always)]
pub(crate) fn seed_state_and_input<const N: usize, const U: usize, const K: usize>(
    state: &[f64; N],
    input: &[f64; U],
) -> ([Dual<f64, K>; N], [Dual<f64, K>; U]) {
    debug_assert_eq!(N + U, K, "gradient length must be state + input dimension");
    let seeded_state = core::array::from_fn(|i| Dual::variable(state[i], i));
    let seeded_input = core::array::from_fn(|j| Dual::variable(input[j], N + j));
    (seeded_state, seeded_input)
}

/// Splits the gradients of `R` dual outputs into the Jacobians with respect to the state
/// (`R × N`) and the input (`R × U`).
#[inline(always)]
pub(crate) fn split_jacobians<const R: usize, const N: usize, const U: usize, const K: usize>(
    outputs: &[Dual<f64, K>; R],
) -> (nalgebra::SMatrix<f64, R, N>, nalgebra::SMatrix<f64, R, U>) {
    let state_jacobian = nalgebra::SMatrix::<f64, R, N>::from_fn(|i, j| outputs[i].gradient[j]);
    let input_jacobian = nalgebra::SMatrix::<f64, R, U>::from_fn(|i, j| outputs[i].gradient[N + j]);
    (state_jacobian, input_jacobian)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_quotient_and_chain_rule_match_hand_derivatives() {
        let x = Dual::<f64, 2>::variable(0.7, 0);
        let y = Dual::<f64, 2>::variable(-1.3, 1);
        let f = (x * y).sin() / (x.square() + 1.0) + y.atan2(x);
        let (xv, yv) = (0.7_f64, -1.3_f64);
        let q = xv * xv + 1.0;
        let df_dx = (xv * yv).cos() * yv / q - (xv * yv).sin() * 2.0 * xv / (q * q)
            + (-yv) / (xv * xv + yv * yv);
        let df_dy = (xv * yv).cos() * xv / q + xv / (xv * xv + yv * yv);
        assert!((f.gradient[0] - df_dx).abs() < 1e-14);
        assert!((f.gradient[1] - df_dy).abs() < 1e-14);
    }

    #[test]
    fn nested_duals_give_second_derivatives() {
        // f(x) = x³ sqrt(x): f' = 3.5 x^2.5, f'' = 8.75 x^1.5
        let x = 1.7_f64;
        let outer = Dual::<f64, 1>::variable(x, 0);
        let inner = Dual::<Dual<f64, 1>, 1>::variable(outer, 0);
        let f = inner * inner * inner * inner.sqrt();
        let first = f.gradient[0];
        assert!((first.value - 3.5 * x.powf(2.5)).abs() < 1e-12);
        assert!((first.gradient[0] - 8.75 * x.powf(1.5)).abs() < 1e-12);
    }

    #[test]
    fn root_of_zero_has_zero_derivative_instead_of_nan() {
        let x = Dual::<f64, 1>::variable(0.0, 0);
        let r = (x * x).sqrt();
        assert_eq!(r.value, 0.0);
        assert_eq!(r.gradient[0], 0.0);
    }
}
