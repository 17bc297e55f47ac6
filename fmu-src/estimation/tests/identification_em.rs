//! EM identification: the minimisers and the Fisher information. Recovery of model C's
//! parameters on the seed-003 set-up is tested in the studies crate
//! (`harness/studies/tests/seed003_identification.rs`).

use estimation::identification::{
    cramer_rao_standard_deviations, minimise_powell, minimise_scalar, parameter_information,
    LineSearchConfig, Parameterised,
};
use estimation::kalman::InitialEstimate;
use estimation::particle::RecordedRun;
use estimation::StateSpaceModel;
use nalgebra::{SMatrix, SVector};

#[test]
fn scalar_minimiser_finds_the_minimum_of_a_parabola_and_respects_invalid_regions() {
    let config = LineSearchConfig::default();
    let (x, fx, evaluations) = minimise_scalar(|x| (x - 3.7).powi(2) + 1.0, 3.0, &config);
    assert!((x - 3.7).abs() < 1e-6, "x = {x}");
    assert!((fx - 1.0).abs() < 1e-10);
    assert!(evaluations < 40, "{evaluations} evaluations");
    // A region where the model is invalid (infinite objective) is never chosen.
    let (x, _, _) = minimise_scalar(
        |x| {
            if x < 1.0 {
                f64::INFINITY
            } else {
                (x - 0.5).powi(2)
            }
        },
        1.2,
        &config,
    );
    assert!((1.0..1.01).contains(&x), "x = {x}");
}

#[test]
fn powell_minimises_a_correlated_quadratic_in_few_sweeps() {
    let target = SVector::<f64, 4>::new(8.36, 7.78, 0.62, 1.014);
    let objective = |p: &SVector<f64, 4>| {
        let d = p - target;
        // Strongly correlated: the ridge that makes coordinate search zig-zag.
        d[0].powi(2) + d[1].powi(2) + 50.0 * (d[2] - d[3]).powi(2) + (d[2] + d[3]).powi(2) * 0.5
    };
    let start = SVector::<f64, 4>::new(7.942, 7.386, 0.56, 0.91);
    let (x, _, evaluations) =
        minimise_powell(objective, start, 30, 1e-10, &LineSearchConfig::default());
    assert!((x - target).amax() < 1e-5, "{x:?}");
    assert!(evaluations < 1500, "{evaluations} evaluations");
}

/// `x(k+1) = a x(k) + b u(k)`, `y = x + v`, `v ~ N(0, r)`: a model whose Fisher information is
/// known in closed form when the state starts known and there is no process noise.
#[derive(Debug, Clone)]
struct ScalarLinear {
    a: f64,
    b: f64,
    r: f64,
}

impl StateSpaceModel<1, 1, 1> for ScalarLinear {
    fn state_names(&self) -> [&'static str; 1] {
        ["x"]
    }
    fn measurement_names(&self) -> [&'static str; 1] {
        ["y"]
    }
    fn transition(&self, x: &SVector<f64, 1>, u: &SVector<f64, 1>) -> SVector<f64, 1> {
        x * self.a + u * self.b
    }
    fn transition_jacobian(&self, _: &SVector<f64, 1>, _: &SVector<f64, 1>) -> SMatrix<f64, 1, 1> {
        SMatrix::<f64, 1, 1>::from_element(self.a)
    }
    fn transition_input_jacobian(
        &self,
        _: &SVector<f64, 1>,
        _: &SVector<f64, 1>,
    ) -> SMatrix<f64, 1, 1> {
        SMatrix::<f64, 1, 1>::from_element(self.b)
    }
    fn measurement(&self, x: &SVector<f64, 1>, _: &SVector<f64, 1>) -> SVector<f64, 1> {
        *x
    }
    fn measurement_jacobian(&self, _: &SVector<f64, 1>, _: &SVector<f64, 1>) -> SMatrix<f64, 1, 1> {
        SMatrix::identity()
    }
    fn measurement_input_jacobian(
        &self,
        _: &SVector<f64, 1>,
        _: &SVector<f64, 1>,
    ) -> SMatrix<f64, 1, 1> {
        SMatrix::zeros()
    }
    fn process_noise(&self) -> SMatrix<f64, 1, 1> {
        // Positive definite for the EKF, far below anything the data resolve.
        SMatrix::<f64, 1, 1>::from_element(1e-24)
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        SMatrix::<f64, 1, 1>::from_element(self.r)
    }
}

impl Parameterised<2> for ScalarLinear {
    fn parameter_names(&self) -> [&'static str; 2] {
        ["a", "b"]
    }
    fn parameters(&self) -> SVector<f64, 2> {
        SVector::<f64, 2>::new(self.a, self.b)
    }
    fn with_parameters(&self, p: &SVector<f64, 2>) -> Option<Self> {
        Some(Self {
            a: p[0],
            b: p[1],
            r: self.r,
        })
    }
}

#[test]
fn fisher_information_matches_the_closed_form_and_flags_an_unexcited_parameter() {
    let model = ScalarLinear {
        a: 0.95,
        b: 0.3,
        r: 0.01,
    };
    let x0 = 2.0;
    let steps = 60;
    let initial = InitialEstimate {
        state: SVector::<f64, 1>::new(x0),
        covariance: SMatrix::<f64, 1, 1>::from_element(1e-24),
    };
    // No input: the prediction is a^t x0 whatever the data, so the innovation sensitivity is
    // -t a^(t-1) x0 and I_aa = Σ_t (t a^(t-1) x0)² / r; b never acts, so I is singular.
    let run = RecordedRun {
        inputs: vec![SVector::<f64, 1>::zeros(); steps],
        measurements: (0..steps)
            .map(|t| SVector::<f64, 1>::new(x0 * model.a.powi(t as i32) + 0.05))
            .collect(),
    };
    let information = parameter_information(&model, &run, &initial).unwrap();
    let expected: f64 = (1..steps)
        .map(|t| (t as f64 * model.a.powi(t as i32 - 1) * x0).powi(2) / model.r)
        .sum();
    assert!(
        (information[(0, 0)] - expected).abs() < 1e-6 * expected,
        "{} vs {expected}",
        information[(0, 0)]
    );
    assert!(information[(1, 1)].abs() < 1e-9 * expected);
    assert!(cramer_rao_standard_deviations(&information)
        .iter()
        .all(|sd| sd.is_infinite()));

    // With an input, b is identifiable and both bounds are finite; more data, tighter bounds.
    let excited = |steps: usize| RecordedRun {
        inputs: (0..steps)
            .map(|t| SVector::<f64, 1>::new((t as f64 * 0.7).sin()))
            .collect(),
        measurements: vec![SVector::<f64, 1>::zeros(); steps],
    };
    let short = cramer_rao_standard_deviations(
        &parameter_information(&model, &excited(steps), &initial).unwrap(),
    );
    let long = cramer_rao_standard_deviations(
        &parameter_information(&model, &excited(4 * steps), &initial).unwrap(),
    );
    for j in 0..2 {
        assert!(short[j].is_finite() && short[j] > 0.0, "{short:?}");
        assert!(long[j] < short[j], "{long:?} vs {short:?}");
    }
}
