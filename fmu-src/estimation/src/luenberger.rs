//! Discrete Luenberger observer with the gain placed by the Ackermann formula (002: §4).
//!
//! The seed derives the observer in continuous time for one output: `l = p̂(A) O⁻¹ eₙ`, where
//! `p̂` is the desired characteristic polynomial, `O = [cᵀ; cᵀA; …; cᵀAⁿ⁻¹]` the observability
//! matrix and `eₙ` the last unit vector (the seed's `sᵀ` is the last row of `O⁻¹`, 002: "ACKERMANN-
//! Formel"). Here the gain is placed on the discrete linearisation `x(k+1) = A x(k) + B u(k)`,
//! `y = C x + D u` about an operating point (as the LKF's), and the observer runs in
//! predictor/corrector form on the model itself, the extended Luenberger observer (M. Zeitz,
//! "The extended Luenberger observer for nonlinear systems", Systems & Control Letters 9, 1987):
//!
//! `x̂⁻(k+1) = f(x̂⁺(k), u(k))`,  `x̂⁺(k+1) = x̂⁻(k+1) + L (y(k+1) - h(x̂⁻(k+1), u(k+1)))`.
//!
//! For a linear model `f` and `h` are the linearisation (the seed's observer, to rounding); near
//! the operating point the a-posteriori error obeys `e⁺(k+1) = (I - L C) A e⁺(k) =
//! (A - L C A) e⁺(k)`, so the gain is placed for the pair `(A, C A)`; the a-priori error map
//! `A (I - L C)` has the same eigenvalues. The requested poles are discrete (inside the unit
//! circle); see [`crate::kalman::discrete_poles`] to map continuous poles. Why the model and not
//! its linearisation: a linearisation errs away from its operating point, and the error enters the
//! estimate as a bias the gain only shrinks; gain scheduling moves the operating point, but near
//! the tyres' limit the linearisation is open-loop unstable and is not taken, so on a slow ramp to
//! the limit the observer ran on a linearisation of lower lateral acceleration; with the gyro in
//! none of its blocks then, its yaw rate ran 66 % above the gyro's (measured on the mismatch
//! campaigns, fmu-src/estimation/README.md, "Luenberger observer").
//!
//! Several outputs (our decision; the seed covers only one): the state is split into blocks, each
//! observed through one output row. Where the blocks are decoupled in `A` and in the chosen rows
//! of `C A` (checked, relative tolerance 1e-12), the error matrix is block-diagonal and its
//! eigenvalues are exactly the union of the per-block poles ([`observer_gain`]). Where they are
//! coupled, each block's poles are placed on its own part and the gain is taken only if the whole
//! error map is stable ([`scheduled_observer_gain`]), the placed poles then holding up to the
//! coupling. Model A's default design observes `vy` through the lateral acceleration, `r` through
//! the yaw rate and (vx, ωF, ωR) through the front wheel speed
//! ([`crate::models::single_track::SingleTrackEstimationModel::default_observer_design`]). A
//! single block with all states is the seed's single-output design. States no output observes
//! as a block of their own may be left without feedback ([`ObserverDesign::open_loop`]) where
//! their own dynamics are stable: model B's `ay`, which its model computes from the tyre forces
//! ([`crate::models::two_track::TwoTrackEstimationModel::default_observer_design`]), and the
//! grip model's grip factors and transient slip angles. A design may place its gain at another
//! point than the one it runs at ([`ObserverDesign::placement_state`]): the grip model's at
//! the relaxation factor 0, the quasi-static tyre, where its gain is model A's.
//!
//! Numerics: with a short sample time `A ≈ I`, so the rows `cᵀAʲ` of the observability matrix are
//! nearly equal. Ackermann is applied instead to `Ã = (A - I)/h` with poles `(zᵢ - 1)/h`
//! (`h = max|A - I|`), which places exactly the same eigenvalues because
//! `A - l c̃ᵀ = I + h (Ã - (l/h) c̃ᵀ)`, and is well conditioned.
//!
//! The observer also propagates the covariance of its estimation error for its fixed gain
//! (Joseph form, valid for any gain), so it reports an uncertainty and NIS like the filters.
//! A skipped measurement row contributes nothing to that step (its gain column is not applied).

use nalgebra::{Complex, DMatrix, DVector, SMatrix, SVector};

use crate::kalman::linearised::{restored_linearisation, save_operating_point};
use crate::kalman::{
    discrete_poles, finite_or_restore, joseph_update, InitialEstimate, LinearisedModel,
    SettingsError,
};
use crate::linalg::{check_covariance, symmetrize};
use crate::running::Restored;
use crate::snapshot::{read_gaussian, save_gaussian, SnapshotError, SnapshotSink, SnapshotSource};
use crate::{Estimator, FilterIssue, MeasurementMask, StateSpaceModel, UpdateReport};

/// One block of the observer design: these states, observed through this output row, get
/// these (discrete) error-dynamics poles.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignBlock {
    /// State indices of the block.
    pub states: Vec<usize>,
    /// The measurement row whose innovation drives this block.
    pub output: usize,
    /// Desired discrete poles, one per state of the block; complex ones in conjugate pairs.
    pub poles: Vec<Complex<f64>>,
}

impl DesignBlock {
    /// A block with real continuous-time poles `continuous` (1/s), mapped to discrete ones for
    /// `sample_time` by [`discrete_poles`].
    pub fn real_poles(
        states: Vec<usize>,
        output: usize,
        continuous: &[f64],
        sample_time: f64,
    ) -> Self {
        let poles = continuous
            .iter()
            .map(|&pole| discrete_poles([Complex::new(pole, 0.0)], sample_time)[0])
            .collect();
        Self {
            states,
            output,
            poles,
        }
    }
}

/// How the observer gain is placed: the blocks and the open-loop states together must cover
/// every state exactly once.
#[derive(Debug, Clone, PartialEq)]
pub struct ObserverDesign {
    pub blocks: Vec<DesignBlock>,
    /// States that get no output feedback (gain rows zero): states whose own dynamics are
    /// already faster than the design or stable and slow on purpose, and that no output makes
    /// observable as a block of their own, such as a state the model computes algebraically from
    /// the others (model B's `ay`). The design is accepted only where their open-loop part of
    /// `A` is stable (see [`blockwise_observer_gain`]).
    pub open_loop: Vec<usize>,
    /// States set to these values in the linearisation the gain is placed on, not in the one
    /// the observer propagates its error covariance with (empty: the gain is placed at the
    /// operating point itself). For states through which the outputs see the others only after
    /// a lag, such as the grip model's relaxation factor: placed at 0 (the quasi-static tyre)
    /// the gain is model A's ([`crate::models::single_track_grip`]). The gain is taken only
    /// where the operating point's own error map `(I - L C) A` is stable with it, else it is
    /// placed at the operating point ([`design_gain`]).
    pub placement_state: Vec<(usize, f64)>,
}

impl ObserverDesign {
    /// The seed's single-output design: all states observed through `output`.
    pub fn single_output(output: usize, poles: Vec<Complex<f64>>) -> Self {
        Self {
            blocks: vec![DesignBlock {
                states: (0..poles.len()).collect(),
                output,
                poles,
            }],
            open_loop: Vec::new(),
            placement_state: Vec::new(),
        }
    }

    /// All the poles of the design, in block order.
    pub fn poles(&self) -> Vec<Complex<f64>> {
        self.blocks
            .iter()
            .flat_map(|b| b.poles.iter().copied())
            .collect()
    }
}

/// Coefficients `[a₀, …, a_{k-1}]` of the monic polynomial `∏(s - pᵢ) = sᵏ + a_{k-1}sᵏ⁻¹ + … + a₀`
/// (002: "Koeffizienten âᵢ des charakteristischen Polynoms aus den vorgegebenen Eigenwerten").
pub fn characteristic_coefficients(poles: &[Complex<f64>]) -> Result<Vec<f64>, SettingsError> {
    // Coefficients in ascending order, leading 1 at the end.
    let mut coefficients = vec![Complex::new(1.0, 0.0)];
    for &pole in poles {
        if !(pole.re.is_finite() && pole.im.is_finite()) {
            return Err(SettingsError(format!(
                "observer poles must be finite, got {pole}"
            )));
        }
        let mut next = vec![Complex::new(0.0, 0.0); coefficients.len() + 1];
        for (j, &c) in coefficients.iter().enumerate() {
            next[j + 1] += c;
            next[j] -= pole * c;
        }
        coefficients = next;
    }
    let scale = coefficients.iter().map(|c| c.norm()).fold(1.0, f64::max);
    if coefficients.iter().any(|c| c.im.abs() > 1e-9 * scale) {
        return Err(SettingsError(format!(
            "observer poles must come in complex-conjugate pairs, got {poles:?}"
        )));
    }
    coefficients.pop();
    Ok(coefficients.into_iter().map(|c| c.re).collect())
}

/// The Ackermann formula for an observer (002: §4): the gain `l` such that `A - l cᵀ` has the
/// eigenvalues `poles`, `l = p̂(A) O⁻¹ eₙ`. Errors when `(A, cᵀ)` is not observable.
pub fn ackermann_observer_gain(
    system: &DMatrix<f64>,
    output_row: &DVector<f64>,
    poles: &[Complex<f64>],
) -> Result<DVector<f64>, SettingsError> {
    let n = system.nrows();
    if system.ncols() != n || output_row.len() != n || poles.len() != n {
        return Err(SettingsError(format!(
            "pole placement needs a square system, an output row of its size and one pole per state; got a {}x{} system, {} output entries, {} poles",
            system.nrows(),
            system.ncols(),
            output_row.len(),
            poles.len()
        )));
    }
    let coefficients = characteristic_coefficients(poles)?;
    // O = [cᵀ; cᵀA; …; cᵀAⁿ⁻¹].
    let mut observability = DMatrix::<f64>::zeros(n, n);
    let mut row = output_row.transpose();
    for j in 0..n {
        observability.set_row(j, &row);
        row *= system;
    }
    let mut last_unit = DVector::<f64>::zeros(n);
    last_unit[n - 1] = 1.0;
    let singular_values = observability.clone().svd(false, false).singular_values;
    let largest = singular_values.max();
    let smallest = singular_values.min();
    if largest.is_nan() || largest <= 0.0 || smallest <= 1e-12 * largest {
        return Err(SettingsError(format!(
            "the system is not observable from the chosen output (observability matrix singular values {})",
            singular_values.transpose()
        )));
    }
    let q = observability
        .lu()
        .solve(&last_unit)
        .ok_or_else(|| SettingsError("the observability matrix is singular".to_string()))?;
    // p̂(A) by Horner's scheme: Aⁿ + a_{n-1}Aⁿ⁻¹ + … + a₀ I.
    let identity = DMatrix::<f64>::identity(n, n);
    let mut polynomial = identity.clone();
    for &a in coefficients.iter().rev() {
        polynomial = &polynomial * system + &identity * a;
    }
    Ok(polynomial * q)
}

/// The observer gain `L` (N × M) of `design` for the discrete linear model: places the
/// eigenvalues of `(I - L C) A` (see the module documentation).
pub fn observer_gain<const N: usize, const M: usize, const U: usize>(
    linear: &LinearisedModel<N, M, U>,
    design: &ObserverDesign,
) -> Result<SMatrix<f64, N, M>, SettingsError> {
    place_gain(linear, design, true).map(|(gain, _)| gain)
}

/// The gain of `design` on a linearisation whose blocks may be coupled, as gain scheduling
/// meets them (our decision, beyond the seed): in a corner `r vy`, `r vx` and the tyres' speed
/// dependence couple the lateral and longitudinal states that straight driving decouples. Each
/// block's poles are placed for its own part of `A` and `C A` with the coupling left out of the
/// design (a decentralised design on the block-diagonal part), so the eigenvalues of the whole
/// error map `(I - L C) A` are the placed ones only up to the coupling's size. The gain is
/// accepted only when the linearised model itself is stable (a sample whose rows are gated runs
/// it open loop) and that error map is no slower than the slowest placed pole
/// ([`blockwise_observer_gain`]).
pub fn scheduled_observer_gain<const N: usize, const M: usize, const U: usize>(
    linear: &LinearisedModel<N, M, U>,
    design: &ObserverDesign,
) -> Result<SMatrix<f64, N, M>, SettingsError> {
    let open_loop = spectral_radius(&linear.transition);
    // A neutral mode (the free-rolling speed) is not unstable, whatever its rounding.
    if open_loop > 1.0 + STABILITY_MARGIN {
        return Err(SettingsError(format!(
            "observer design: the linearised model is not stable at this operating point (spectral radius {open_loop}); a sample whose rows are gated or missing would run it open loop"
        )));
    }
    blockwise_observer_gain(linear, design)
}

/// The decentralised gain of [`scheduled_observer_gain`] without its open-loop test: each block
/// placed on its own part, accepted only when the whole error map `(I - L C) A` is no slower
/// than the slowest placed pole.
fn blockwise_observer_gain<const N: usize, const M: usize, const U: usize>(
    linear: &LinearisedModel<N, M, U>,
    design: &ObserverDesign,
) -> Result<SMatrix<f64, N, M>, SettingsError> {
    let (gain, open_loop) = place_gain(linear, design, false)?;
    let error_map = error_map(linear, &gain);
    let placed = design.poles().iter().fold(0.0f64, |m, z| m.max(z.norm()));
    // The fed-back states' part of the error map (all of it without open-loop states): no
    // slower than the slowest placed pole. A relative margin for the eigenvalue routine's
    // rounding: where the blocks happen to decouple, the radius is that pole itself.
    let fed_back = sub_radius(&error_map, |s| !design.open_loop.contains(&s));
    if fed_back > placed * (1.0 + STABILITY_MARGIN) {
        return Err(SettingsError(format!(
            "observer design: the error dynamics of the block-wise gain are not stable at this operating point (spectral radius {fed_back})"
        )));
    }
    if design.open_loop.is_empty() {
        return Ok(gain);
    }
    // With states left open loop (stable, place_gain checked), the whole error map no slower
    // than they are on their own (the design cannot make it faster) or than the placed poles.
    let radius = spectral_radius(&error_map);
    if radius <= placed.max(open_loop) * (1.0 + STABILITY_MARGIN) {
        Ok(gain)
    } else {
        Err(SettingsError(format!(
            "observer design: with the states {:?} without feedback (on their own spectral radius {open_loop}) the error dynamics are not stable at this operating point (spectral radius {radius})",
            design.open_loop
        )))
    }
}

/// The gain the observer starts with: the exact placement of [`observer_gain`] where the
/// design's blocks decouple at the operating point, else the block-wise one with its test of
/// the error map ([`blockwise_observer_gain`]). Not the open-loop test of a re-schedule: the
/// exact design never had it, and at walking pace model A's discretised lateral dynamics are
/// unstable (spectral radius 3.2 at 1 m/s and 10 ms) while the observer's error map is not.
fn starting_gain<const N: usize, const M: usize, const U: usize>(
    linear: &LinearisedModel<N, M, U>,
    design: &ObserverDesign,
) -> Result<SMatrix<f64, N, M>, SettingsError> {
    observer_gain(linear, design).or_else(|exact| {
        blockwise_observer_gain(linear, design)
            .map_err(|blockwise| SettingsError(format!("{}; {}", exact.0, blockwise.0)))
    })
}

/// The gain `rule` places for `design` on the observer's linearisation `linear`, at the
/// design's placement state ([`ObserverDesign::placement_state`]) where it has one: `rule`
/// applied to the model linearised there (same input), the gain kept where the error map of
/// `linear` itself, `(I - L C) A`, is stable with it; otherwise `rule` applied to `linear`, the
/// placement without that state.
fn design_gain<Model, const N: usize, const M: usize, const U: usize>(
    model: &Model,
    linear: &LinearisedModel<N, M, U>,
    design: &ObserverDesign,
    rule: fn(
        &LinearisedModel<N, M, U>,
        &ObserverDesign,
    ) -> Result<SMatrix<f64, N, M>, SettingsError>,
) -> Result<SMatrix<f64, N, M>, SettingsError>
where
    Model: StateSpaceModel<N, M, U>,
{
    if design.placement_state.is_empty() {
        return rule(linear, design);
    }
    check_design::<N, M>(design)?;
    let mut state = linear.state;
    for &(index, value) in &design.placement_state {
        state[index] = value;
    }
    let placed = LinearisedModel::about(model, &state, &linear.input).and_then(|placement| {
        let gain = rule(&placement, design)?;
        let radius = spectral_radius(&error_map(linear, &gain));
        if radius < 1.0 {
            Ok(gain)
        } else {
            Err(SettingsError(format!(
                "observer design: the gain placed at the placement state leaves the error dynamics unstable (spectral radius {radius})"
            )))
        }
    });
    placed.or_else(|_| rule(linear, design))
}

/// The a-posteriori error map `(I - L C) A` of `gain` on `linear` (module docs).
fn error_map<const N: usize, const M: usize, const U: usize>(
    linear: &LinearisedModel<N, M, U>,
    gain: &SMatrix<f64, N, M>,
) -> SMatrix<f64, N, N> {
    (SMatrix::<f64, N, N>::identity() - gain * linear.output_matrix) * linear.transition
}

/// Relative rounding margin of [`scheduled_observer_gain`]'s open-loop stability test.
const STABILITY_MARGIN: f64 = 1e-9;

/// How many error time constants a design is kept at least before the observer is re-scheduled:
/// 3, so that the error of one design has decayed to 5 % before the next gain applies. Frozen-time
/// stability of each design does not make the scheduled observer stable when the operating point
/// moves fast against the error dynamics (Rugh & Shamma, "Research on gain scheduling",
/// Automatica 36, 2000, §4.3: the scheduling variable must vary slowly); re-placed at every sample
/// at walking pace, the observer's vy went 15 times off (0.62 against 0.04 m/s).
const DWELL_TIME_CONSTANTS: f64 = 3.0;

/// The samples a design is kept at least: [`DWELL_TIME_CONSTANTS`] times the time constant, in
/// samples, of its slowest pole `z`, `-1 / ln|z|`.
fn dwell_samples(design: &ObserverDesign) -> u64 {
    let slowest = design.poles().iter().fold(0.0f64, |m, z| m.max(z.norm()));
    let time_constant = -1.0 / slowest.ln();
    (DWELL_TIME_CONSTANTS * time_constant).ceil().max(1.0) as u64
}

/// The spectral radius of the square part of `matrix` on the states `keep` selects (0 for none),
/// as a dynamic matrix: the eigenvalue routine needs dimension bounds a const N lacks.
fn sub_radius<const N: usize>(matrix: &SMatrix<f64, N, N>, keep: impl Fn(usize) -> bool) -> f64 {
    let states: Vec<usize> = (0..N).filter(|&s| keep(s)).collect();
    if states.is_empty() {
        return 0.0;
    }
    DMatrix::from_fn(states.len(), states.len(), |i, j| {
        matrix[(states[i], states[j])]
    })
    .complex_eigenvalues()
    .iter()
    .fold(0.0f64, |largest, z| largest.max(z.norm()))
}

/// The largest modulus of the eigenvalues of `matrix`.
fn spectral_radius<const N: usize>(matrix: &SMatrix<f64, N, N>) -> f64 {
    sub_radius(matrix, |_| true)
}

/// Places the gain of `design` block by block; with `decoupled`, refuses blocks that are
/// coupled in the linear model. Also returns the spectral radius of the open-loop states' part
/// of `A` (0 without them), which must be below 1.
fn place_gain<const N: usize, const M: usize, const U: usize>(
    linear: &LinearisedModel<N, M, U>,
    design: &ObserverDesign,
    decoupled: bool,
) -> Result<(SMatrix<f64, N, M>, f64), SettingsError> {
    let a = &linear.transition;
    let ca = linear.output_matrix * a;
    check_design::<N, M>(design)?;
    let open_loop = sub_radius(a, |s| design.open_loop.contains(&s));
    if open_loop >= 1.0 {
        return Err(SettingsError(format!(
            "observer design: the states without feedback {:?} are not stable at this operating point (spectral radius {open_loop})",
            design.open_loop
        )));
    }
    if decoupled {
        check_decoupled(a, &ca, design)?;
    }
    let mut gain = SMatrix::<f64, N, M>::zeros();
    for block in &design.blocks {
        let k = block.states.len();
        let shifted_system = DMatrix::from_fn(k, k, |i, j| {
            a[(block.states[i], block.states[j])] - if i == j { 1.0 } else { 0.0 }
        });
        let h = shifted_system.amax();
        let h = if h > 0.0 { h } else { 1.0 };
        let shifted_system = shifted_system / h;
        let output_row = DVector::from_fn(k, |i, _| ca[(block.output, block.states[i])]);
        let shifted_poles: Vec<Complex<f64>> = block.poles.iter().map(|&z| (z - 1.0) / h).collect();
        let block_gain = ackermann_observer_gain(&shifted_system, &output_row, &shifted_poles)?;
        for (i, &s) in block.states.iter().enumerate() {
            gain[(s, block.output)] = h * block_gain[i];
        }
    }
    Ok((gain, open_loop))
}

/// Every block's output and poles are valid and the blocks cover every state exactly once.
fn check_design<const N: usize, const M: usize>(
    design: &ObserverDesign,
) -> Result<(), SettingsError> {
    let mut covered = [false; N];
    for block in &design.blocks {
        if block.output >= M {
            return Err(SettingsError(format!(
                "observer design: output index {} out of range (the model has {M} outputs)",
                block.output
            )));
        }
        if block.poles.len() != block.states.len() {
            return Err(SettingsError(format!(
                "observer design: a block with states {:?} needs {} poles, got {}",
                block.states,
                block.states.len(),
                block.poles.len()
            )));
        }
        for &s in &block.states {
            if s >= N || covered[s] {
                return Err(SettingsError(format!(
                    "observer design: state index {s} is out of range or in two blocks (the model has {N} states)"
                )));
            }
            covered[s] = true;
        }
        if let Some(pole) = block
            .poles
            .iter()
            .find(|p| p.norm().is_nan() || p.norm() >= 1.0)
        {
            return Err(SettingsError(format!(
                "observer poles must lie inside the unit circle (discrete time), got {pole}"
            )));
        }
    }
    if let Some((index, value)) = design
        .placement_state
        .iter()
        .find(|(index, value)| *index >= N || !value.is_finite())
    {
        return Err(SettingsError(format!(
            "observer design: placement state {index} = {value} must name one of the {N} states and be finite"
        )));
    }
    for &s in &design.open_loop {
        if s >= N || covered[s] {
            return Err(SettingsError(format!(
                "observer design: open-loop state index {s} is out of range or also in a block (the model has {N} states)"
            )));
        }
        covered[s] = true;
    }
    if let Some(missing) = covered.iter().position(|&c| !c) {
        return Err(SettingsError(format!(
            "observer design: state {missing} is in no block"
        )));
    }
    Ok(())
}

/// Block decoupling, so that the eigenvalues of the whole error matrix are the union of the
/// per-block ones.
fn check_decoupled<const N: usize, const M: usize>(
    a: &SMatrix<f64, N, N>,
    ca: &SMatrix<f64, M, N>,
    design: &ObserverDesign,
) -> Result<(), SettingsError> {
    let tolerance = 1e-12 * a.amax().max(ca.amax());
    for block in &design.blocks {
        for &inside in &block.states {
            for outside in (0..N).filter(|s| !block.states.contains(s)) {
                let coupled = a[(inside, outside)].abs() > tolerance
                    || a[(outside, inside)].abs() > tolerance
                    || ca[(block.output, outside)].abs() > tolerance;
                if coupled {
                    return Err(SettingsError(format!(
                        "observer design: states {:?} are coupled to state {outside} in the linear model or in output {}; use one block",
                        block.states, block.output
                    )));
                }
            }
        }
    }
    Ok(())
}

/// The discrete Luenberger observer of seed 002 on the linearisation of any [`StateSpaceModel`].
#[derive(Debug, Clone)]
pub struct LuenbergerObserver<Model, const N: usize, const M: usize, const U: usize> {
    model: Model,
    linear: LinearisedModel<N, M, U>,
    gain: SMatrix<f64, N, M>,
    /// The pole placement, to place the gain again when the observer is re-scheduled.
    design: ObserverDesign,
    /// Samples a design is kept at least before the next re-schedule ([`dwell_samples`]).
    dwell: u64,
    /// Samples since the last re-schedule (or the start).
    since_schedule: u64,
    process_noise: SMatrix<f64, N, N>,
    measurement_noise: SMatrix<f64, M, M>,
    state: SVector<f64, N>,
    covariance: SMatrix<f64, N, N>,
    last_report: UpdateReport<M>,
}

impl<Model, const N: usize, const M: usize, const U: usize> LuenbergerObserver<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    /// Linearises `model` about `(operating_state, operating_input)`, places the gain by
    /// `design` and starts from `initial` (its covariance seeds the error-covariance propagation).
    pub fn new(
        model: Model,
        operating_state: &SVector<f64, N>,
        operating_input: &SVector<f64, U>,
        design: &ObserverDesign,
        initial: &InitialEstimate<N>,
    ) -> Result<Self, SettingsError> {
        initial.validate()?;
        let process_noise = model.process_noise();
        let measurement_noise = model.measurement_noise();
        check_covariance("the process noise covariance Q", &process_noise)
            .map_err(SettingsError)?;
        check_covariance("the measurement noise covariance R", &measurement_noise)
            .map_err(SettingsError)?;
        let linear = LinearisedModel::about(&model, operating_state, operating_input)?;
        let gain = design_gain(&model, &linear, design, starting_gain)?;
        Ok(Self {
            model,
            linear,
            gain,
            design: design.clone(),
            dwell: dwell_samples(design),
            since_schedule: 0,
            process_noise,
            measurement_noise,
            state: initial.state,
            covariance: initial.covariance,
            last_report: UpdateReport::skipped(),
        })
    }

    /// The placed observer gain `L`.
    pub fn gain(&self) -> &SMatrix<f64, N, M> {
        &self.gain
    }

    /// The a-posteriori error map `(I - L C) A` at the operating point, whose eigenvalues were
    /// placed (with a [`ObserverDesign::placement_state`] they were placed at that state, and
    /// here they are only stable).
    pub fn error_dynamics(&self) -> SMatrix<f64, N, N> {
        error_map(&self.linear, &self.gain)
    }

    /// The linear model the observer runs on.
    pub fn linearisation(&self) -> &LinearisedModel<N, M, U> {
        &self.linear
    }

    /// The model the observer was linearised from.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The report of the last measurement update.
    pub fn last_report(&self) -> &UpdateReport<M> {
        &self.last_report
    }
}

impl<Model, const N: usize, const M: usize, const U: usize> Estimator<N, M, U>
    for LuenbergerObserver<Model, N, M, U>
where
    Model: StateSpaceModel<N, M, U>,
{
    fn predict(&mut self, input: &SVector<f64, U>) -> Result<(), FilterIssue> {
        let previous_state = self.state;
        let previous_covariance = self.covariance;
        // The model itself (Zeitz's extended observer, see the module documentation); the
        // linearisation gives the gain and the error covariance's transition.
        self.state = self.model.transition(&self.state, input);
        let a = &self.linear.transition;
        self.covariance = a * self.covariance * a.transpose() + self.process_noise;
        symmetrize(&mut self.covariance);
        if finite_or_restore(
            &mut self.state,
            &mut self.covariance,
            previous_state,
            previous_covariance,
        ) {
            Ok(())
        } else {
            Err(FilterIssue::StateReset)
        }
    }

    fn update(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &MeasurementMask<M>,
    ) -> Result<UpdateReport<M>, FilterIssue> {
        let predicted = self.model.measurement(&self.state, input);
        let c = &self.linear.output_matrix;
        let cross = self.covariance * c.transpose();
        let innovation_covariance = c * cross + self.measurement_noise;
        // The Kalman gain of masked_gain is not used; it yields the masked innovation and NIS.
        let step = match crate::kalman::masked_gain(
            cross,
            innovation_covariance,
            measurement,
            &predicted,
            mask,
        ) {
            Ok(Some(step)) => step,
            Ok(None) => {
                self.last_report = UpdateReport::skipped();
                return Ok(self.last_report);
            }
            Err(issue) => {
                self.last_report = UpdateReport::skipped();
                return Err(issue);
            }
        };
        let report = step.report;
        let mut gain = self.gain;
        let mut used_output_matrix = *c;
        for row in 0..M {
            if !report.used[row] {
                gain.column_mut(row).fill(0.0);
                used_output_matrix.row_mut(row).fill(0.0);
            }
        }
        let previous_state = self.state;
        let previous_covariance = self.covariance;
        self.state += gain * report.innovation;
        self.covariance = joseph_update(
            &self.covariance,
            &gain,
            &used_output_matrix,
            &self.measurement_noise,
        );
        symmetrize(&mut self.covariance);
        if !finite_or_restore(
            &mut self.state,
            &mut self.covariance,
            previous_state,
            previous_covariance,
        ) {
            self.last_report = UpdateReport::skipped();
            return Err(FilterIssue::StateReset);
        }
        self.last_report = report;
        Ok(report)
    }

    fn state(&self) -> &SVector<f64, N> {
        &self.state
    }

    fn covariance(&self) -> &SMatrix<f64, N, N> {
        &self.covariance
    }
}

/// In the registry: described by `(x̂, P)`, its settings and the operating point it runs at
/// (which gain scheduling moves).
impl<Model, const N: usize, const M: usize, const U: usize>
    crate::running::RunningEstimator<N, M, U> for LuenbergerObserver<Model, N, M, U>
where
    Model: crate::running::RegistryModel<N, M, U>,
{
    fn last_report(&self) -> UpdateReport<M> {
        self.last_report
    }

    // The gain is fixed (seed 002's poles), so the estimate does not see `extra`; the covariance
    // the observer reports, propagated with that gain in the Joseph form (004), does:
    // `+ L extra Lᵀ`.
    crate::kalman::update_with_r_plus_extra!();

    /// Re-linearises about `(x̂, input)` when the linearisation errs there by more than
    /// `threshold` noise standard deviations, and places the gain again by the same design
    /// ([`scheduled_observer_gain`]); keeps the old linearisation and gain when the new one
    /// cannot be placed stably.
    fn reschedule(&mut self, input: &SVector<f64, U>, threshold: f64) -> bool {
        self.since_schedule = self.since_schedule.saturating_add(1);
        if self.since_schedule < self.dwell {
            return false;
        }
        let error = self.linear.normalised_error(
            &self.model,
            &self.state,
            input,
            &self.process_noise,
            &self.measurement_noise,
        );
        if error <= threshold {
            return false;
        }
        let Ok(linear) = LinearisedModel::about(&self.model, &self.state, input) else {
            return false;
        };
        match design_gain(&self.model, &linear, &self.design, scheduled_observer_gain) {
            Ok(gain) => {
                self.linear = linear;
                self.gain = gain;
                self.since_schedule = 0;
                true
            }
            Err(_) => false,
        }
    }

    fn save(&self, sink: &mut dyn SnapshotSink) {
        save_gaussian(sink, &self.state, &self.covariance);
        save_operating_point(sink, &self.linear);
        sink.u64(self.since_schedule);
    }

    fn restore(&mut self, source: &mut dyn SnapshotSource) -> Result<Restored<N>, SnapshotError> {
        let (state, covariance) = read_gaussian(source)?;
        let linear = restored_linearisation(&self.model, &self.linear, source)?;
        self.since_schedule = source.u64("samples since the last re-schedule")?;
        if linear != self.linear {
            self.gain = design_gain(&self.model, &linear, &self.design, scheduled_observer_gain)
                .map_err(|error| SnapshotError(error.0))?;
            self.linear = linear;
        }
        self.state = state;
        self.covariance = covariance;
        self.last_report = UpdateReport::skipped();
        Ok(Restored::InPlace)
    }
}
