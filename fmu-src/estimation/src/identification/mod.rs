//! EM parameter identification with the particle filter and the reweighting smoother
//! (003: §2.2, 2.76-2.78, §3.1, 3.3-3.12), generic over [`StateSpaceModel`] and a parameter
//! vector ([`Parameterised`]).
//!
//! One iteration follows the seed's "ganz Schritt Verfahren" (003: §3.1, EM-Identifikation):
//! the parameters are identified one at a time; for each one the particle method runs again
//! with the current parameters (E-step: filter, then smoother), and the intermediate quantity
//! `Q(θ, θ_m)` is maximised over that one parameter with the others fixed (M-step). After a sweep
//! over all parameters the change is checked against a tolerance.
//!
//! `Q` is the seed's `I_2` (003: 2.77, 3.3): the expected transition log-density under the joint
//! smoothing distribution of neighbouring particles, with the pair weights
//! `φ_t^i w̃_t^l p_θm(x_{t+1}^i|x_t^l)` of the smoother. The seed writes the Gaussian weight as
//! `exp[+Ψ]` in 3.8-3.12; the density it stands for (3.4-3.6) is `exp[-Ψ]`, which is what is
//! used here. The seed also subtracts a process-noise sample `w_t` inside the residual; here the
//! noise is the random variable of the density (zero mean), as in 2.24. When the measurement
//! function or its noise depend on the parameters, `I_3` (003: 2.78) is added (for model C they
//! do not, so `Q = I_2` exactly as in 003: 3.3).
//!
//! Speed: `Q` is quadratic in the transition mean, so the smoother hands over the pair moments
//! per source particle ([`crate::smoother::PairMoments`]) and one evaluation of `Q` costs one
//! transition per particle and sample (`O(NT)`) instead of `O(N²T)`; evaluations run in parallel
//! over samples with a fixed summation order (bit-deterministic). The E-steps use common random
//! numbers (the same filter seed every time) so that the EM map is a deterministic function of
//! the parameters and the iteration settles instead of jittering with Monte-Carlo noise.

pub mod accelerated;

use nalgebra::{SMatrix, SVector};
use rayon::prelude::*;

use crate::kalman::{ExtendedKalmanFilter, InitialEstimate};
use crate::model::StateSpaceModel;
use crate::particle::{
    filter_run, masked_covariance, used_rows, ParticleFilter, ParticleFilterConfig,
    ParticleFilterError, ParticleHistory, RecordedRun,
};
use crate::smoother::{smooth, SmoothedRun, SmootherError, SmootherWorkspace};
use crate::Estimator;

/// A model with a vector of `P` identifiable parameters.
pub trait Parameterised<const P: usize>: Sized {
    /// Names of the parameters, in order.
    fn parameter_names(&self) -> [&'static str; P];

    /// The current parameter vector.
    fn parameters(&self) -> SVector<f64, P>;

    /// The same model with other parameters; `None` when they are outside the model's valid
    /// range (the M-step then treats them as infinitely unlikely).
    fn with_parameters(&self, parameters: &SVector<f64, P>) -> Option<Self>;

    /// Whether the measurement function or its noise depend on the parameters (then `I_3`,
    /// 003: 2.78, enters the M-step). Models whose measurement is parameter-free say `false`
    /// and save the work.
    fn measurement_depends_on_parameters(&self) -> bool {
        true
    }
}

/// Settings of the scalar minimiser of the M-step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineSearchConfig {
    /// First trial step, as a fraction of the parameter's magnitude.
    pub initial_step: f64,
    /// Relative tolerance on the parameter.
    pub tolerance: f64,
    /// Most objective evaluations per one-parameter search.
    pub max_evaluations: usize,
}

impl Default for LineSearchConfig {
    fn default() -> Self {
        Self {
            initial_step: 0.02,
            tolerance: 1e-7,
            max_evaluations: 80,
        }
    }
}

/// How E-steps and one-parameter M-steps alternate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EmSchedule {
    /// The seed's: before identifying each parameter the particle method runs again with the
    /// parameters updated so far (003: §3.1, "Nach jedem Update des Parametervektor muss die
    /// Partikel-Methode ... einmal durchlaufen"). One iteration = `P` E-steps.
    #[default]
    ParameterWise,
    /// One E-step per iteration, then the M-step maximises `Q` fully with
    /// [`minimise_powell`] (line searches one direction at a time, starting along the parameter
    /// axes; up to `max_sweeps` sweeps, until a sweep changes less than a tenth of the
    /// tolerance). Converges in far fewer E-steps when parameters are correlated.
    FullMaximisation { max_sweeps: usize },
}

/// Settings of the EM identification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmConfig<const N: usize> {
    /// The particle filter of the E-step (particle count, resampling, seed, proposal: the seed
    /// uses the bootstrap proposal, 003: 2.58; the seed-003 reproduction, `harness::seed003` in
    /// the studies crate, defaults to the linearised optimal one).
    pub filter: ParticleFilterConfig,
    /// Prior of the initial state.
    pub initial_state: SVector<f64, N>,
    pub initial_covariance: SMatrix<f64, N, N>,
    /// Stop when no parameter changed by more than this fraction of its value in one sweep.
    pub tolerance: f64,
    /// Most sweeps over all parameters.
    pub max_iterations: usize,
    pub line_search: LineSearchConfig,
    /// `false` (default): every E-step uses the same filter seed (common random numbers).
    pub fresh_random_numbers: bool,
    pub schedule: EmSchedule,
}

/// Why the identification cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdentificationError {
    #[error("the starting parameters are outside the model's valid range: {0:?}")]
    InvalidStart(Vec<f64>),
    #[error("the recorded run needs at least two samples, got {0}")]
    TooShort(usize),
    #[error("particle filter: {0}")]
    Filter(#[from] ParticleFilterError),
    #[error("smoother: {0}")]
    Smoother(#[from] SmootherError),
    #[error("Fisher information: {0}")]
    Information(String),
}

/// One single-parameter update of the EM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmUpdate<const P: usize> {
    /// Sweep number, from 1.
    pub iteration: usize,
    /// Which parameter was identified (`P`: all at once, [`EmSchedule::FullMaximisation`]).
    pub parameter_index: usize,
    /// The parameter vector after the update.
    pub parameters: SVector<f64, P>,
    /// `-Q(θ, θ_m)` before and after the update (lower is better).
    pub objective_before: f64,
    pub objective_after: f64,
    /// Objective evaluations of the line search.
    pub evaluations: usize,
    /// Effective sample size of the smoothed weights, averaged over the samples.
    pub mean_smoothed_ess: f64,
}

/// Result of the EM identification with its full history.
#[derive(Debug, Clone, PartialEq)]
pub struct EmResult<const P: usize> {
    pub parameter_names: [&'static str; P],
    /// The identified parameters.
    pub parameters: SVector<f64, P>,
    /// The parameter vector at the start and after every sweep (003: fig. 3.11 per iteration).
    pub iterations: Vec<SVector<f64, P>>,
    /// Every single-parameter update, in order.
    pub updates: Vec<EmUpdate<P>>,
    /// Whether the change fell below the tolerance (otherwise `max_iterations` ended it).
    pub converged: bool,
}

/// The E-step: filter and smoother on `model` over `run`, the smoother with pair moments.
pub fn expectation_step<Model, const N: usize, const M: usize, const U: usize>(
    model: &Model,
    run: &RecordedRun<M, U>,
    filter: ParticleFilterConfig,
    initial_state: SVector<f64, N>,
    initial_covariance: SMatrix<f64, N, N>,
    workspace: &mut SmootherWorkspace<N>,
) -> Result<(ParticleHistory<N>, SmoothedRun<N>), IdentificationError>
where
    Model: StateSpaceModel<N, M, U> + Clone + Sync,
{
    let mut particle_filter =
        ParticleFilter::new(model.clone(), filter, initial_state, initial_covariance)?;
    let history = filter_run(&mut particle_filter, run);
    let smoothed = smooth(model, &history, run, true, workspace)?;
    Ok((history, smoothed))
}

/// Pair moments below this mass are skipped in `Q` (their contribution is below rounding).
const MASS_FLOOR: f64 = 1e-13;

/// `-Q(θ, θ_m)` of 003: 2.77/3.3 (plus `I_3`, 2.78, when the measurement depends on `θ`) for a
/// candidate model, from an E-step made with `θ_m`. `per_sample` is scratch of length `T`.
pub fn negative_intermediate_quantity<Model, const N: usize, const M: usize, const U: usize>(
    candidate: &Model,
    include_measurement_term: bool,
    history: &ParticleHistory<N>,
    smoothed: &SmoothedRun<N>,
    run: &RecordedRun<M, U>,
    per_sample: &mut [f64],
) -> f64
where
    Model: StateSpaceModel<N, M, U> + Sync,
{
    let steps = history.len();
    let Some(noise_cholesky) = candidate.process_noise().cholesky() else {
        return f64::INFINITY;
    };
    // G = Lᵀ Ξ_θ⁻¹ L maps the smoother's whitened residuals to the candidate's metric.
    let factor = smoothed.process_noise_factor;
    let metric = factor.transpose() * noise_cholesky.solve(&factor);
    let log_det = 2.0
        * noise_cholesky
            .l_dirty()
            .diagonal()
            .iter()
            .map(|d| d.ln())
            .sum::<f64>();
    let normalisation = 0.5 * (log_det + N as f64 * (2.0 * std::f64::consts::PI).ln());
    let measurement_noise = candidate.measurement_noise();
    per_sample[..steps]
        .par_iter_mut()
        .enumerate()
        .for_each(|(t, total)| {
            let mut value = 0.0;
            if t + 1 < steps {
                let moments = smoothed.pair_moments_at(t);
                let mut mass = 0.0;
                for (moment, particle) in moments.iter().zip(history.particles_at(t)) {
                    if moment.mass < MASS_FLOOR {
                        continue;
                    }
                    let shift = factor
                        .solve_lower_triangular(
                            &(candidate.transition(particle, &run.inputs[t]) - moment.anchor),
                        )
                        .unwrap_or_else(|| SVector::repeat(f64::INFINITY));
                    let metric_shift = metric * shift;
                    let quadratic = metric.component_mul(&moment.second).sum()
                        - 2.0 * moment.first.dot(&metric_shift)
                        + moment.mass * shift.dot(&metric_shift);
                    value += 0.5 * quadratic;
                    mass += moment.mass;
                }
                value += mass * normalisation;
            }
            if include_measurement_term {
                value += negative_measurement_log_likelihood(
                    candidate,
                    &measurement_noise,
                    history.particles_at(t),
                    smoothed.weights_at(t),
                    &run.measurements[t],
                    &run.inputs[t],
                );
            }
            *total = if value.is_nan() { f64::INFINITY } else { value };
        });
    // Fixed-order sum: the same bits whatever the thread split.
    per_sample[..steps].iter().sum()
}

/// `-Σ_i w̃_{t|T}^i log N(y_t; h_θ(x_t^i, u_t), R_θ)` over the rows present (003: 2.78).
fn negative_measurement_log_likelihood<Model, const N: usize, const M: usize, const U: usize>(
    candidate: &Model,
    measurement_noise: &SMatrix<f64, M, M>,
    particles: &[SVector<f64, N>],
    weights: &[f64],
    measurement: &SVector<f64, M>,
    input: &SVector<f64, U>,
) -> f64
where
    Model: StateSpaceModel<N, M, U>,
{
    let used = used_rows(measurement, &[true; M]);
    let rows = used.iter().filter(|&&u| u).count();
    if rows == 0 {
        return 0.0;
    }
    let Some(cholesky) = masked_covariance(measurement_noise, &used).cholesky() else {
        return f64::INFINITY;
    };
    let log_det: f64 = 2.0
        * cholesky
            .l_dirty()
            .diagonal()
            .iter()
            .map(|d| d.ln())
            .sum::<f64>();
    let normalisation = 0.5 * (log_det + rows as f64 * (2.0 * std::f64::consts::PI).ln());
    let mut value = 0.0;
    for (particle, &weight) in particles.iter().zip(weights) {
        if weight < MASS_FLOOR {
            continue;
        }
        let mut residual = measurement - candidate.measurement(particle, input);
        for (row, &flag) in used.iter().enumerate() {
            if !flag {
                residual[row] = 0.0;
            }
        }
        value += weight * (0.5 * residual.dot(&cholesky.solve(&residual)) + normalisation);
    }
    value
}

/// Minimises a scalar function near `start`: bracket the minimum by expanding steps, then
/// Brent's method (parabolic interpolation with golden-section fall-back). Returns the best
/// point, its value and the number of evaluations. A non-finite value counts as `+∞`.
pub fn minimise_scalar(
    objective: impl FnMut(f64) -> f64,
    start: f64,
    config: &LineSearchConfig,
) -> (f64, f64, usize) {
    let step = config.initial_step * start.abs().max(1e-6);
    minimise_from(objective, start, step, 1e-12, config)
}

/// [`minimise_scalar`] with an explicit first step and absolute tolerance.
fn minimise_from(
    mut objective: impl FnMut(f64) -> f64,
    start: f64,
    step: f64,
    absolute_tolerance: f64,
    config: &LineSearchConfig,
) -> (f64, f64, usize) {
    const GOLDEN: f64 = 1.618_033_988_749_895;
    const GOLDEN_SECTION: f64 = 0.381_966_011_250_105;
    let evaluations = std::cell::Cell::new(0_usize);
    let mut f = |x: f64| {
        evaluations.set(evaluations.get() + 1);
        let value = objective(x);
        if value.is_nan() {
            f64::INFINITY
        } else {
            value
        }
    };

    // Bracket: a, b, c with f(b) <= f(a), f(b) <= f(c).
    let (mut a, mut fa) = (start, f(start));
    let (mut b, mut fb) = (start + step, f(start + step));
    if fb > fa {
        std::mem::swap(&mut a, &mut b);
        std::mem::swap(&mut fa, &mut fb);
    }
    let mut c = b + GOLDEN * (b - a);
    let mut fc = f(c);
    while fc < fb && evaluations.get() < config.max_evaluations {
        a = b;
        fa = fb;
        b = c;
        fb = fc;
        c = b + GOLDEN * (b - a);
        fc = f(c);
    }
    let _ = fa;
    if fc < fb {
        return (c, fc, evaluations.get());
    }

    // Brent's method on [min(a,c), max(a,c)] with b as the best point so far.
    let (mut low, mut high) = if a < c { (a, c) } else { (c, a) };
    let (mut x, mut w, mut v) = (b, b, b);
    let (mut fx, mut fw, mut fv) = (fb, fb, fb);
    let mut d: f64 = 0.0;
    let mut e: f64 = 0.0;
    while evaluations.get() < config.max_evaluations {
        let middle = 0.5 * (low + high);
        let tol1 = config.tolerance * x.abs() + absolute_tolerance;
        let tol2 = 2.0 * tol1;
        if (x - middle).abs() <= tol2 - 0.5 * (high - low) {
            break;
        }
        let mut golden_step = true;
        if e.abs() > tol1 && fx.is_finite() && fw.is_finite() && fv.is_finite() {
            // Parabola through (v, fv), (w, fw), (x, fx).
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let previous = e;
            if p.abs() < (0.5 * q * previous).abs() && p > q * (low - x) && p < q * (high - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - low < tol2 || high - u < tol2 {
                    d = tol1.copysign(middle - x);
                }
                golden_step = false;
            }
        }
        if golden_step {
            e = if x >= middle { low - x } else { high - x };
            d = GOLDEN_SECTION * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                low = x;
            } else {
                high = x;
            }
            v = w;
            fv = fw;
            w = x;
            fw = fx;
            x = u;
            fx = fu;
        } else {
            if u < x {
                low = u;
            } else {
                high = u;
            }
            if fu <= fw || w == x {
                v = w;
                fv = fw;
                w = u;
                fw = fu;
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    (x, fx, evaluations.get())
}

/// Powell's conjugate-direction method (derivative-free): line minimisations along one
/// direction at a time, starting with the parameter axes (the seed's one-parameter-at-a-time
/// search is its first sweep); after each sweep the net move becomes a new direction, so a
/// quadratic objective with correlated parameters is minimised in about `P` sweeps instead of
/// the many zig-zag sweeps of pure coordinate search. Returns the minimiser, its value and the
/// evaluation count.
pub fn minimise_powell<const P: usize>(
    mut objective: impl FnMut(&SVector<f64, P>) -> f64,
    start: SVector<f64, P>,
    max_sweeps: usize,
    tolerance: f64,
    config: &LineSearchConfig,
) -> (SVector<f64, P>, f64, usize) {
    let mut evaluations = 1;
    let mut x = start;
    let mut fx = objective(&x);
    let mut directions: [SVector<f64, P>; P] = std::array::from_fn(|k| {
        let mut direction = SVector::<f64, P>::zeros();
        direction[k] = config.initial_step * start[k].abs().max(1e-6);
        direction
    });
    for _ in 0..max_sweeps {
        let (x_start, f_start) = (x, fx);
        let (mut largest_drop, mut largest_index) = (0.0, 0);
        for (k, direction) in directions.iter().enumerate() {
            let before = fx;
            let (alpha, value, used) =
                minimise_from(|a| objective(&(x + direction * a)), 0.0, 1.0, 1e-9, config);
            evaluations += used;
            if value < fx {
                x += direction * alpha;
                fx = value;
            }
            if before - fx > largest_drop {
                largest_drop = before - fx;
                largest_index = k;
            }
        }
        if largest_relative_change(&x, &x_start) < tolerance {
            break;
        }
        // Powell's test whether the net move is worth a new direction.
        let extrapolated = x * 2.0 - x_start;
        let f_extrapolated = objective(&extrapolated);
        evaluations += 1;
        if f_extrapolated < f_start {
            let t =
                2.0 * (f_start - 2.0 * fx + f_extrapolated) * (f_start - fx - largest_drop).powi(2)
                    - largest_drop * (f_start - f_extrapolated).powi(2);
            if t < 0.0 {
                let direction = x - x_start;
                let (alpha, value, used) =
                    minimise_from(|a| objective(&(x + direction * a)), 0.0, 1.0, 1e-9, config);
                evaluations += used;
                if value < fx {
                    x += direction * alpha;
                    fx = value;
                }
                directions[largest_index] = directions[P - 1];
                directions[P - 1] = direction;
            }
        }
    }
    (x, fx, evaluations)
}

/// `max_k |new_k - old_k| / |old_k|`.
fn largest_relative_change<const P: usize>(new: &SVector<f64, P>, old: &SVector<f64, P>) -> f64 {
    new.iter()
        .zip(old.iter())
        .map(|(new, old)| (new - old).abs() / old.abs().max(1e-12))
        .fold(0.0, f64::max)
}

/// The EM identification of 003: §3.1 (see the module text). `model` carries the starting
/// parameters `θ_0` and the noise covariances `Ξ`, `Θ` the identification assumes.
pub fn identify<Model, const N: usize, const M: usize, const U: usize, const P: usize>(
    model: &Model,
    run: &RecordedRun<M, U>,
    config: &EmConfig<N>,
) -> Result<EmResult<P>, IdentificationError>
where
    Model: StateSpaceModel<N, M, U> + Parameterised<P> + Clone + Sync,
{
    let steps = run.len();
    if steps < 2 {
        return Err(IdentificationError::TooShort(steps));
    }
    let mut theta = model.parameters();
    let mut current = model
        .with_parameters(&theta)
        .ok_or_else(|| IdentificationError::InvalidStart(theta.iter().copied().collect()))?;
    let include_measurement_term = model.measurement_depends_on_parameters();
    let mut workspace = SmootherWorkspace::new();
    let mut per_sample = vec![0.0; steps];
    let mut iterations = vec![theta];
    let mut updates = Vec::new();
    let mut converged = false;
    let mut e_steps: u64 = 0;
    for iteration in 1..=config.max_iterations {
        let before = theta;
        // The seed's schedule runs one E-step per parameter; the full one a single E-step per
        // iteration followed by a Powell maximisation of that E-step's Q.
        let (e_steps_this_iteration, sweeps) = match config.schedule {
            EmSchedule::ParameterWise => (P, 1),
            EmSchedule::FullMaximisation { max_sweeps } => (1, max_sweeps.max(1)),
        };
        for e_step_in_iteration in 0..e_steps_this_iteration {
            let mut filter = config.filter;
            if config.fresh_random_numbers {
                filter.seed = filter.seed.wrapping_add(e_steps);
            }
            e_steps += 1;
            let (history, smoothed) = expectation_step(
                &current,
                run,
                filter,
                config.initial_state,
                config.initial_covariance,
                &mut workspace,
            )?;
            let mean_smoothed_ess = (0..history.len())
                .map(|t| crate::particle::effective_sample_size(smoothed.weights_at(t)))
                .sum::<f64>()
                / history.len() as f64;
            if let EmSchedule::FullMaximisation { .. } = config.schedule {
                let objective = |candidate_theta: &SVector<f64, P>| match current
                    .with_parameters(candidate_theta)
                {
                    Some(candidate) => negative_intermediate_quantity(
                        &candidate,
                        include_measurement_term,
                        &history,
                        &smoothed,
                        run,
                        &mut per_sample,
                    ),
                    None => f64::INFINITY,
                };
                let mut objective = objective;
                let objective_before = objective(&theta);
                let (best, objective_after, evaluations) = minimise_powell(
                    &mut objective,
                    theta,
                    sweeps,
                    0.1 * config.tolerance,
                    &config.line_search,
                );
                if objective_after <= objective_before {
                    theta = best;
                    if let Some(updated) = current.with_parameters(&theta) {
                        current = updated;
                    }
                }
                updates.push(EmUpdate {
                    iteration,
                    parameter_index: P,
                    parameters: theta,
                    objective_before,
                    objective_after: objective_after.min(objective_before),
                    evaluations,
                    mean_smoothed_ess,
                });
                continue;
            }
            // Parameter-wise (the seed): the E-step's `Q` is maximised over one parameter.
            let index = e_step_in_iteration;
            let mut objective = |value: f64| {
                let mut candidate_theta = theta;
                candidate_theta[index] = value;
                match current.with_parameters(&candidate_theta) {
                    Some(candidate) => negative_intermediate_quantity(
                        &candidate,
                        include_measurement_term,
                        &history,
                        &smoothed,
                        run,
                        &mut per_sample,
                    ),
                    None => f64::INFINITY,
                }
            };
            let objective_before = objective(theta[index]);
            let (best, objective_after, evaluations) =
                minimise_scalar(&mut objective, theta[index], &config.line_search);
            if objective_after <= objective_before {
                theta[index] = best;
                if let Some(updated) = current.with_parameters(&theta) {
                    current = updated;
                }
            }
            updates.push(EmUpdate {
                iteration,
                parameter_index: index,
                parameters: theta,
                objective_before,
                objective_after: objective_after.min(objective_before),
                evaluations,
                mean_smoothed_ess,
            });
        }
        iterations.push(theta);
        if largest_relative_change(&theta, &before) < config.tolerance {
            converged = true;
            break;
        }
    }
    Ok(EmResult {
        parameter_names: model.parameter_names(),
        parameters: theta,
        iterations,
        updates,
        converged,
    })
}

/// One EKF innovation `e_t` with its covariance `S_t`.
type Innovation<const M: usize> = (SVector<f64, M>, SMatrix<f64, M, M>);

/// Innovations `e_t = y_t - h(x̂⁻_t)` and their covariances `S_t = H P⁻ Hᵀ + R` of an EKF run
/// over `run` (rows a sample lacks are zero in `e_t` and unit, uncorrelated in `S_t`, so they
/// carry no information).
fn innovation_sequence<Model, const N: usize, const M: usize, const U: usize>(
    model: Model,
    run: &RecordedRun<M, U>,
    initial: &InitialEstimate<N>,
) -> Result<Vec<Innovation<M>>, IdentificationError>
where
    Model: StateSpaceModel<N, M, U> + Clone,
{
    let measurement_noise = model.measurement_noise();
    let mut filter = ExtendedKalmanFilter::new(model.clone(), initial)
        .map_err(|error| IdentificationError::Information(error.0))?;
    let mut sequence = Vec::with_capacity(run.len().saturating_sub(1));
    for t in 1..run.len() {
        // A repaired step still leaves a finite estimate; its innovations count as they are.
        let _ = filter.predict(&run.inputs[t - 1]);
        let output_matrix = model.measurement_jacobian(filter.state(), &run.inputs[t]);
        let predicted_covariance =
            output_matrix * filter.covariance() * output_matrix.transpose() + measurement_noise;
        let report = filter
            .update(&run.measurements[t], &run.inputs[t], &[true; M])
            .unwrap_or_else(|_| *filter.last_report());
        sequence.push((
            report.innovation,
            masked_covariance(&predicted_covariance, &report.used),
        ));
    }
    Ok(sequence)
}

/// Fisher information of the parameters in a recorded run, for the model (parameters and
/// noise) that generated it: the prediction-error form of the Gaussian likelihood through the
/// EKF, `-log L(θ) = Σ_t ½ (e_tᵀ S_t⁻¹ e_t + log det S_t) + const`, whose expected curvature is
///
/// ```text
/// I_ab = Σ_t ∂e_tᵀ/∂θ_a S_t⁻¹ ∂e_t/∂θ_b + ½ tr(S_t⁻¹ ∂S_t/∂θ_a S_t⁻¹ ∂S_t/∂θ_b).
/// ```
///
/// Its inverse bounds the covariance of any unbiased estimate from these data (Cramér-Rao), so
/// it tells whether an identification error is the estimator's fault or the data's (how well
/// the input excites a parameter). The derivatives are central differences over whole EKF runs
/// (relative step 1e-5): they are derivatives of the filter recursion with respect to `θ`,
/// which no model provides analytically. The EKF needs a positive definite process noise; a
/// model that generated its data without process noise should carry a tiny one.
pub fn parameter_information<
    Model,
    const N: usize,
    const M: usize,
    const U: usize,
    const P: usize,
>(
    model: &Model,
    run: &RecordedRun<M, U>,
    initial: &InitialEstimate<N>,
) -> Result<SMatrix<f64, P, P>, IdentificationError>
where
    Model: StateSpaceModel<N, M, U> + Parameterised<P> + Clone,
{
    const RELATIVE_STEP: f64 = 1e-5;
    let theta = model.parameters();
    let base = innovation_sequence(model.clone(), run, initial)?;
    let perturbed = |index: usize, sign: f64| {
        let step = RELATIVE_STEP * theta[index].abs().max(1e-8);
        let mut shifted = theta;
        shifted[index] += sign * step;
        let candidate = model.with_parameters(&shifted).ok_or_else(|| {
            IdentificationError::Information(format!(
                "parameter {} = {} is on the edge of the model's valid range",
                model.parameter_names()[index],
                theta[index]
            ))
        })?;
        innovation_sequence(candidate, run, initial).map(|sequence| (sequence, step))
    };
    let mut derivatives: Vec<Vec<Innovation<M>>> = Vec::with_capacity(P);
    for index in 0..P {
        let (plus, step) = perturbed(index, 1.0)?;
        let (minus, _) = perturbed(index, -1.0)?;
        derivatives.push(
            plus.iter()
                .zip(&minus)
                .map(|((e_plus, s_plus), (e_minus, s_minus))| {
                    (
                        (e_plus - e_minus) / (2.0 * step),
                        (s_plus - s_minus) / (2.0 * step),
                    )
                })
                .collect(),
        );
    }
    let mut information = SMatrix::<f64, P, P>::zeros();
    for (t, (_, covariance)) in base.iter().enumerate() {
        let Some(inverse) = covariance.try_inverse() else {
            continue;
        };
        for a in 0..P {
            let (de_a, ds_a) = &derivatives[a][t];
            let weighted_a = inverse * de_a;
            let scaled_a = inverse * ds_a;
            for b in a..P {
                let (de_b, ds_b) = &derivatives[b][t];
                let value = weighted_a.dot(de_b) + 0.5 * (scaled_a * inverse * ds_b).trace();
                information[(a, b)] += value;
                if a != b {
                    information[(b, a)] += value;
                }
            }
        }
    }
    Ok(information)
}

/// Cramér-Rao standard deviations `sqrt(diag(I⁻¹))` from a Fisher information; infinite for
/// every parameter when the information is singular (some combination is not identifiable).
pub fn cramer_rao_standard_deviations<const P: usize>(
    information: &SMatrix<f64, P, P>,
) -> SVector<f64, P> {
    match information.cholesky() {
        Some(cholesky) => cholesky.inverse().diagonal().map(f64::sqrt),
        None => SVector::repeat(f64::INFINITY),
    }
}
