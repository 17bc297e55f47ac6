//! The posterior Cramér-Rao lower bound (PCRLB) of a [`StateSpaceModel`] with additive Gaussian
//! noise, by the information recursion of Tichavský, Muravchik and Nehorai, "Posterior
//! Cramér-Rao bounds for discrete-time nonlinear filtering", IEEE Trans. Signal Processing 46(5),
//! 1998, pp. 1386-1396 (their eqs. 21 and 34-37 for additive Gaussian noise):
//!
//! ```text
//! J(k+1) = D22 − D21 (J(k) + D11)⁻¹ D12,    J(0) = P(0)⁻¹
//! D11 = E[Fᵀ Q⁻¹ F],   D12 = D21ᵀ = −E[Fᵀ] Q⁻¹,   D22 = Q⁻¹ + E[Hᵀ R⁻¹ H]
//! ```
//!
//! with `F = ∂f/∂x` at `(x(k), u(k))` and `H = ∂h/∂x` at `(x(k+1), u(k+1))`, the expectations
//! over the true trajectories. `J(k)⁻¹` bounds the error covariance of any unbiased estimator of
//! `x(k)` from `y(1..k)`: `E[(x̂ − x)(x̂ − x)ᵀ] ≥ J(k)⁻¹`.
//!
//! The recursion is split as a filter is: [`PosteriorCramerRao::predict`] forms the information
//! about `x(k+1)` from `y(1..k)`, `Q⁻¹ − Q⁻¹ E[F] (J(k) + D11)⁻¹ E[Fᵀ] Q⁻¹` (the bound of a
//! one-step prediction, which is what the estimator FMU publishes), and
//! [`PosteriorCramerRao::update`] adds the measurement information `E[Hᵀ R⁻¹ H]` of the rows
//! taken. Together they are exactly the recursion above. The expectations are approximated by
//! the average over the true states handed in: one trajectory (the bound along the true path)
//! or many Monte Carlo truths. The Jacobians are the model's own (exact, by forward-mode
//! automatic differentiation where the model has them).
//!
//! For a linear Gaussian model `F` and `H` are constant, the expectations are exact and `J(k)⁻¹`
//! is the Kalman filter's covariance (the Riccati recursion): the test below checks that.

use nalgebra::{SMatrix, SVector};

use crate::kalman::SettingsError;
use crate::{MeasurementMask, StateSpaceModel};

/// The Fisher information `J(k)` of the state and its inverse, the bound.
#[derive(Debug, Clone, PartialEq)]
pub struct PosteriorCramerRao<const N: usize> {
    information: SMatrix<f64, N, N>,
}

/// `a⁻¹` of a symmetric positive definite matrix, by Cholesky; the error names `what`.
fn spd_inverse<const N: usize>(
    what: &str,
    a: &SMatrix<f64, N, N>,
) -> Result<SMatrix<f64, N, N>, SettingsError> {
    let symmetric = (a + a.transpose()) * 0.5;
    symmetric
        .cholesky()
        .map(|factor| factor.inverse())
        .ok_or_else(|| {
            SettingsError(format!(
                "PCRLB: {what} must be symmetric positive definite, got {a}"
            ))
        })
}

impl<const N: usize> PosteriorCramerRao<N> {
    /// Starts from the prior `x(0) ~ N(x̂(0), P(0))`: `J(0) = P(0)⁻¹`.
    pub fn new(initial_covariance: &SMatrix<f64, N, N>) -> Result<Self, SettingsError> {
        Ok(Self {
            information: spd_inverse("the initial covariance P(0)", initial_covariance)?,
        })
    }

    /// The Fisher information `J(k)`.
    pub fn information(&self) -> &SMatrix<f64, N, N> {
        &self.information
    }

    /// The bound `J(k)⁻¹` on the error covariance.
    pub fn bound(&self) -> Result<SMatrix<f64, N, N>, SettingsError> {
        spd_inverse("the information J(k)", &self.information)
    }

    /// The bound's diagonal square roots: the least root-mean-square error of each state.
    pub fn bound_std(&self) -> Result<SVector<f64, N>, SettingsError> {
        Ok(self.bound()?.diagonal().map(|v| v.max(0.0).sqrt()))
    }

    /// The time step from `k` to `k + 1` with the true `(x(k), u(k))` of every trajectory in
    /// `truths` (their average stands for the expectation): afterwards [`Self::information`] is
    /// the information about `x(k+1)` from `y(1..k)`. `Q` must be positive definite.
    pub fn predict<Model, const M: usize, const U: usize>(
        &mut self,
        model: &Model,
        truths: &[(SVector<f64, N>, SVector<f64, U>)],
    ) -> Result<(), SettingsError>
    where
        Model: StateSpaceModel<N, M, U>,
    {
        if truths.is_empty() {
            return Err(SettingsError(String::from(
                "PCRLB: predict needs at least one true state",
            )));
        }
        let q_inverse = spd_inverse("the process noise Q", &model.process_noise())?;
        let count = truths.len() as f64;
        let mut mean_jacobian = SMatrix::<f64, N, N>::zeros();
        let mut d11 = SMatrix::<f64, N, N>::zeros();
        for (state, input) in truths {
            let jacobian = model.transition_jacobian(state, input);
            mean_jacobian += jacobian / count;
            d11 += jacobian.transpose() * q_inverse * jacobian / count;
        }
        // D21 (J + D11)⁻¹ D12 with D21 = −Q⁻¹ E[F], D12 = D21ᵀ (the two minus signs cancel).
        let inner = spd_inverse("J(k) + E[Fᵀ Q⁻¹ F]", &(self.information + d11))?;
        let d21 = q_inverse * mean_jacobian;
        let mut information = q_inverse - d21 * inner * d21.transpose();
        crate::linalg::symmetrize(&mut information);
        self.information = information;
        Ok(())
    }

    /// The measurement at `k + 1` with the true `(x(k+1), u(k+1))` of every trajectory: adds
    /// `E[Hᵀ R⁻¹ H]` over the rows `mask` takes (a skipped row brings no information).
    pub fn update<Model, const M: usize, const U: usize>(
        &mut self,
        model: &Model,
        truths: &[(SVector<f64, N>, SVector<f64, U>)],
        mask: &MeasurementMask<M>,
    ) -> Result<(), SettingsError>
    where
        Model: StateSpaceModel<N, M, U>,
    {
        if truths.is_empty() {
            return Err(SettingsError(String::from(
                "PCRLB: update needs at least one true state",
            )));
        }
        let mut noise = model.measurement_noise();
        // Dropping a row from the information is the same as an infinite variance on it; the
        // rows kept form the sub-matrix of R, inverted below.
        let mut used = SMatrix::<f64, M, M>::identity();
        for row in (0..M).filter(|&row| !mask[row]) {
            used[(row, row)] = 0.0;
            for column in 0..M {
                let keep = if row == column { 1.0 } else { 0.0 };
                noise[(row, column)] = keep;
                noise[(column, row)] = keep;
            }
        }
        let r_inverse = used * spd_inverse("the measurement noise R", &noise)? * used;
        let count = truths.len() as f64;
        for (state, input) in truths {
            let jacobian = model.measurement_jacobian(state, input);
            self.information += jacobian.transpose() * r_inverse * jacobian / count;
        }
        crate::linalg::symmetrize(&mut self.information);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::{InitialEstimate, LinearKalmanFilter};
    use crate::Estimator;

    /// A linear Gaussian model with 3 states, 2 measurements and 1 input: a damped oscillator
    /// with a drifting bias, measured in position and the sum of velocity and bias.
    #[derive(Debug, Clone)]
    struct Linear;

    const F: [f64; 9] = [0.98, 0.1, 0.0, -0.2, 0.95, 0.05, 0.0, 0.0, 0.999];
    const H: [f64; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 1.0];

    impl StateSpaceModel<3, 2, 1> for Linear {
        fn state_names(&self) -> [&'static str; 3] {
            ["position", "velocity", "bias"]
        }
        fn measurement_names(&self) -> [&'static str; 2] {
            ["position", "velocity_plus_bias"]
        }
        fn transition(&self, x: &SVector<f64, 3>, u: &SVector<f64, 1>) -> SVector<f64, 3> {
            SMatrix::<f64, 3, 3>::from_row_slice(&F) * x + SVector::<f64, 3>::new(0.0, u[0], 0.0)
        }
        fn transition_jacobian(
            &self,
            _: &SVector<f64, 3>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 3, 3> {
            SMatrix::<f64, 3, 3>::from_row_slice(&F)
        }
        fn transition_input_jacobian(
            &self,
            _: &SVector<f64, 3>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 3, 1> {
            SMatrix::<f64, 3, 1>::new(0.0, 1.0, 0.0)
        }
        fn measurement(&self, x: &SVector<f64, 3>, _: &SVector<f64, 1>) -> SVector<f64, 2> {
            SMatrix::<f64, 2, 3>::from_row_slice(&H) * x
        }
        fn measurement_jacobian(
            &self,
            _: &SVector<f64, 3>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 2, 3> {
            SMatrix::<f64, 2, 3>::from_row_slice(&H)
        }
        fn measurement_input_jacobian(
            &self,
            _: &SVector<f64, 3>,
            _: &SVector<f64, 1>,
        ) -> SMatrix<f64, 2, 1> {
            SMatrix::<f64, 2, 1>::zeros()
        }
        fn process_noise(&self) -> SMatrix<f64, 3, 3> {
            SMatrix::<f64, 3, 3>::from_diagonal(&SVector::<f64, 3>::new(1e-4, 4e-3, 1e-6))
        }
        fn measurement_noise(&self) -> SMatrix<f64, 2, 2> {
            SMatrix::<f64, 2, 2>::new(0.01, 0.002, 0.002, 0.04)
        }
    }

    fn relative_difference(a: &SMatrix<f64, 3, 3>, b: &SMatrix<f64, 3, 3>) -> f64 {
        (a - b).amax() / b.amax()
    }

    /// For a linear Gaussian model the bound is the Kalman filter's covariance, prior and
    /// posterior, at every step, also when a row is missing (Tichavský et al. 1998, §IV).
    #[test]
    fn linear_gaussian_bound_equals_the_kalman_covariance() {
        let initial = InitialEstimate::diagonal(
            SVector::<f64, 3>::new(1.0, 0.0, 0.2),
            SVector::<f64, 3>::new(0.5, 0.2, 0.1),
        );
        let input = SVector::<f64, 1>::new(0.3);
        let mut filter =
            LinearKalmanFilter::new(Linear, &SVector::zeros(), &SVector::zeros(), &initial)
                .unwrap();
        let mut bound = PosteriorCramerRao::new(&initial.covariance).unwrap();
        // The truths do not matter for a linear model; any states will do.
        let mut truth = initial.state;
        for k in 0..200 {
            let next = Linear.transition(&truth, &input);
            filter.predict(&input).unwrap();
            bound.predict(&Linear, &[(truth, input)]).unwrap();
            let prior = bound.bound().unwrap();
            assert!(
                relative_difference(&prior, filter.covariance()) < 1e-9,
                "prior at {k}: {prior} against {}",
                filter.covariance()
            );
            let mask = if k % 7 == 3 {
                [true, false]
            } else {
                [true, true]
            };
            let y = Linear.measurement(&next, &input);
            filter.update(&y, &input, &mask).unwrap();
            bound.update(&Linear, &[(next, input)], &mask).unwrap();
            let posterior = bound.bound().unwrap();
            assert!(
                relative_difference(&posterior, filter.covariance()) < 1e-9,
                "posterior at {k}: {posterior} against {}",
                filter.covariance()
            );
            truth = next;
        }
    }

    /// The average over truths is an expectation: two copies of one truth give the bound of one.
    #[test]
    fn averaging_over_identical_truths_changes_nothing() {
        let p0 = SMatrix::<f64, 3, 3>::from_diagonal_element(0.3);
        let mut one = PosteriorCramerRao::new(&p0).unwrap();
        let mut two = one.clone();
        let pair = (
            SVector::<f64, 3>::new(0.1, 0.2, 0.3),
            SVector::<f64, 1>::new(0.0),
        );
        one.predict(&Linear, &[pair]).unwrap();
        two.predict(&Linear, &[pair, pair]).unwrap();
        one.update(&Linear, &[pair], &[true; 2]).unwrap();
        two.update(&Linear, &[pair, pair], &[true; 2]).unwrap();
        assert!(relative_difference(two.information(), one.information()) < 1e-14);
    }

    #[test]
    fn a_singular_start_is_an_error_naming_it() {
        let error = PosteriorCramerRao::<3>::new(&SMatrix::zeros()).unwrap_err();
        assert!(error.0.contains("initial covariance"), "{error}");
    }
}
