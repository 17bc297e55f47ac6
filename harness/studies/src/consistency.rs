//! Consistency and efficiency of the estimator FMUs where their model is right: the
//! seed-000 high-ay ramp, model A as truth and filter model with the seed's
//! `Q` and `R` (SPEC §7), run N times through FMI with N noise seeds as `harness montecarlo`
//! runs it ([`Plan::run`] with the scenario's `[montecarlo] seeds` overridden per run).
//!
//! Per state and estimator it measures
//! - the NEES `e² / σ²` of the published estimate against the truth with the published
//!   one-sigma uncertainty, averaged over the runs at each instant: for a consistent filter that
//!   average is chi-square(N)/N, inside the 95 % band `[q(0.025, N)/N, q(0.975, N)/N]` (Bar-Shalom,
//!   Li and Kirubarajan 2001, §5.4); its time average (ANEES) and the share of instants inside;
//! - the NIS the FMU reports, summed over the runs: chi-square with the summed rows as degrees of
//!   freedom;
//! - the RMSE over runs and time against the square root of the posterior Cramér-Rao lower bound
//!   ([`estimation::pcrlb`], Tichavský et al. 1998) of model A with the same `Q` and `R`, its
//!   expectations averaged over the N true trajectories. The FMU publishes its one-step
//!   prediction (the estimate of the next sample from the measurements up to the current one), so
//!   the bound compared is that of the prediction; sideslip's bound is the state bound carried
//!   through `atan2(vy, vx)` by its gradient. The ratio RMSE / sqrt(bound) is the efficiency
//!   (1 = as good as any estimator can be).
//!
//! Offline only: the bound uses `estimation`'s model A (feature `offline`); the estimators are
//! the FMUs.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use estimation::models::single_track::SingleTrackEstimationModel;
use estimation::pcrlb::PosteriorCramerRao;
use nalgebra::{SMatrix, SVector};

use fmi_master::cosim::{Plan, RunResult};
use fmi_master::montecarlo::{
    run_averaged_band, stream_runs, NeesOverRuns, NisOverRuns, ScoredRun, Spread,
};
use fmi_master::plot::{draw_panels, Panel, Series};
use fmi_master::report::Document;
use fmi_master::runner::{scenario_dir, Environment};
use fmi_master::scenario::{Scenario, ScoreSection};

/// Model A's states as the FMUs publish them: label, truth variable of the ReferenceVehicle,
/// estimate and one-sigma outputs of the estimator. The first five are the filter state
/// `[vx, vy, r, ωF, ωR]` (000: 5.58); sideslip is derived.
const STATES: [(&str, &str, &str, &str); 6] = [
    ("vx", "vx", "vx_est", "vx_std"),
    ("vy", "vy", "vy_est", "vy_std"),
    ("yaw_rate", "yaw_rate", "yaw_rate_est", "yaw_rate_std"),
    (
        "omega_front",
        "omega_front",
        "omega_front_est",
        "omega_front_std",
    ),
    (
        "omega_rear",
        "omega_rear",
        "omega_rear_est",
        "omega_rear_std",
    ),
    ("sideslip", "sideslip", "sideslip_est", "sideslip_std"),
];
const FILTER_STATES: usize = 5;
const SIDESLIP: usize = 5;

/// The driver inputs `[δ, drive torque, brake torque]` of model A, as the master records the
/// manoeuvre's channels.
const INPUTS: [&str; 3] = [
    "manoeuvre.steering_angle",
    "manoeuvre.drive_torque",
    "manoeuvre.brake_torque",
];

/// What to run.
#[derive(Debug, Clone)]
pub struct ConsistencyStudy {
    pub scenario: PathBuf,
    /// The ReferenceVehicle instance (truth, model A).
    pub vehicle: String,
    /// The estimator instances kept from the scenario (the others are removed).
    pub estimators: Vec<String>,
    pub runs: usize,
    pub first_seed: i32,
    /// The filters' sample time (the bound's model A is built with it).
    pub sample_time: f64,
    /// The figures leave out the first seconds: the truth starts at the filters' initial
    /// estimate instead of being drawn from `P(0)`, so the bound of the start (`P(0)` itself)
    /// is no bound on those errors, and its large values would dominate a time average.
    pub settle_time: f64,
}

impl ConsistencyStudy {
    /// The demo's study: the seed-000 high-ay ramp at 1 ms with LKF, EKF, UKF and the scaled
    /// UKF, 40 noise seeds (about 10 s on two cores).
    pub fn shipped() -> Self {
        Self {
            scenario: scenario_dir().join("seed000_ramp_high_ay.toml"),
            vehicle: String::from("vehicle"),
            estimators: ["LKF", "EKF", "UKF", "UKF_scaled"]
                .map(String::from)
                .to_vec(),
            runs: 40,
            first_seed: 1,
            sample_time: 0.001,
            settle_time: 1.0,
        }
    }
}

/// One estimator's figures for one state.
#[derive(Debug, Clone)]
pub struct StateRow {
    pub estimator: String,
    pub state: String,
    /// Time average of the run-averaged NEES.
    pub anees: f64,
    /// Share of instants whose run-averaged NEES is inside the 95 % band.
    pub share_in_band: f64,
    /// RMSE over all runs and instants.
    pub rmse: f64,
    /// Square root of the time-averaged bound.
    pub bound_rms: f64,
    /// RMSE / sqrt(bound) per run, mean and spread over the runs.
    pub efficiency: Spread,
}

/// One estimator's NIS over the runs.
#[derive(Debug, Clone)]
pub struct NisRow {
    pub estimator: String,
    /// Time average of the run-summed NIS divided by the run-summed rows (1 when consistent).
    pub mean_nis_per_row: f64,
    /// Share of instants whose run-summed NIS is inside its 95 % chi-square band.
    pub share_in_band: f64,
}

/// The study's result.
#[derive(Debug, Clone)]
pub struct ConsistencyReport {
    pub scenario: String,
    pub runs: usize,
    /// The 95 % band of a run-averaged NEES, chi-square(N)/N.
    pub nees_band: (f64, f64),
    pub states: Vec<StateRow>,
    pub nis: Vec<NisRow>,
    /// The plot, relative to the output folder's parent (the report's folder).
    pub plot: Option<PathBuf>,
    pub seconds: f64,
    /// The figures start this long after the start, s.
    pub settle_time: f64,
}

/// What the study reads from one run's recording besides the master's scores and NEES: the
/// truth for the bound, the squared errors for the RMSE, the NIS per instant.
struct RunData {
    /// `[x (5), u (3)]` per instant.
    truth: Vec<[f64; FILTER_STATES + 3]>,
    /// `[estimator][state]`: squared errors per instant from the settle time on.
    squared_errors: Vec<Vec<Vec<f64>>>,
    /// `[estimator]`: NIS and rows used per instant from the settle time on.
    nis: Vec<Vec<(f64, f64)>>,
    /// The first estimator's published variances at the start, `P(0)`'s diagonal.
    initial_variances: [f64; FILTER_STATES],
}

/// Sums over the runs per instant, and each run's mean squared error per estimator and state.
struct Sums {
    truths: Vec<Vec<[f64; FILTER_STATES + 3]>>,
    squared_errors: Vec<Vec<Vec<f64>>>,
    /// `[estimator][state]`: the master's NEES series from the settle time on.
    nees: Vec<Vec<NeesOverRuns>>,
    /// `[estimator]`.
    nis: Vec<NisOverRuns>,
    run_mse: Vec<Vec<Vec<f64>>>,
    initial_variances: [f64; FILTER_STATES],
}

fn column<'a>(result: &'a RunResult, name: &str) -> Result<&'a [f64]> {
    result
        .column(name)
        .ok_or_else(|| anyhow!("consistency study: the run recorded no column {name}"))
}

/// The scenario with only the vehicle and the chosen estimators, scored on [`STATES`].
fn plan(study: &ConsistencyStudy, env: &Environment) -> Result<Plan> {
    let mut scenario = Scenario::from_file(&study.scenario)?;
    let keep = |name: &String| *name == study.vehicle || study.estimators.contains(name);
    scenario.fmus.retain(|fmu| keep(&fmu.name));
    scenario
        .connections
        .retain(|c| keep(&c.from) && keep(&c.to));
    for name in &study.estimators {
        if !scenario.fmus.iter().any(|fmu| &fmu.name == name) {
            bail!(
                "consistency study: {} has no estimator instance {name}",
                study.scenario.display()
            );
        }
    }
    scenario.scores = score_sections(&study.vehicle);
    Plan::new(scenario, &env.fmu_dir, &env.work_dir())
}

/// One `[[score]]` per state with its one-sigma output: the master's NEES series
/// ([`fmi_master::montecarlo::scored_run_with`]) are those of [`STATES`].
fn score_sections(vehicle: &str) -> Vec<ScoreSection> {
    STATES
        .iter()
        .map(|(label, truth, estimate, std)| ScoreSection {
            label: (*label).to_string(),
            unit: String::new(),
            truth: format!("{vehicle}.{truth}"),
            estimate: format!("*.{estimate}"),
            std: Some(format!("*.{std}")),
            display_scale: None,
            display_unit: None,
        })
        .collect()
}

/// Reads one run's truth, squared errors and NIS.
fn run_data(study: &ConsistencyStudy, result: &RunResult) -> Result<RunData> {
    let vehicle = |name: &str| column(result, &format!("{}.{name}", study.vehicle));
    let truth_columns: Vec<&[f64]> = STATES
        .iter()
        .map(|(_, truth, _, _)| vehicle(truth))
        .collect::<Result<_>>()?;
    let input_columns: Vec<&[f64]> = INPUTS
        .iter()
        .map(|name| column(result, name))
        .collect::<Result<_>>()?;
    let rows = result.times.len();
    let first = settle_rows(study, rows);
    let truth = (0..rows)
        .map(|k| {
            let mut row = [0.0; FILTER_STATES + 3];
            for (i, c) in truth_columns.iter().take(FILTER_STATES).enumerate() {
                row[i] = c[k];
            }
            for (i, c) in input_columns.iter().enumerate() {
                row[FILTER_STATES + i] = c[k];
            }
            row
        })
        .collect();
    let mut data = RunData {
        truth,
        squared_errors: Vec::new(),
        nis: Vec::new(),
        initial_variances: [0.0; FILTER_STATES],
    };
    for (index, estimator) in study.estimators.iter().enumerate() {
        let output = |name: &str| column(result, &format!("{estimator}.{name}"));
        let mut squared = Vec::new();
        for (state, (_, _, estimate, std)) in STATES.iter().enumerate() {
            let (estimate, truth) = (output(estimate)?, truth_columns[state]);
            squared.push(
                (first..rows)
                    .map(|k| (estimate[k] - truth[k]).powi(2))
                    .collect(),
            );
            if index == 0 && state < FILTER_STATES {
                data.initial_variances[state] = output(std)?[0].powi(2);
            }
        }
        let (nis, dof) = (output("nis")?, output("rows_used")?);
        data.nis
            .push((first..rows).map(|k| (nis[k], dof[k])).collect());
        data.squared_errors.push(squared);
    }
    Ok(data)
}

/// The instants left out at the start ([`ConsistencyStudy::settle_time`]), fewer than `rows`.
fn settle_rows(study: &ConsistencyStudy, rows: usize) -> usize {
    let rows_per_second = 1.0 / study.sample_time;
    ((study.settle_time * rows_per_second).round() as usize).min(rows.saturating_sub(1))
}

/// Adds `b` into `a` element by element.
fn accumulate(a: &mut [Vec<Vec<f64>>], b: &[Vec<Vec<f64>>]) {
    for (a, b) in a.iter_mut().flatten().zip(b.iter().flatten()) {
        for (x, y) in a.iter_mut().zip(b) {
            *x += y;
        }
    }
}

impl Sums {
    fn new(estimators: usize) -> Self {
        Self {
            truths: Vec::new(),
            squared_errors: Vec::new(),
            nees: vec![vec![NeesOverRuns::default(); STATES.len()]; estimators],
            nis: vec![NisOverRuns::default(); estimators],
            run_mse: Vec::new(),
            initial_variances: [0.0; FILTER_STATES],
        }
    }

    /// Adds one run: its NEES from the master's series, the rest from what the study read.
    fn add(&mut self, study: &ConsistencyStudy, run: ScoredRun<RunData>) -> Result<()> {
        let data = run.read;
        let first = settle_rows(study, data.truth.len());
        for (e, estimator) in study.estimators.iter().enumerate() {
            for (s, (label, ..)) in STATES.iter().enumerate() {
                let series = run
                    .nees
                    .iter()
                    .find(|((l, instance), _)| l == label && instance == estimator)
                    .ok_or_else(|| anyhow!("consistency study: no NEES of {estimator} {label}"))?;
                self.nees[e][s].add(&series.1[first..]);
            }
            self.nis[e].add(&data.nis[e]);
        }
        let mse = data
            .squared_errors
            .iter()
            .map(|states| {
                states
                    .iter()
                    .map(|e| e.iter().sum::<f64>() / e.len() as f64)
                    .collect()
            })
            .collect();
        self.run_mse.push(mse);
        if self.truths.is_empty() {
            self.initial_variances = data.initial_variances;
            self.squared_errors = data.squared_errors;
        } else {
            accumulate(&mut self.squared_errors, &data.squared_errors);
        }
        self.truths.push(data.truth);
        Ok(())
    }
}

/// Runs the campaign through the master ([`stream_runs`]: a batch at a time, summed in run
/// order, bit-identical for any thread count).
fn campaign(study: &ConsistencyStudy, plan: &Plan) -> Result<Sums> {
    let mut sums = Sums::new(study.estimators.len());
    stream_runs(
        plan,
        study.runs,
        study.first_seed,
        &|result| run_data(study, result),
        &mut |run| sums.add(study, run),
    )?;
    Ok(sums)
}

/// The prediction bound of model A along the runs' truths at every instant, with sideslip's
/// through `atan2(vy, vx)`: `[instant][state]` variances.
fn bound_series(study: &ConsistencyStudy, sums: &Sums) -> Result<Vec<[f64; 6]>> {
    let model = SingleTrackEstimationModel::seed_000(study.sample_time)
        .map_err(|e| anyhow!("consistency study: model A for the bound: {e}"))?;
    let p0 = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from(sums.initial_variances));
    let mut bound = PosteriorCramerRao::new(&p0).map_err(|e| anyhow!("{e}"))?;
    let rows = sums.truths[0].len();
    let mut series = Vec::with_capacity(rows);
    let mut truths = Vec::with_capacity(sums.truths.len());
    for k in 0..rows {
        let covariance = bound.bound().map_err(|e| anyhow!("instant {k}: {e}"))?;
        let count = sums.truths.len() as f64;
        let mean_velocity = sums
            .truths
            .iter()
            .map(|t| t[k])
            .fold([0.0; 2], |m, t| [m[0] + t[0] / count, m[1] + t[1] / count]);
        series.push(state_variances(&covariance, mean_velocity));
        truths.clear();
        truths.extend(sums.truths.iter().map(|t| {
            let row = t[k];
            (
                SVector::<f64, 5>::from_column_slice(&row[..FILTER_STATES]),
                SVector::<f64, 3>::from_column_slice(&row[FILTER_STATES..]),
            )
        }));
        // The FMU's sample: the update with y(k), then the prediction to k + 1 (runner.rs).
        let step = bound
            .update(&model, &truths, &[true; 4])
            .and_then(|()| bound.predict(&model, &truths));
        step.map_err(|e| anyhow!("consistency study: bound at instant {k}: {e}"))?;
    }
    Ok(series)
}

/// The five state variances of a bound and sideslip's, `gᵀ B g` with `g = ∇ atan2(vy, vx)` at
/// the mean true `(vx, vy)`.
fn state_variances(bound: &SMatrix<f64, 5, 5>, mean_velocity: [f64; 2]) -> [f64; 6] {
    let [vx, vy] = mean_velocity;
    let speed_squared = vx * vx + vy * vy;
    let gradient = nalgebra::Vector2::new(-vy, vx) / speed_squared;
    let planar = bound.fixed_view::<2, 2>(0, 0);
    let mut variances = [0.0; 6];
    for (i, v) in variances.iter_mut().take(FILTER_STATES).enumerate() {
        *v = bound[(i, i)];
    }
    variances[SIDESLIP] = gradient.dot(&(planar * gradient));
    variances
}

/// Runs the study; writes its plot into `out_dir`.
pub fn run(study: &ConsistencyStudy, env: &Environment) -> Result<ConsistencyReport> {
    let started = Instant::now();
    if study.runs < 2 {
        bail!("consistency study: at least 2 runs, got {}", study.runs);
    }
    std::fs::create_dir_all(&env.out_dir)
        .with_context(|| format!("creating {}", env.out_dir.display()))?;
    let work = env.work_folder();
    let plan = plan(study, env)?;
    let sums = campaign(study, &plan)?;
    let times = plan_times(&plan, sums.truths[0].len());
    drop(plan);
    drop(work);
    let mut bound = bound_series(study, &sums)?;
    let first = settle_rows(study, bound.len());
    bound.drain(..first);
    let times = &times[first..];
    let nees_band = run_averaged_band(study.runs);
    let states = state_rows(study, &sums, &bound);
    let nis = nis_rows(study, &sums);
    let plot_path = env.out_dir.join("consistency.png");
    draw_panels(
        &plot_path,
        "RMSE over the runs against sqrt(PCRLB), seed-000 high-ay ramp",
        &rmse_panels(study, &sums, &bound, times),
        3,
    )?;
    let plot = env
        .out_dir
        .file_name()
        .map(|folder| Path::new(folder).join("consistency.png"));
    Ok(ConsistencyReport {
        // relative to the workspace, as the report is read on other machines
        scenario: study
            .scenario
            .strip_prefix(fmi_master::runner::workspace_root())
            .unwrap_or(&study.scenario)
            .display()
            .to_string(),
        runs: study.runs,
        nees_band,
        states,
        nis,
        plot,
        seconds: started.elapsed().as_secs_f64(),
        settle_time: study.settle_time,
    })
}

/// The instants of the runs.
fn plan_times(plan: &Plan, rows: usize) -> Vec<f64> {
    let scenario = &plan.scenario;
    (0..rows)
        .map(|k| scenario.start_time + k as f64 * scenario.step)
        .collect()
}

/// Per estimator and state: NEES over the runs (the master's aggregation) and RMSE against
/// the bound.
fn state_rows(study: &ConsistencyStudy, sums: &Sums, bound: &[[f64; 6]]) -> Vec<StateRow> {
    let n = study.runs as f64;
    let rows = bound.len() as f64;
    let mut out = Vec::new();
    for (e, estimator) in study.estimators.iter().enumerate() {
        for (s, (label, ..)) in STATES.iter().enumerate() {
            let (anees, share_in_band) = sums.nees[e][s].consistency();
            let bound_ms = bound.iter().map(|b| b[s]).sum::<f64>() / rows;
            let efficiency: Vec<f64> = sums
                .run_mse
                .iter()
                .map(|run| (run[e][s] / bound_ms).sqrt())
                .collect();
            out.push(StateRow {
                estimator: estimator.clone(),
                state: (*label).to_string(),
                anees,
                share_in_band,
                rmse: (sums.squared_errors[e][s].iter().sum::<f64>() / (n * rows)).sqrt(),
                bound_rms: bound_ms.sqrt(),
                efficiency: Spread::of(&efficiency),
            });
        }
    }
    out
}

/// Per estimator: the run-summed NIS against chi-square with the run-summed rows (the master's
/// aggregation).
fn nis_rows(study: &ConsistencyStudy, sums: &Sums) -> Vec<NisRow> {
    study
        .estimators
        .iter()
        .zip(&sums.nis)
        .map(|(estimator, nis)| {
            let (mean_nis_per_row, share_in_band) = nis.consistency();
            NisRow {
                estimator: estimator.clone(),
                mean_nis_per_row,
                share_in_band,
            }
        })
        .collect()
}

/// Estimators whose RMSE is more than this many times the bound's are left out of the plot (they
/// would set its scale; the table has them).
const PLOTTED_EFFICIENCY: f64 = 10.0;

/// Every tenth instant: enough for a plot of 12 000 samples.
const PLOT_STRIDE: usize = 10;

fn rmse_panels(
    study: &ConsistencyStudy,
    sums: &Sums,
    bound: &[[f64; 6]],
    times: &[f64],
) -> Vec<Panel> {
    let n = study.runs as f64;
    let x: Vec<f64> = times.iter().step_by(PLOT_STRIDE).copied().collect();
    STATES
        .iter()
        .enumerate()
        .map(|(s, (label, ..))| {
            let mut series = vec![Series {
                name: String::from("sqrt(PCRLB)"),
                x: x.clone(),
                y: bound
                    .iter()
                    .step_by(PLOT_STRIDE)
                    .map(|b| b[s].sqrt())
                    .collect(),
                is_truth: true,
            }];
            let bound_ms = bound.iter().map(|b| b[s]).sum::<f64>() / bound.len() as f64;
            let near_the_bound = |e: &usize| {
                let errors = &sums.squared_errors[*e][s];
                let mse = errors.iter().sum::<f64>() / (n * errors.len() as f64);
                mse <= PLOTTED_EFFICIENCY.powi(2) * bound_ms
            };
            series.extend((0..study.estimators.len()).filter(near_the_bound).map(|e| {
                Series {
                    name: study.estimators[e].clone(),
                    x: x.clone(),
                    y: sums.squared_errors[e][s]
                        .iter()
                        .step_by(PLOT_STRIDE)
                        .map(|v| (v / n).sqrt())
                        .collect(),
                    is_truth: false,
                }
            }));
            Panel {
                title: format!("{label}: RMSE over {} runs", study.runs),
                x_label: String::from("t (s)"),
                y_label: String::from("RMSE (SI)"),
                series,
            }
        })
        .collect()
}

/// The shipped study with its output below `out_dir/consistency`.
pub fn run_shipped(fmu_dir: &Path, out_dir: &Path) -> Result<ConsistencyReport> {
    run(
        &ConsistencyStudy::shipped(),
        &Environment {
            fmu_dir: fmu_dir.to_path_buf(),
            out_dir: out_dir.to_path_buf(),
        },
    )
}

/// The report's section: NEES and NIS against their bands, RMSE against the bound, the plot.
pub fn section(doc: &mut Document, report: &ConsistencyReport) {
    doc.heading(2, "Consistency and the Cramér-Rao bound (matched model)");
    doc.paragraph(format!(
        "`{}` (truth and filters on model A with the seed's Q and R), {} Monte Carlo runs through \
         the FMUs with noise seeds 1 to {} ({:.0} s). NEES = e²/σ² with the published estimate and \
         one-sigma output, averaged over the runs at each instant: a consistent filter keeps it in \
         the 95 % chi-square band [{:.2}, {:.2}] at about 95 % of the instants and near 1 on \
         average. Every figure is taken from {:.0} s on (the truth starts at the initial estimate, \
         not drawn from the initial covariance the bound starts from). NIS summed over the runs against chi-square with the summed rows. The bound is \
         the posterior Cramér-Rao lower bound of model A (Tichavský, Muravchik and Nehorai 1998, \
         `estimation::pcrlb`) for the one-step prediction the FMU publishes, its expectations \
         averaged over the runs' true trajectories; efficiency = RMSE / sqrt(time-averaged bound) \
         per run (mean ± std over runs; 1 is the best any estimator can do).",
        report.scenario,
        report.runs,
        report.runs,
        report.seconds,
        report.nees_band.0,
        report.nees_band.1,
        report.settle_time,
    ));
    let verdict = |anees: f64| {
        if (report.nees_band.0..=report.nees_band.1).contains(&anees) {
            "inside"
        } else {
            "outside"
        }
    };
    let rows = report
        .states
        .iter()
        .map(|r| {
            vec![
                r.estimator.clone(),
                r.state.clone(),
                format!("{:.2}", r.anees),
                verdict(r.anees).to_string(),
                format!("{:.0} %", 100.0 * r.share_in_band),
                format!("{:.3e}", r.rmse),
                format!("{:.3e}", r.bound_rms),
                format!("{:.2} ± {:.2}", r.efficiency.mean, r.efficiency.std),
            ]
        })
        .collect();
    doc.table(
        [
            "estimator",
            "state",
            "ANEES",
            "ANEES in band",
            "instants in band",
            "RMSE (SI)",
            "sqrt(PCRLB) (SI)",
            "efficiency",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
    let nis = report
        .nis
        .iter()
        .map(|r| {
            vec![
                r.estimator.clone(),
                format!("{:.2}", r.mean_nis_per_row),
                format!("{:.0} %", 100.0 * r.share_in_band),
            ]
        })
        .collect();
    doc.table(
        ["estimator", "mean NIS per row", "instants in the 95 % band"]
            .map(String::from)
            .to_vec(),
        nis,
    );
    if let Some(plot) = &report.plot {
        doc.image(
            plot.display().to_string(),
            "RMSE over the runs of every state against the square root of the PCRLB (red); \
             in a panel, an estimator more than 10 times above the bound is in the table only",
        );
    }
}
