//! Monte Carlo runs: the same scenario with N noise seeds, in parallel (rayon). Each worker
//! thread creates its own FMU instances (inside `Plan::run`) from the shared, once-extracted
//! archives; instance names carry the run index.
//!
//! Consistency over runs (Bar-Shalom et al., ch. 5.4): at each communication point the NEES of a
//! state averaged over N runs is chi-square(N)/N for a consistent filter; the fraction of points
//! inside the 95 % band [q(0.025, N)/N, q(0.975, N)/N] should be about 0.95.

use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::{bail, Context, Result};
use rayon::prelude::*;

use crate::cosim::{ParameterValue, Plan, RunOptions, RunResult};
use crate::fmu::VariableType;
use crate::scenario::VarRef;
use crate::scoring::{self, average_band, chi_square_quantile, matching_columns, Band, RunScores};

/// Mean and sample standard deviation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    pub mean: f64,
    pub std: f64,
}

impl Spread {
    pub fn of(values: &[f64]) -> Spread {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let n = finite.len() as f64;
        if finite.is_empty() {
            return Spread {
                mean: f64::NAN,
                std: f64::NAN,
            };
        }
        let mean = finite.iter().sum::<f64>() / n;
        let var = if finite.len() > 1 {
            finite.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)
        } else {
            0.0
        };
        Spread {
            mean,
            std: var.sqrt(),
        }
    }
}

#[derive(Debug, Clone)]
pub struct StateSummary {
    pub label: String,
    pub estimator: String,
    pub unit: String,
    pub rmse: Spread,
    pub max_abs: Spread,
    pub nees: Option<Spread>,
    /// Average NEES over runs and time (ANEES) and the fraction of communication points where
    /// the run-averaged NEES is inside the 95 % band of chi-square(N)/N.
    pub consistency: Option<(f64, f64)>,
}

#[derive(Debug, Clone)]
pub struct NisSummary {
    pub estimator: String,
    pub mean_nis: Spread,
    pub mean_dof: f64,
}

#[derive(Debug, Clone)]
pub struct MonteCarloSummary {
    pub scenario: String,
    pub runs: usize,
    pub band: (f64, f64),
    pub states: Vec<StateSummary>,
    pub nis: Vec<NisSummary>,
    pub step_wall_time: Vec<(String, Spread)>,
    /// Every run's scores, run i with seed first_seed + i (`harness montecarlo` writes them to runs.csv).
    pub per_run: Vec<RunScores>,
}

/// NEES time series keyed by (score label, estimator).
pub type NeesSeries = Vec<((String, String), Vec<f64>)>;

/// Per-run NEES time series, one per (score label, estimator) having a std output.
fn nees_series(plan: &Plan, result: &RunResult) -> NeesSeries {
    let mut out = Vec::new();
    for section in &plan.scenario.scores {
        let (Some(std_pattern), Some(truth)) = (&section.std, result.column(&section.truth)) else {
            continue;
        };
        let Some(std_var) = VarRef::parse(std_pattern).map(|r| r.variable) else {
            continue;
        };
        for (instance, column) in matching_columns(result, &section.estimate) {
            let Some(std) = result.column(&format!("{instance}.{std_var}")) else {
                continue;
            };
            let estimate = &result.data[column];
            let series = (0..truth.len())
                .map(|k| {
                    let e = estimate[k] - truth[k];
                    if std[k] > 0.0 && e.is_finite() {
                        e * e / (std[k] * std[k])
                    } else {
                        f64::NAN
                    }
                })
                .collect();
            out.push(((section.label.clone(), instance), series));
        }
    }
    out
}

/// The most runs of one campaign (the scores of every run are kept in memory).
pub const MAX_RUNS: usize = 100_000;

/// A seed is an Integer parameter: a Real or an enumeration (e.g. the estimator kind) would
/// change what is run, not only its noise, and the runs would not be repeats of one case.
fn check_seed_variable(plan: &Plan, r: &VarRef) -> Result<()> {
    let Some(variable) = plan.variable_of(r) else {
        bail!("seed variable {r}: no such instance or variable in the scenario");
    };
    if variable.var_type != VariableType::Integer || !variable.is_parameter() {
        bail!(
            "seed variable {r} is a {:?} {}; a seed must be an Integer parameter",
            variable.var_type,
            variable.causality
        );
    }
    Ok(())
}

/// One run of `plan` with `options`, scored: every Monte Carlo run goes through here, and so
/// does every case of a campaign chunk (`harness cases`), so both give the same bits.
pub fn scored_run(plan: &Plan, options: &RunOptions) -> Result<(RunScores, NeesSeries)> {
    scored_run_with(plan, options, &|_| Ok(())).map(|(scores, nees, ())| (scores, nees))
}

/// [`scored_run`] that also hands the recording to `read` before it is recycled, for what a
/// study needs beyond the scores (a trajectory, an error series).
pub fn scored_run_with<T>(
    plan: &Plan,
    options: &RunOptions,
    read: &dyn Fn(&RunResult) -> Result<T>,
) -> Result<(RunScores, NeesSeries, T)> {
    let result = plan.run(options, |_| {})?;
    let scores = scoring::score_run(&plan.scenario, &result);
    let nees = nees_series(plan, &result);
    let read = read(&result);
    plan.recycle(result);
    Ok((scores, nees, read?))
}

/// The scenario's `[montecarlo] seeds` and `extra_seeds`, each checked to be an Integer
/// parameter; at least one.
pub fn seed_variables(plan: &Plan, extra_seeds: &[VarRef]) -> Result<Vec<VarRef>> {
    let mut seed_vars: Vec<VarRef> = plan
        .scenario
        .montecarlo
        .seeds
        .iter()
        .filter_map(|s| VarRef::parse(s))
        .collect();
    seed_vars.extend(extra_seeds.iter().cloned());
    for r in &seed_vars {
        check_seed_variable(plan, r)?;
    }
    if seed_vars.is_empty() {
        bail!(
            "scenario {}: no seed parameter to vary: add [montecarlo] seeds = [\"inst.seed\"] or pass --seed-var",
            plan.scenario.source.display()
        );
    }
    Ok(seed_vars)
}

/// Run `index`'s options: every seed variable set to `seed`, instance names suffixed with the
/// index (unique per worker thread).
pub fn seeded_options(seed_vars: &[VarRef], index: usize, seed: i32) -> RunOptions {
    RunOptions {
        instance_suffix: format!("#run{index}"),
        overrides: seed_vars
            .iter()
            .map(|r| (r.clone(), ParameterValue::Integer(seed)))
            .collect(),
    }
}

/// One run of [`stream_runs`]: its index, scores, NEES series and what the study read.
pub struct ScoredRun<T> {
    pub index: usize,
    pub scores: RunScores,
    pub nees: NeesSeries,
    pub read: T,
}

/// Runs seeds `first_seed ..` of `plan` like [`run`], but a few at a time (two per worker
/// thread) and hands each to `consume` in run order as soon as its batch is done: a study that
/// keeps sums instead of every run holds one batch of recordings at a time, and gets the same
/// bits for any thread count.
pub fn stream_runs<T: Send>(
    plan: &Plan,
    runs: usize,
    first_seed: i32,
    read: &(dyn Fn(&RunResult) -> Result<T> + Sync),
    consume: &mut dyn FnMut(ScoredRun<T>) -> Result<()>,
) -> Result<()> {
    let seed_vars = seed_variables(plan, &[])?;
    let batch = 2 * rayon::current_num_threads();
    for start in (0..runs).step_by(batch) {
        let done: Vec<Result<ScoredRun<T>>> = (start..(start + batch).min(runs))
            .into_par_iter()
            .map(|index| {
                let seed = first_seed.wrapping_add(index as i32);
                let options = seeded_options(&seed_vars, index, seed);
                let (scores, nees, read) = scored_run_with(plan, &options, read)
                    .with_context(|| format!("Monte Carlo run {index} (seed {seed})"))?;
                Ok(ScoredRun {
                    index,
                    scores,
                    nees,
                    read,
                })
            })
            .collect();
        for run in done {
            consume(run?)?;
        }
    }
    Ok(())
}

/// The 95 % band of a NEES (one degree of freedom) averaged over `runs` runs at one instant:
/// chi-square(N)/N (Bar-Shalom et al., ch. 5.4).
pub fn run_averaged_band(runs: usize) -> Band {
    average_band(runs as f64, runs)
}

/// One state's NEES series of every run, summed instant by instant in run order.
#[derive(Debug, Clone, Default)]
pub struct NeesOverRuns {
    sums: Vec<f64>,
    /// Whether every run's NEES was finite at the instant.
    finite: Vec<bool>,
    runs: usize,
}

impl NeesOverRuns {
    /// Adds one run's series (the same instants as the runs before).
    pub fn add(&mut self, nees: &[f64]) {
        if self.runs == 0 {
            self.sums = nees.to_vec();
            self.finite = nees.iter().map(|v| v.is_finite()).collect();
        } else {
            for ((sum, finite), v) in self.sums.iter_mut().zip(&mut self.finite).zip(nees) {
                *sum += v;
                *finite &= v.is_finite();
            }
        }
        self.runs += 1;
    }

    /// ANEES (the run-averaged NEES averaged over time) and the share of instants whose
    /// run-averaged NEES is inside [`run_averaged_band`], over the instants where every run's
    /// NEES is finite; NaN for both when there is none (or no run).
    pub fn consistency(&self) -> (f64, f64) {
        if self.runs == 0 {
            return (f64::NAN, f64::NAN);
        }
        let n = self.runs as f64;
        let band = run_averaged_band(self.runs);
        let (mut total, mut counted, mut inside) = (0.0, 0usize, 0usize);
        for (sum, _) in self.sums.iter().zip(&self.finite).filter(|(_, f)| **f) {
            let mean = sum / n;
            total += mean;
            counted += 1;
            if mean >= band.0 && mean <= band.1 {
                inside += 1;
            }
        }
        if counted == 0 {
            (f64::NAN, f64::NAN)
        } else {
            (total / counted as f64, inside as f64 / counted as f64)
        }
    }
}

/// One estimator's NIS and rows used (its degrees of freedom) of every run, summed instant by
/// instant in run order: for a consistent filter the run-summed NIS of an instant is
/// chi-square with the run-summed rows (Bar-Shalom et al., ch. 5.4).
#[derive(Debug, Clone, Default)]
pub struct NisOverRuns {
    sums: Vec<(f64, f64)>,
}

impl NisOverRuns {
    /// Adds one run's `(NIS, rows used)` per instant.
    pub fn add(&mut self, nis: &[(f64, f64)]) {
        if self.sums.is_empty() {
            self.sums = nis.to_vec();
        } else {
            for (sum, (value, dof)) in self.sums.iter_mut().zip(nis) {
                *sum = (sum.0 + value, sum.1 + dof);
            }
        }
    }

    /// The time average of the run-summed NIS per run-summed row (1 when consistent) and the
    /// share of instants inside the 95 % band of chi-square(run-summed rows), over the instants
    /// with a row in some run (the others had no update).
    pub fn consistency(&self) -> (f64, f64) {
        let used: Vec<&(f64, f64)> = self.sums.iter().filter(|(_, dof)| *dof > 0.0).collect();
        let inside = used
            .iter()
            .filter(|(value, dof)| {
                let band = (
                    chi_square_quantile(0.025, *dof),
                    chi_square_quantile(0.975, *dof),
                );
                (band.0..=band.1).contains(value)
            })
            .count();
        let count = used.len().max(1) as f64;
        (
            used.iter().map(|(v, d)| v / d).sum::<f64>() / count,
            inside as f64 / count,
        )
    }
}

/// Run `runs` seeds of `plan` in parallel; run i sets every `montecarlo.seeds` parameter (and
/// `extra_seeds`) to `first_seed + i`. `on_done` is called after each finished run.
pub fn run(
    plan: &Plan,
    runs: usize,
    first_seed: i32,
    extra_seeds: &[VarRef],
    on_done: &(dyn Fn() + Sync),
) -> Result<MonteCarloSummary> {
    if !(2..=MAX_RUNS).contains(&runs) {
        bail!("--runs must be 2 to {MAX_RUNS} (at least 2 for a spread), got {runs}");
    }
    let last_seed = i64::from(first_seed) + runs as i64 - 1;
    if i32::try_from(last_seed).is_err() {
        bail!("--first-seed {first_seed} with {runs} runs gives seeds beyond the 32-bit Integer range");
    }
    let seed_vars = seed_variables(plan, extra_seeds)?;
    let finished = AtomicUsize::new(0);
    let outcomes: Vec<Result<(RunScores, NeesSeries)>> = (0..runs)
        .into_par_iter()
        .map(|i| {
            let seed = first_seed.wrapping_add(i as i32); // In range: checked above.
            let outcome = scored_run(plan, &seeded_options(&seed_vars, i, seed));
            finished.fetch_add(1, Ordering::Relaxed);
            on_done();
            outcome.map_err(|e| e.context(format!("Monte Carlo run {i} (seed {seed})")))
        })
        .collect();
    let mut per_run = Vec::with_capacity(runs);
    for outcome in outcomes {
        per_run.push(outcome?);
    }
    let band = run_averaged_band(runs);
    let first = &per_run[0].0;
    let mut states = Vec::new();
    for (index, s) in first.states.iter().enumerate() {
        let collect = |f: &dyn Fn(&scoring::StateScore) -> f64| -> Vec<f64> {
            per_run
                .iter()
                .map(|(scores, _)| f(&scores.states[index]))
                .collect()
        };
        let nees = s
            .nees
            .map(|_| Spread::of(&collect(&|x| x.nees.map_or(f64::NAN, |v| v.0))));
        let key = (s.label.clone(), s.estimator.clone());
        let consistency = per_run[0]
            .1
            .iter()
            .position(|(k, _)| *k == key)
            .map(|series_index| {
                let mut over_runs = NeesOverRuns::default();
                for (_, series) in &per_run {
                    over_runs.add(&series[series_index].1);
                }
                over_runs.consistency()
            });
        states.push(StateSummary {
            label: s.label.clone(),
            estimator: s.estimator.clone(),
            unit: s.unit.clone(),
            rmse: Spread::of(&collect(&|x| x.rmse)),
            max_abs: Spread::of(&collect(&|x| x.max_abs)),
            nees,
            consistency,
        });
    }
    let nis = first
        .nis
        .iter()
        .enumerate()
        .map(|(index, s)| NisSummary {
            estimator: s.estimator.clone(),
            mean_nis: Spread::of(
                &per_run
                    .iter()
                    .map(|(r, _)| r.nis[index].mean_nis)
                    .collect::<Vec<_>>(),
            ),
            mean_dof: s.mean_dof,
        })
        .collect();
    let step_wall_time = first
        .step_wall_time
        .iter()
        .enumerate()
        .map(|(index, (name, _))| {
            (
                name.clone(),
                Spread::of(
                    &per_run
                        .iter()
                        .map(|(r, _)| r.step_wall_time[index].1)
                        .collect::<Vec<_>>(),
                ),
            )
        })
        .collect();
    Ok(MonteCarloSummary {
        scenario: plan.scenario.name.clone(),
        runs,
        band,
        states,
        nis,
        step_wall_time,
        per_run: per_run.into_iter().map(|(scores, _)| scores).collect(),
    })
}

/// The summary as a Markdown document.
pub fn to_markdown(summary: &MonteCarloSummary) -> String {
    let mut md = format!(
        "# Monte Carlo: {} ({} runs)\n\nMean ± sample standard deviation over the runs. \
         ANEES = NEES averaged over runs and time; \"in band\" = fraction of communication points \
         at which the run-averaged NEES lies in the 95 % band [{:.3}, {:.3}] of chi-square({})/{} \
         (about 0.95 for a consistent filter).\n\n",
        summary.scenario, summary.runs, summary.band.0, summary.band.1, summary.runs, summary.runs
    );
    md += "| state | estimator | RMSE | max abs error | time-avg NEES | ANEES | in band | unit |\n|---|---|---|---|---|---|---|---|\n";
    for s in &summary.states {
        let nees = s
            .nees
            .map_or("-".to_string(), |n| format!("{:.3} ± {:.3}", n.mean, n.std));
        let (anees, inside) = s
            .consistency
            .map_or(("-".to_string(), "-".to_string()), |(a, f)| {
                (format!("{a:.3}"), format!("{f:.3}"))
            });
        md += &format!(
            "| {} | {} | {:.4e} ± {:.1e} | {:.4e} ± {:.1e} | {} | {} | {} | {} |\n",
            s.label,
            s.estimator,
            s.rmse.mean,
            s.rmse.std,
            s.max_abs.mean,
            s.max_abs.std,
            nees,
            anees,
            inside,
            s.unit
        );
    }
    md += "\n| estimator | time-avg NIS | mean dof |\n|---|---|---|\n";
    for n in &summary.nis {
        md += &format!(
            "| {} | {:.3} ± {:.3} | {:.2} |\n",
            n.estimator, n.mean_nis.mean, n.mean_nis.std, n.mean_dof
        );
    }
    md += "\n| instance | doStep wall time [µs] |\n|---|---|\n";
    for (name, s) in &summary.step_wall_time {
        md += &format!("| {name} | {:.2} ± {:.2} |\n", s.mean * 1e6, s.std * 1e6);
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nees_over_runs_leaves_out_instants_with_a_non_finite_run() {
        let mut over_runs = NeesOverRuns::default();
        over_runs.add(&[1.0, f64::NAN, 9.0]);
        over_runs.add(&[1.0, 2.0, 9.0]);
        // Instants 0 and 2: run averages 1 and 9; chi-square(2)/2's 95 % band is
        // [0.025, 3.69], so only the first is inside.
        let band = run_averaged_band(2);
        assert!(band.0 < 1.0 && band.1 < 9.0, "{band:?}");
        assert_eq!(over_runs.consistency(), (5.0, 0.5));
        assert!(NeesOverRuns::default().consistency().0.is_nan());
    }

    #[test]
    fn nis_over_runs_tests_the_summed_nis_against_the_summed_rows() {
        let mut over_runs = NisOverRuns::default();
        let run = [(2.0, 2.0), (0.0, 0.0), (100.0, 2.0)];
        over_runs.add(&run);
        over_runs.add(&run);
        // Summed: (4, 4), no update, (200, 4); per row 1 and 50; chi-square(4)'s 95 % band is
        // [0.48, 11.1]: the first inside, the last not, the instant without rows left out.
        assert_eq!(over_runs.consistency(), (25.5, 0.5));
    }
}
