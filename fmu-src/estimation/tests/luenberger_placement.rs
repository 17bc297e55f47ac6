//! The Luenberger observer (002: §4): its error dynamics must have exactly the placed eigenvalues.

use crate::kalman_support;

use estimation::kalman::{discrete_poles, InitialEstimate};
use estimation::luenberger::{
    ackermann_observer_gain, characteristic_coefficients, DesignBlock, LuenbergerObserver,
    ObserverDesign,
};
use estimation::Estimator;
use kalman_support::LinearModel;
use nalgebra::{Complex, DMatrix, DVector, SMatrix, SVector, Vector1};

fn sorted(mut values: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
    values.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
    values
}

fn assert_same_eigenvalues(actual: Vec<Complex<f64>>, expected: Vec<Complex<f64>>, tolerance: f64) {
    let (actual, expected) = (sorted(actual), sorted(expected));
    assert_eq!(actual.len(), expected.len());
    for (a, e) in actual.iter().zip(&expected) {
        assert!(
            (a - e).norm() < tolerance,
            "eigenvalues {actual:?}, placed {expected:?}"
        );
    }
}

#[test]
fn characteristic_polynomial_of_known_poles() {
    // (s + 1)(s + 2)(s + 3) = s³ + 6 s² + 11 s + 6.
    let c = characteristic_coefficients(&[-1.0, -2.0, -3.0].map(|p| Complex::new(p, 0.0))).unwrap();
    assert_eq!(c, vec![6.0, 11.0, 6.0]);
    // (s - (-1 + 2i))(s - (-1 - 2i)) = s² + 2 s + 5.
    let c =
        characteristic_coefficients(&[Complex::new(-1.0, 2.0), Complex::new(-1.0, -2.0)]).unwrap();
    assert!((c[0] - 5.0).abs() < 1e-15 && (c[1] - 2.0).abs() < 1e-15);
    assert!(
        characteristic_coefficients(&[Complex::new(-1.0, 2.0), Complex::new(-1.0, 1.0)])
            .unwrap_err()
            .to_string()
            .contains("conjugate")
    );
}

#[test]
fn ackermann_places_the_seed_002_oscillator_poles() {
    // The damped oscillator of 002 §6, ẍ + r ẋ + w0² x = 0, observed through the velocity,
    // with observer poles five times the system's eigenvalues (002: "l = 5 · eig(A)").
    let (w0, r) = (2.0_f64, 0.4_f64);
    let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w0 * w0, -r]);
    let c = DVector::from_vec(vec![0.0, 1.0]);
    let system_poles: Vec<Complex<f64>> = a.complex_eigenvalues().iter().copied().collect();
    let poles: Vec<Complex<f64>> = system_poles.iter().map(|p| p * 5.0).collect();
    let l = ackermann_observer_gain(&a, &c, &poles).unwrap();
    let error_matrix = &a - &l * c.transpose();
    assert_same_eigenvalues(
        error_matrix.complex_eigenvalues().iter().copied().collect(),
        poles,
        1e-10,
    );
    // By hand: A - l cᵀ = [[0, 1 - l1], [-w0², -r - l2]] has the characteristic polynomial
    // s² + (r + l2) s + w0² (1 - l1); the placed one is s² + 5 r s + 25 w0².
    assert!((l[1] - 4.0 * r).abs() < 1e-12);
    assert!((l[0] - (1.0 - 25.0)).abs() < 1e-12);
}

#[test]
fn an_unobservable_output_is_refused() {
    let a = DMatrix::from_row_slice(2, 2, &[0.5, 0.0, 0.0, 0.7]);
    let c = DVector::from_vec(vec![1.0, 0.0]);
    let poles = [Complex::new(0.1, 0.0), Complex::new(0.2, 0.0)];
    let err = ackermann_observer_gain(&a, &c, &poles).unwrap_err();
    assert!(err.to_string().contains("not observable"), "{err}");
}

/// Two decoupled subsystems (2 + 2 states), one output each, sampled at 10 ms: the structure of
/// model A linearised about straight driving.
fn block_model() -> LinearModel<4, 2, 1> {
    let t = 0.01;
    let a = SMatrix::<f64, 4, 4>::new(
        1.0 - 3.0 * t,
        -18.0 * t,
        0.0,
        0.0, //
        0.4 * t,
        1.0 - 5.0 * t,
        0.0,
        0.0, //
        0.0,
        0.0,
        1.0 - 0.1 * t,
        2.0 * t, //
        0.0,
        0.0,
        30.0 * t,
        1.0 - 120.0 * t,
    );
    LinearModel {
        a,
        b: SMatrix::<f64, 4, 1>::new(0.0, 0.1, 0.0, 0.3),
        c: SMatrix::<f64, 2, 4>::new(0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        d: SMatrix::zeros(),
        q: SMatrix::identity() * 1e-6,
        r: SMatrix::identity() * 1e-4,
    }
}

fn initial() -> InitialEstimate<4> {
    InitialEstimate::diagonal(SVector::<f64, 4>::zeros(), SVector::<f64, 4>::repeat(1.0))
}

#[test]
fn block_design_places_every_eigenvalue_of_the_error_dynamics() {
    let t = 0.01;
    let lateral = discrete_poles([Complex::new(-20.0, 5.0), Complex::new(-20.0, -5.0)], t);
    let longitudinal = discrete_poles([Complex::new(-40.0, 0.0), Complex::new(-300.0, 0.0)], t);
    let design = ObserverDesign {
        blocks: vec![
            DesignBlock {
                states: vec![0, 1],
                output: 0,
                poles: lateral.to_vec(),
            },
            DesignBlock {
                states: vec![2, 3],
                output: 1,
                poles: longitudinal.to_vec(),
            },
        ],
        open_loop: Vec::new(),
        placement_state: Vec::new(),
    };
    let observer = LuenbergerObserver::new(
        block_model(),
        &SVector::zeros(),
        &Vector1::zeros(),
        &design,
        &initial(),
    )
    .unwrap();
    let error_matrix = observer.error_dynamics();
    let eigenvalues: Vec<Complex<f64>> = DMatrix::from_iterator(4, 4, error_matrix.iter().copied())
        .complex_eigenvalues()
        .iter()
        .copied()
        .collect();
    assert_same_eigenvalues(eigenvalues, design.poles(), 1e-10);
    // The a-priori error map A (I - L C) has the same spectrum.
    let model = block_model();
    let prior_map = model.a * (SMatrix::<f64, 4, 4>::identity() - observer.gain() * model.c);
    let eigenvalues: Vec<Complex<f64>> = DMatrix::from_iterator(4, 4, prior_map.iter().copied())
        .complex_eigenvalues()
        .iter()
        .copied()
        .collect();
    assert_same_eigenvalues(eigenvalues, design.poles(), 1e-10);
}

#[test]
fn single_output_design_on_the_coupled_system() {
    // Couple the blocks; then only the seed's single-output design applies, and it must place
    // all four poles through output 1 alone.
    let mut model = block_model();
    model.a[(2, 1)] = 0.05;
    model.a[(1, 3)] = -0.02;
    let poles = vec![
        Complex::new(0.8, 0.1),
        Complex::new(0.8, -0.1),
        Complex::new(0.6, 0.0),
        Complex::new(0.3, 0.0),
    ];
    let blocks = ObserverDesign {
        blocks: vec![
            DesignBlock {
                states: vec![0, 1],
                output: 0,
                poles: poles[..2].to_vec(),
            },
            DesignBlock {
                states: vec![2, 3],
                output: 1,
                poles: poles[2..].to_vec(),
            },
        ],
        open_loop: Vec::new(),
        placement_state: Vec::new(),
    };
    let refused = LuenbergerObserver::new(
        model.clone(),
        &SVector::zeros(),
        &Vector1::zeros(),
        &blocks,
        &initial(),
    );
    assert!(refused.unwrap_err().to_string().contains("coupled"));
    let design = ObserverDesign::single_output(1, poles.clone());
    let observer = LuenbergerObserver::new(
        model,
        &SVector::zeros(),
        &Vector1::zeros(),
        &design,
        &initial(),
    )
    .unwrap();
    assert_eq!(observer.gain().column(0).amax(), 0.0);
    let e = observer.error_dynamics();
    let eigenvalues: Vec<Complex<f64>> = DMatrix::from_iterator(4, 4, e.iter().copied())
        .complex_eigenvalues()
        .iter()
        .copied()
        .collect();
    assert_same_eigenvalues(eigenvalues, poles, 1e-9);
}

#[test]
fn the_estimation_error_follows_the_placed_error_dynamics() {
    // Noise-free: e⁺(k+1) = (I - L C) A e⁺(k) exactly, so the observer converges to the truth.
    let model = block_model();
    let poles = [
        Complex::new(0.5, 0.2),
        Complex::new(0.5, -0.2),
        Complex::new(0.4, 0.0),
        Complex::new(0.2, 0.0),
    ];
    let design = ObserverDesign {
        blocks: vec![
            DesignBlock {
                states: vec![0, 1],
                output: 0,
                poles: poles[..2].to_vec(),
            },
            DesignBlock {
                states: vec![2, 3],
                output: 1,
                poles: poles[2..].to_vec(),
            },
        ],
        open_loop: Vec::new(),
        placement_state: Vec::new(),
    };
    let mut observer = LuenbergerObserver::new(
        model.clone(),
        &SVector::zeros(),
        &Vector1::zeros(),
        &design,
        &initial(),
    )
    .unwrap();
    let error_map = observer.error_dynamics();
    let mut truth = SVector::<f64, 4>::new(0.3, -0.1, 2.0, 0.5);
    let mut expected_error = truth - observer.state();
    for k in 0..40 {
        let u = Vector1::new((k as f64 * 0.3).sin());
        truth = model.a * truth + model.b * u;
        observer.predict(&u).unwrap();
        let y = model.c * truth;
        observer.update(&y, &u, &[true, true]).unwrap();
        expected_error = error_map * expected_error;
        let error = truth - observer.state();
        assert!(
            (error - expected_error).amax() < 1e-12,
            "step {k}: {error} vs {expected_error}"
        );
    }
    assert!(expected_error.amax() < 1e-6);
}

/// States left without feedback (`ObserverDesign::open_loop`): their gain rows are zero, the
/// error dynamics keep their own eigenvalues beside the placed ones, and the design is refused
/// where they are unstable or where a state is both in a block and open loop.
#[test]
fn open_loop_states_keep_their_own_dynamics() {
    let t = 0.01;
    let lateral = discrete_poles([Complex::new(-20.0, 5.0), Complex::new(-20.0, -5.0)], t);
    let design = ObserverDesign {
        blocks: vec![DesignBlock {
            states: vec![0, 1],
            output: 0,
            poles: lateral.to_vec(),
        }],
        open_loop: vec![2, 3],
        placement_state: Vec::new(),
    };
    let build = |model: LinearModel<4, 2, 1>, design: &ObserverDesign| {
        LuenbergerObserver::new(
            model,
            &SVector::zeros(),
            &Vector1::zeros(),
            design,
            &initial(),
        )
    };
    // block_model's second subsystem has a slowly growing mode (1.004); damp it
    let mut stable = block_model();
    stable.a[(2, 2)] = 1.0 - 5.0 * t;
    let observer = build(stable.clone(), &design).unwrap();
    assert_eq!(observer.gain().fixed_rows::<2>(2).amax(), 0.0);
    let eigenvalues: Vec<Complex<f64>> =
        DMatrix::from_iterator(4, 4, observer.error_dynamics().iter().copied())
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect();
    let a = stable.a;
    let own: Vec<Complex<f64>> = DMatrix::from_fn(2, 2, |i, j| a[(i + 2, j + 2)])
        .complex_eigenvalues()
        .iter()
        .copied()
        .collect();
    assert_same_eigenvalues(eigenvalues, [lateral.to_vec(), own].concat(), 1e-10);

    let err = build(block_model(), &design).unwrap_err();
    assert!(err.to_string().contains("without feedback"), "{err}");

    let overlapping = ObserverDesign {
        open_loop: vec![1, 2, 3],
        placement_state: Vec::new(),
        ..design
    };
    let err = build(stable, &overlapping).unwrap_err();
    assert!(err.to_string().contains("also in a block"), "{err}");
}

/// A state `x` seen by the output only after a first-order lag `x'`, weighted by a third state
/// `k` (the grip model's structure: `y = k x' + (1 - k) x`, its relaxation factor `k`):
/// `x⁺ = a x`, `x'⁺ = x' + s (x - x')`, `k⁺ = 1 + d (k - 1)` (a Gauss-Markov step about 1).
#[derive(Debug, Clone)]
struct LaggedOutput {
    decay: f64,
    lag_share: f64,
}

const WEIGHT_DECAY: f64 = 0.999;

impl estimation::StateSpaceModel<3, 1, 1> for LaggedOutput {
    fn state_names(&self) -> [&'static str; 3] {
        ["x", "lagged x", "lag weight"]
    }
    fn measurement_names(&self) -> [&'static str; 1] {
        ["y"]
    }
    fn transition(&self, state: &SVector<f64, 3>, _: &Vector1<f64>) -> SVector<f64, 3> {
        let lagged = state[1] + self.lag_share * (state[0] - state[1]);
        let weight = 1.0 + WEIGHT_DECAY * (state[2] - 1.0);
        SVector::<f64, 3>::new(self.decay * state[0], lagged, weight)
    }
    fn transition_jacobian(&self, _: &SVector<f64, 3>, _: &Vector1<f64>) -> SMatrix<f64, 3, 3> {
        let s = self.lag_share;
        SMatrix::<f64, 3, 3>::new(
            self.decay,
            0.0,
            0.0,
            s,
            1.0 - s,
            0.0,
            0.0,
            0.0,
            WEIGHT_DECAY,
        )
    }
    fn transition_input_jacobian(
        &self,
        _: &SVector<f64, 3>,
        _: &Vector1<f64>,
    ) -> SMatrix<f64, 3, 1> {
        SMatrix::zeros()
    }
    fn measurement(&self, state: &SVector<f64, 3>, _: &Vector1<f64>) -> Vector1<f64> {
        Vector1::new(state[2] * state[1] + (1.0 - state[2]) * state[0])
    }
    fn measurement_jacobian(
        &self,
        state: &SVector<f64, 3>,
        _: &Vector1<f64>,
    ) -> SMatrix<f64, 1, 3> {
        SMatrix::<f64, 1, 3>::new(1.0 - state[2], state[2], state[1] - state[0])
    }
    fn measurement_input_jacobian(
        &self,
        _: &SVector<f64, 3>,
        _: &Vector1<f64>,
    ) -> SMatrix<f64, 1, 1> {
        SMatrix::zeros()
    }
    fn process_noise(&self) -> SMatrix<f64, 3, 3> {
        SMatrix::<f64, 3, 3>::from_diagonal_element(1e-6)
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        SMatrix::<f64, 1, 1>::new(1e-4)
    }
}

/// `ObserverDesign::placement_state`: the gain is the one placed on the linearisation at the
/// placement state (here the lag weight 0, the output seeing `x` directly), the observer keeps
/// the operating point's own linearisation for its covariance, and the error map there is
/// stable with that gain. Where it would not be, the gain is placed at the operating point
/// instead; an index outside the state is refused.
#[test]
fn a_placement_state_moves_only_the_point_the_gain_is_placed_at() {
    let model = LaggedOutput {
        decay: 0.99,
        lag_share: 0.36,
    };
    let design = |pole: f64, placement_state: Vec<(usize, f64)>| ObserverDesign {
        blocks: vec![DesignBlock {
            states: vec![0],
            output: 0,
            poles: vec![Complex::new(pole, 0.0)],
        }],
        open_loop: vec![1, 2],
        placement_state,
    };
    let start = InitialEstimate::diagonal(SVector::<f64, 3>::zeros(), SVector::repeat(1.0));
    let build = |at: [f64; 3], design: &ObserverDesign| {
        LuenbergerObserver::new(
            model.clone(),
            &SVector::from(at),
            &Vector1::zeros(),
            design,
            &start,
        )
    };
    let lagged_point = [0.0, 0.0, 1.0];
    let quasi_static_point = [0.0, 0.0, 0.0];
    let placed = build(lagged_point, &design(0.67, vec![(2, 0.0)])).unwrap();
    let at_placement = build(quasi_static_point, &design(0.67, Vec::new())).unwrap();
    let at_operating_point = build(lagged_point, &design(0.67, Vec::new())).unwrap();
    assert_eq!(placed.gain(), at_placement.gain());
    // the quasi-static gain: (a - z) / a of the output's direct view of x
    assert!((placed.gain()[(0, 0)] - (0.99 - 0.67) / 0.99).abs() < 1e-12);
    // placed through the lag (C A sees x by s = 0.36 only), the gain is 1 / 0.36 times larger
    let ratio = at_operating_point.gain()[(0, 0)] / placed.gain()[(0, 0)];
    assert!((ratio - 0.99 / 0.36).abs() < 1e-9, "{ratio}");
    assert_eq!(placed.linearisation().state, SVector::from(lagged_point));
    let radius = |observer: &LuenbergerObserver<LaggedOutput, 3, 1, 1>| {
        DMatrix::from_iterator(3, 3, observer.error_dynamics().iter().copied())
            .complex_eigenvalues()
            .iter()
            .fold(0.0f64, |m, z| m.max(z.norm()))
    };
    assert!(radius(&placed) < 1.0, "{}", radius(&placed));
    // At the lag weight 1.55 the output sees x by only (1 - k) a + k s = 0.0135, so the gain
    // placed there is 24, and the error map is unstable with it (at the placement state and at
    // the operating point: trace -6.9): the observer places its gain at the operating point.
    let unstable = build(lagged_point, &design(0.67, vec![(2, 1.55)])).unwrap();
    assert_eq!(unstable.gain(), at_operating_point.gain());
    let err = build(lagged_point, &design(0.67, vec![(3, 0.0)])).unwrap_err();
    assert!(err.to_string().contains("placement state 3"), "{err}");
}
