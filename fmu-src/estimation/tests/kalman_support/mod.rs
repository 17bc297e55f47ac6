//! A linear-Gaussian test model shared by the Kalman and Luenberger tests.
#![allow(dead_code)]

use estimation::kalman::SigmaPoints;
use estimation::luenberger::ObserverDesign;
use estimation::particle::ParticleFilterConfig;
use estimation::registry::EstimatorSettings;
use estimation::StateSpaceModel;
use nalgebra::{Complex, Vector1, Vector3};
use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// `x(k+1) = A x + B u + w`, `y = C x + D u + v` with fixed matrices: on such a model the LKF is
/// the optimal filter and the EKF and the UKFs must reproduce it.
#[derive(Debug, Clone)]
pub struct LinearModel<const N: usize, const M: usize, const U: usize> {
    pub a: SMatrix<f64, N, N>,
    pub b: SMatrix<f64, N, U>,
    pub c: SMatrix<f64, M, N>,
    pub d: SMatrix<f64, M, U>,
    pub q: SMatrix<f64, N, N>,
    pub r: SMatrix<f64, M, M>,
}

impl<const N: usize, const M: usize, const U: usize> StateSpaceModel<N, M, U>
    for LinearModel<N, M, U>
{
    fn state_names(&self) -> [&'static str; N] {
        ["x"; N]
    }
    fn measurement_names(&self) -> [&'static str; M] {
        ["y"; M]
    }
    fn transition(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, N> {
        self.a * state + self.b * input
    }
    fn transition_jacobian(&self, _: &SVector<f64, N>, _: &SVector<f64, U>) -> SMatrix<f64, N, N> {
        self.a
    }
    fn transition_input_jacobian(
        &self,
        _: &SVector<f64, N>,
        _: &SVector<f64, U>,
    ) -> SMatrix<f64, N, U> {
        self.b
    }
    fn measurement(&self, state: &SVector<f64, N>, input: &SVector<f64, U>) -> SVector<f64, M> {
        self.c * state + self.d * input
    }
    fn measurement_jacobian(&self, _: &SVector<f64, N>, _: &SVector<f64, U>) -> SMatrix<f64, M, N> {
        self.c
    }
    fn measurement_input_jacobian(
        &self,
        _: &SVector<f64, N>,
        _: &SVector<f64, U>,
    ) -> SMatrix<f64, M, U> {
        self.d
    }
    fn process_noise(&self) -> SMatrix<f64, N, N> {
        self.q
    }
    fn measurement_noise(&self) -> SMatrix<f64, M, M> {
        self.r
    }
}

/// A 3-state, 2-output, 1-input model: a lightly damped oscillator driven by the input plus a
/// slow drift state, measured through a position-like and a mixed output with feed-through.
pub fn three_state_model() -> LinearModel<3, 2, 1> {
    LinearModel {
        a: SMatrix::<f64, 3, 3>::new(0.98, 0.1, 0.0, -0.2, 0.95, 0.05, 0.0, 0.0, 0.999),
        b: SMatrix::<f64, 3, 1>::new(0.0, 0.1, 0.02),
        c: SMatrix::<f64, 2, 3>::new(1.0, 0.0, 0.0, 0.3, 0.0, 1.0),
        d: SMatrix::<f64, 2, 1>::new(0.0, 0.5),
        q: SMatrix::<f64, 3, 3>::new(1e-3, 2e-4, 0.0, 2e-4, 2e-3, 0.0, 0.0, 0.0, 1e-4),
        r: SMatrix::<f64, 2, 2>::new(4e-2, 1e-2, 1e-2, 9e-2),
    }
}

/// One noisy trajectory of a linear model: inputs `u(k)`, states `x(k)` and measurements `y(k)`,
/// `k = 0..steps`, deterministic for `seed`.
pub struct Trajectory<const N: usize, const M: usize, const U: usize> {
    pub inputs: Vec<SVector<f64, U>>,
    pub states: Vec<SVector<f64, N>>,
    pub measurements: Vec<SVector<f64, M>>,
}

pub fn gaussian<const K: usize>(
    rng: &mut ChaCha8Rng,
    covariance: &SMatrix<f64, K, K>,
) -> SVector<f64, K> {
    let l = covariance.cholesky().expect("test covariance is SPD").l();
    let z = SVector::<f64, K>::from_fn(|_, _| StandardNormal.sample(rng));
    l * z
}

pub fn simulate<const N: usize, const M: usize, const U: usize>(
    model: &LinearModel<N, M, U>,
    start: SVector<f64, N>,
    input: impl Fn(usize) -> SVector<f64, U>,
    steps: usize,
    seed: u64,
) -> Trajectory<N, M, U> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = start;
    let mut trajectory = Trajectory {
        inputs: Vec::new(),
        states: Vec::new(),
        measurements: Vec::new(),
    };
    for k in 0..steps {
        let u = input(k);
        let y = model.measurement(&x, &u) + gaussian(&mut rng, &model.r);
        trajectory.inputs.push(u);
        trajectory.states.push(x);
        trajectory.measurements.push(y);
        x = model.transition(&x, &u) + gaussian(&mut rng, &model.q);
    }
    trajectory
}

/// Every estimator of the registry on [`three_state_model`]: the LKF about the origin, the
/// Luenberger observer placed through the first output, 200 particles.
pub fn three_state_settings() -> EstimatorSettings<3, 1> {
    let poles = [0.6, 0.7, 0.8].map(|p| Complex::new(p, 0.0)).to_vec();
    EstimatorSettings {
        operating_point: Ok((Vector3::zeros(), Vector1::zeros())),
        scaled_sigma_points: SigmaPoints::scaled(0.5, 2.0, 0.0),
        observer_design: Ok(ObserverDesign::single_output(0, poles)),
        particles: Ok(ParticleFilterConfig {
            particle_count: 200,
            seed: 7,
            ..ParticleFilterConfig::default()
        }),
    }
}
