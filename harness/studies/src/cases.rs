//! `harness cases`: runs one chunk of a campaign's cases and prints every case's scores.
//!
//! The campaign runner (`python -m vse_campaign`, harness/campaign) expands a campaign file into
//! cases and hands each Dask task a chunk file; the co-simulation stays in this master. A chunk
//! file is TOML:
//!
//! ```toml
//! scenario = "/abs/path/seed000_ramp_high_ay.toml"
//! instances = ["vehicle", "UKF"]        # optional: keep only these [[fmu]] instances
//! [[case]]
//! id = 17
//! manoeuvre = "seed000_ramp_moderate_ay"           # optional: a library manoeuvre instead
//! parameter_files = { vehicle = ["/abs/car.ssv"] } # optional: replaces the instance's files
//! set = { "vehicle.seed" = 18, "UKF.process_noise_std_vy" = 1e-4 }
//! ```
//!
//! Output (stdout): CSV rows `case,field,value`, every row of one case together, written as soon
//! as the case ends. Fields: `status` (`ok` or `error`), `error` (the message), `wall_time` [s],
//! and the scores named by [`score_fields`]. Numbers are written in Rust's shortest round-trip
//! form, so a reader gets the same bits. Each case runs through [`montecarlo::scored_run`], the
//! function every `harness montecarlo` run goes through, so equal parameters give equal scores.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use rayon::prelude::*;
use serde::Deserialize;

use fmi_master::cosim::{convert_value, ParameterValue, Plan, RunOptions};
use fmi_master::montecarlo;
use fmi_master::runner::{resolve_sine_with_dwell, Environment, WorkFolder};
use fmi_master::scenario::{Scenario, VarRef};
use fmi_master::scoring::RunScores;

/// A chunk file as the campaign runner writes it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Chunk {
    pub scenario: PathBuf,
    #[serde(default)]
    pub instances: Vec<String>,
    #[serde(default, rename = "case")]
    pub cases: Vec<Case>,
}

/// One case: what it changes in the scenario.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    pub id: u64,
    #[serde(default)]
    pub manoeuvre: Option<String>,
    #[serde(default)]
    pub parameter_files: BTreeMap<String, Vec<String>>,
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
}

/// What makes two cases need different plans (FMUs loaded and bound anew).
type Variant = (Option<String>, BTreeMap<String, Vec<String>>);

impl Case {
    fn variant(&self) -> Variant {
        (self.manoeuvre.clone(), self.parameter_files.clone())
    }
}

/// Read and check a chunk file; errors name the file.
pub fn read_chunk(path: &Path) -> Result<Chunk> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading chunk file {}", path.display()))?;
    toml::from_str(&text).with_context(|| format!("chunk file {}", path.display()))
}

/// Keep only the `[[fmu]]` instances named in `keep` and the connections between them (as the
/// co-simulation benchmark does for its UKF-only run); an empty `keep` keeps everything.
pub fn keep_instances(scenario: &mut Scenario, keep: &[String]) -> Result<()> {
    if keep.is_empty() {
        return Ok(());
    }
    for name in keep {
        if !scenario.fmus.iter().any(|f| &f.name == name) {
            bail!(
                "scenario {}: instances: no [[fmu]] named {name:?} (the scenario has {})",
                scenario.source.display(),
                scenario
                    .fmus
                    .iter()
                    .map(|f| f.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let kept = |name: &str| {
        keep.iter()
            .any(|k| k == name.split('.').next().unwrap_or(name))
    };
    scenario.fmus.retain(|f| kept(&f.name));
    scenario
        .connections
        .retain(|c| kept(&c.from) && kept(&c.to));
    Ok(())
}

/// The scenario of one variant: the library manoeuvre and parameter files it names.
fn variant_scenario(base: &Scenario, variant: &Variant) -> Result<Scenario> {
    let mut scenario = base.clone();
    let (manoeuvre, files) = variant;
    if let Some(name) = manoeuvre {
        let section = scenario.manoeuvre.as_mut().ok_or_else(|| {
            anyhow!("manoeuvre {name:?}: the scenario has no [manoeuvre] section to replace")
        })?;
        section.library = Some(name.clone());
        section.custom = None;
        section.amplitude_from_sis = None;
    }
    for (instance, list) in files {
        let fmu = scenario
            .fmus
            .iter_mut()
            .find(|f| &f.name == instance)
            .ok_or_else(|| anyhow!("parameter_files: no [[fmu]] instance named {instance:?}"))?;
        fmu.parameter_files = list.clone();
    }
    scenario.validate()?;
    Ok(scenario)
}

/// One plan per variant, each with its own extraction folder (two plans may load the same
/// archive). A variant whose plan fails keeps its error, which each of its cases reports.
fn plans_for(
    base: &Scenario,
    cases: &[Case],
    fmu_dir: &Path,
    work: &Path,
) -> BTreeMap<Variant, Result<Plan, String>> {
    let mut plans = BTreeMap::new();
    for case in cases {
        let variant = case.variant();
        if plans.contains_key(&variant) {
            continue;
        }
        let env = Environment {
            fmu_dir: fmu_dir.to_path_buf(),
            out_dir: work.join(format!("variant{}", plans.len())),
        };
        let plan = variant_scenario(base, &variant)
            .and_then(|mut scenario| {
                resolve_sine_with_dwell(&mut scenario, &env)?;
                Plan::new(scenario, &env.fmu_dir, &env.work_dir())
            })
            .map_err(|e| format!("{e:#}"));
        plans.insert(variant, plan);
    }
    plans
}

/// The overrides of `case.set`, typed by the FMU's variables.
fn overrides(plan: &Plan, case: &Case) -> Result<Vec<(VarRef, ParameterValue)>> {
    case.set
        .iter()
        .map(|(name, value)| {
            let r = VarRef::parse(name)
                .ok_or_else(|| anyhow!("set {name:?}: expected instance.variable"))?;
            let var = plan.variable_of(&r).ok_or_else(|| {
                anyhow!("set {name:?}: no such instance or variable in the scenario")
            })?;
            let value = convert_value(var, value).with_context(|| format!("set {name:?}"))?;
            Ok((r, value))
        })
        .collect()
}

/// Every score of one run as (name, value): `<estimator>.<label>.rmse`, `.max_abs`, `.nees`
/// (when the score has a std), `<estimator>.nis` and `<instance>.step_wall_time` [s]. The names
/// of `harness montecarlo`'s runs.csv and of the campaign's Parquet columns.
pub fn score_fields(scores: &RunScores) -> Vec<(String, f64)> {
    let mut fields = Vec::new();
    for s in &scores.states {
        let stem = format!("{}.{}", s.estimator, s.label);
        fields.push((format!("{stem}.rmse"), s.rmse));
        fields.push((format!("{stem}.max_abs"), s.max_abs));
        if let Some((nees, _)) = s.nees {
            fields.push((format!("{stem}.nees"), nees));
        }
    }
    for n in &scores.nis {
        fields.push((format!("{}.nis", n.estimator), n.mean_nis));
    }
    for (instance, seconds) in &scores.step_wall_time {
        fields.push((format!("{instance}.step_wall_time"), *seconds));
    }
    fields
}

/// A number in the shortest form that reads back to the same bits (`NaN`, `inf` included).
fn exact(value: f64) -> String {
    format!("{value:?}")
}

/// The rows of one finished case.
fn case_rows(id: u64, outcome: &Result<RunScores>, wall_time: f64) -> Result<Vec<u8>> {
    let mut writer = csv::Writer::from_writer(Vec::new());
    let id = id.to_string();
    match outcome {
        Ok(scores) => {
            writer.write_record([id.as_str(), "status", "ok"])?;
            for (name, value) in score_fields(scores) {
                writer.write_record([id.as_str(), &name, &exact(value)])?;
            }
        }
        Err(error) => {
            writer.write_record([id.as_str(), "status", "error"])?;
            writer.write_record([id.as_str(), "error", &format!("{error:#}")])?;
        }
    }
    writer.write_record([id.as_str(), "wall_time", &exact(wall_time)])?;
    writer.into_inner().map_err(|e| anyhow!("csv buffer: {e}"))
}

/// Run one case on its variant's plan.
fn run_case(plans: &BTreeMap<Variant, Result<Plan, String>>, case: &Case) -> Result<RunScores> {
    let plan = match &plans[&case.variant()] {
        Ok(plan) => plan,
        Err(message) => bail!("{message}"),
    };
    let options = RunOptions {
        instance_suffix: format!("#case{}", case.id),
        overrides: overrides(plan, case)?,
    };
    montecarlo::scored_run(plan, &options).map(|(scores, _)| scores)
}

/// Run every case of the chunk file on `threads` threads, writing each case's rows to `out` as
/// it ends. A failing case is reported in its rows and does not stop the others; only a chunk
/// that cannot be read (or a scenario that does not parse) is an error.
pub fn run_chunk(
    chunk_file: &Path,
    fmu_dir: &Path,
    threads: usize,
    out: &mut (dyn Write + Send),
) -> Result<()> {
    let chunk = read_chunk(chunk_file)?;
    let mut scenario = Scenario::from_file(&chunk.scenario)?;
    keep_instances(&mut scenario, &chunk.instances)
        .with_context(|| format!("chunk file {}", chunk_file.display()))?;
    let work =
        WorkFolder::new(std::env::temp_dir().join(format!("harness-cases-{}", std::process::id())));
    let plans = plans_for(&scenario, &chunk.cases, fmu_dir, work.path());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .context("creating the worker threads")?;
    let out = Mutex::new(out);
    pool.install(|| {
        chunk.cases.par_iter().try_for_each(|case| -> Result<()> {
            let started = Instant::now();
            let outcome = run_case(&plans, case);
            let rows = case_rows(case.id, &outcome, started.elapsed().as_secs_f64())?;
            let mut out = out.lock().map_err(|_| anyhow!("output lock poisoned"))?;
            out.write_all(&rows)?;
            out.flush()?;
            Ok(())
        })
    })?;
    drop(plans);
    drop(work);
    Ok(())
}

/// `harness montecarlo`'s runs.csv: one row per run, `seed` then every [`score_fields`] column,
/// numbers in round-trip form (the campaign runner's identity test reads it). Written to a
/// temporary name and renamed.
pub fn write_runs_csv(path: &Path, first_seed: i32, per_run: &[RunScores]) -> Result<()> {
    let partial = path.with_extension("csv.partial");
    let mut writer = csv::Writer::from_path(&partial)
        .with_context(|| format!("creating {}", partial.display()))?;
    if let Some(first) = per_run.first() {
        let mut header = vec!["seed".to_string()];
        header.extend(score_fields(first).into_iter().map(|(name, _)| name));
        writer.write_record(&header)?;
    }
    for (i, scores) in per_run.iter().enumerate() {
        let seed = i64::from(first_seed) + i as i64;
        let mut row = vec![seed.to_string()];
        row.extend(score_fields(scores).into_iter().map(|(_, v)| exact(v)));
        writer.write_record(&row)?;
    }
    writer.flush()?;
    drop(writer);
    std::fs::rename(&partial, path)
        .with_context(|| format!("renaming {} to {}", partial.display(), path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_numbers_read_back_to_the_same_bits() {
        for value in [0.1, 1e-300, 3.0e-5, -2.5, f64::MAX, 123456.789] {
            assert_eq!(
                exact(value).parse::<f64>().unwrap().to_bits(),
                value.to_bits()
            );
        }
        assert_eq!(exact(f64::NAN), "NaN");
    }

    #[test]
    fn a_malformed_chunk_names_its_file_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("chunk.toml");
        std::fs::write(&path, "scenario = \"x.toml\"\n[[case]]\nid = \"seven\"\n").unwrap();
        let message = format!("{:#}", read_chunk(&path).unwrap_err());
        assert!(
            message.contains("chunk.toml") && message.contains("id"),
            "{message}"
        );
    }

    #[test]
    fn a_failed_case_reports_status_error_and_its_message() {
        let rows = case_rows(4, &Err(anyhow!("sample_time -1 refused")), 0.5).unwrap();
        let text = String::from_utf8(rows).unwrap();
        assert_eq!(
            text,
            "4,status,error\n4,error,sample_time -1 refused\n4,wall_time,0.5\n"
        );
    }
}
