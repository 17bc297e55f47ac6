//! One scenario run end to end: load, (derive a sine-with-dwell amplitude), co-simulate, score,
//! write the CSV and the plots into the run's output folder.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};

use crate::cosim::{ParameterValue, Plan, RunOptions, RunResult};
use crate::fmu::LoadedFmu;
use crate::plot;
use crate::recording;
use crate::scenario::{Scenario, VarRef};
use crate::scoring::{self, RunScores};
use manoeuvres::{Manoeuvre, STANDARD_GRAVITY};

/// Where FMUs come from and where everything goes.
#[derive(Debug, Clone)]
pub struct Environment {
    /// Replaces `{fmu_dir}` in scenario paths.
    pub fmu_dir: PathBuf,
    /// The output folder; nothing is written outside it (FMUs are extracted below it too).
    pub out_dir: PathBuf,
}

impl Environment {
    /// Folder the FMU archives are extracted into (removed when the runs are done).
    pub fn work_dir(&self) -> PathBuf {
        self.out_dir.join(".fmu-work")
    }

    /// The work folder, removed when the guard drops: on success, on error and on a panic
    /// that unwinds, so no run leaves extracted FMUs behind.
    pub fn work_folder(&self) -> WorkFolder {
        WorkFolder(self.work_dir())
    }
}

/// Removes its folder (and everything in it) when dropped.
#[derive(Debug)]
pub struct WorkFolder(PathBuf);

impl WorkFolder {
    pub fn new(path: PathBuf) -> Self {
        Self(path)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for WorkFolder {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Default folder of the packaged FMUs: `$CARGO_TARGET_DIR/fmu` when set, else
/// `<workspace>/target/fmu` (where `cargo run --release -p packaging` writes them).
pub fn default_fmu_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir).join("fmu"),
        _ => workspace_root().join("target").join("fmu"),
    }
}

/// The archives `cargo run --release -p packaging` writes into [`default_fmu_dir`].
pub const PACKAGED_FMUS: [&str; 2] = ["ReferenceVehicle.fmu", "VehicleStateEstimator.fmu"];

/// `dir` when it holds every one of [`PACKAGED_FMUS`]; otherwise an error naming the missing
/// archive and the command that builds it.
pub fn packaged_fmus_in(dir: &Path) -> Result<PathBuf> {
    for archive in PACKAGED_FMUS {
        let path = dir.join(archive);
        if !path.is_file() {
            bail!(
                "{} missing: build the FMUs with `cargo run --release -p packaging`",
                path.display()
            );
        }
    }
    Ok(dir.to_path_buf())
}

/// [`default_fmu_dir`] once the packaged FMUs are in it ([`packaged_fmus_in`]): the check every
/// test that runs the FMUs makes first.
pub fn packaged_fmu_dir() -> Result<PathBuf> {
    packaged_fmus_in(&default_fmu_dir())
}

/// The workspace this binary was built from (this crate sits in `<workspace>/harness/master`).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Folder of the shipped scenario files, `<workspace>/harness/scenarios`.
pub fn scenario_dir() -> PathBuf {
    workspace_root().join("harness").join("scenarios")
}

/// `harness inspect`: loads the FMU, instantiates it once (so that a binary that cannot be
/// loaded or a GUID the binary does not know fails here, before any run) and writes its
/// variables to `out`. A closed `out` (e.g. `| head`) ends the listing with an `io::Error` of
/// kind BrokenPipe, which [`is_broken_pipe`] recognises.
pub fn inspect(fmu_path: &Path, work_dir: &Path, out: &mut dyn std::io::Write) -> Result<()> {
    let loaded = LoadedFmu::load(fmu_path, work_dir)?;
    let instance = loaded
        .import()
        .instantiate_cs("inspect", false, false)
        .map_err(|e| {
            anyhow!(
                "FMU {}: fmi2Instantiate failed ({e}); the binary cannot be loaded or does not accept the GUID {}",
                fmu_path.display(),
                loaded.guid
            )
        })?;
    drop(instance);
    writeln!(
        out,
        "{}: model {:?}, modelIdentifier {}, GUID {} (instantiated)",
        fmu_path.display(),
        loaded.model_name,
        loaded.model_identifier,
        loaded.guid
    )?;
    writeln!(
        out,
        "{:<34} {:>6} {:<12} {:<12} {:<10}",
        "variable", "vr", "causality", "variability", "type"
    )?;
    for v in &loaded.variables {
        writeln!(
            out,
            "{:<34} {:>6} {:<12} {:<12} {:<10?}",
            v.name,
            v.value_reference,
            v.causality.to_string(),
            v.variability.to_string(),
            v.var_type
        )?;
    }
    out.flush()?;
    Ok(())
}

/// Whether `error` comes from writing to a closed pipe (the reader went away: not a failure).
pub fn is_broken_pipe(error: &anyhow::Error) -> bool {
    error.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Parse "inst.variable=value" (value: true/false, integer, or float).
pub fn parse_override(text: &str) -> Result<(VarRef, ParameterValue)> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| anyhow!("--set {text:?}: expected instance.variable=value"))?;
    let r = VarRef::parse(name.trim())
        .ok_or_else(|| anyhow!("--set {text:?}: {name:?} is not of the form instance.variable"))?;
    let value = value.trim();
    let parsed = if value == "true" || value == "false" {
        ParameterValue::Boolean(value == "true")
    } else if let Ok(i) = value.parse::<i32>() {
        ParameterValue::Integer(i)
    } else if let Ok(x) = value.parse::<f64>() {
        ParameterValue::Real(x)
    } else {
        ParameterValue::String(value.to_string())
    };
    Ok((r, parsed))
}

/// Steering-wheel angle [rad] at which |ay| first reaches 0.3 g in a slowly increasing steer
/// recording (FMVSS 126 S7.5), linearly interpolated between samples.
pub fn angle_at_03g(result: &RunResult, ay_column: &str) -> Result<f64> {
    let ay = result.column(ay_column).ok_or_else(|| {
        anyhow!("slowly increasing steer run has no recorded column {ay_column:?}")
    })?;
    let wheel = result
        .column("manoeuvre.steering_wheel_angle")
        .ok_or_else(|| anyhow!("slowly increasing steer run recorded no steering-wheel angle"))?;
    let target = 0.3 * STANDARD_GRAVITY;
    for k in 1..ay.len() {
        if ay[k].abs() >= target && ay[k - 1].abs() < target {
            let fraction = (target - ay[k - 1].abs()) / (ay[k].abs() - ay[k - 1].abs());
            return Ok(wheel[k - 1] + fraction * (wheel[k] - wheel[k - 1]));
        }
    }
    bail!(
        "slowly increasing steer run: |{ay_column}| never reached 0.3 g = {target:.3} m/s2 (max {:.3})",
        ay.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    )
}

/// Resolve `[manoeuvre.amplitude_from_sis]` by running that scenario first. Returns the
/// amplitude used [rad] and the 0.3 g angle [rad].
pub fn resolve_sine_with_dwell(
    scenario: &mut Scenario,
    env: &Environment,
) -> Result<Option<(f64, f64)>> {
    let Some(section) = scenario.manoeuvre.clone() else {
        return Ok(None);
    };
    let Some(from) = section.amplitude_from_sis.clone() else {
        return Ok(None);
    };
    let Some(Manoeuvre::SineWithDwell(mut swd)) = scenario.manoeuvre()? else {
        unreachable!("validated: amplitude_from_sis only with a sine with dwell")
    };
    let sis_path = scenario.base_dir.join(&from.scenario);
    let sis = Scenario::from_file(&sis_path).with_context(|| {
        format!(
            "scenario {}: manoeuvre.amplitude_from_sis.scenario",
            scenario.source.display()
        )
    })?;
    let plan = Plan::new(sis, &env.fmu_dir, &env.work_dir())?;
    let result = plan.run(&RunOptions::default(), |_| {})?;
    let angle = angle_at_03g(&result, &from.lateral_acceleration)?;
    let cap = from.max_amplitude_deg.to_radians();
    swd.amplitude = (from.scale * angle.abs()).min(cap);
    let amplitude = swd.amplitude;
    let mut section = section;
    section.library = None;
    section.custom = Some(Manoeuvre::SineWithDwell(swd));
    section.amplitude_from_sis = None;
    scenario.manoeuvre = Some(section);
    Ok(Some((amplitude, angle)))
}

/// What a finished run left behind.
pub struct RunOutput {
    pub scenario: Scenario,
    pub result: RunResult,
    pub scores: RunScores,
    pub csv: PathBuf,
    pub plots: Vec<PathBuf>,
    /// Sine with dwell: (amplitude, 0.3 g angle) [rad].
    pub derived_amplitude: Option<(f64, f64)>,
    pub step_order: Vec<String>,
}

/// Labels of the states figure (seed 000 fig. 7.3) and of the derived-quantities figure
/// (figs. 7.4, 7.5); labels the scenario does not score are skipped.
pub const STATE_LABELS: [&str; 5] = ["vx", "vy", "yaw_rate", "omega_front", "omega_rear"];
pub const DERIVED_LABELS: [&str; 6] = [
    "ay",
    "sideslip",
    "slip_angle_front",
    "slip_angle_rear",
    "slip_front",
    "slip_rear",
];

/// Run `scenario` once, write `<out>/<name>.csv` and, with `plots`, its PNG figures.
pub fn run_scenario(
    mut scenario: Scenario,
    env: &Environment,
    overrides: &[(VarRef, ParameterValue)],
    plots: bool,
    progress: impl FnMut(f64),
) -> Result<RunOutput> {
    std::fs::create_dir_all(&env.out_dir)
        .with_context(|| format!("creating output folder {}", env.out_dir.display()))?;
    // A failed run must not leave the previous run's CSV looking current.
    let stale = env.out_dir.join(format!("{}.csv", scenario.name));
    match std::fs::remove_file(&stale) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(e).with_context(|| format!("removing the previous {}", stale.display()))
        }
        _ => {}
    }
    let derived_amplitude = resolve_sine_with_dwell(&mut scenario, env)?;
    let plan = Plan::new(scenario, &env.fmu_dir, &env.work_dir())?;
    let options = RunOptions {
        instance_suffix: String::new(),
        overrides: overrides.to_vec(),
    };
    let result = plan.run(&options, progress)?;
    let scores = scoring::score_run(&plan.scenario, &result);
    let name = plan.scenario.name.clone();
    let csv = env.out_dir.join(format!("{name}.csv"));
    recording::write_csv(&result, &csv)?;
    let mut plot_paths = Vec::new();
    if plots {
        let scored: Vec<String> = plan
            .scenario
            .scores
            .iter()
            .map(|s| s.label.clone())
            .collect();
        let pick = |labels: &[&str]| -> Vec<String> {
            labels
                .iter()
                .map(|l| l.to_string())
                .filter(|l| scored.contains(l))
                .collect()
        };
        let mut groups = vec![
            ("states", pick(&STATE_LABELS)),
            ("derived", pick(&DERIVED_LABELS)),
        ];
        let other: Vec<String> = scored
            .iter()
            .filter(|l| {
                !STATE_LABELS.contains(&l.as_str()) && !DERIVED_LABELS.contains(&l.as_str())
            })
            .cloned()
            .collect();
        groups.push(("other", other));
        for (suffix, labels) in groups {
            if labels.is_empty() {
                continue;
            }
            let panels = plot::estimate_panels(&plan.scenario, &result, &labels);
            let path = env.out_dir.join(format!("{name}_{suffix}.png"));
            plot::draw_panels(&path, &format!("{name}: {suffix}"), &panels, 2)?;
            plot_paths.push(path);
        }
        let course = plan.manoeuvre.clone();
        let course_fn = course
            .as_ref()
            .filter(|m| m.path_lateral_position(0.0).is_some())
            .map(|m| move |x: f64| m.path_lateral_position(x).unwrap_or(0.0));
        let panels = plot::manoeuvre_panels(
            &result,
            course_fn.as_ref().map(|f| f as &dyn Fn(f64) -> f64),
        );
        if !panels.is_empty() {
            let path = env.out_dir.join(format!("{name}_manoeuvre.png"));
            plot::draw_panels(
                &path,
                &format!("{name}: manoeuvre"),
                &panels,
                panels.len().min(3),
            )?;
            plot_paths.push(path);
        }
    }
    let step_order = plan.step_order();
    Ok(RunOutput {
        scenario: plan.scenario.clone(),
        result,
        scores,
        csv,
        plots: plot_paths,
        derived_amplitude,
        step_order,
    })
}

/// Plain-text table of the state scores (and NIS) for stdout.
pub fn scores_table(scores: &RunScores) -> String {
    let mut out = format!(
        "{:<18} {:<14} {:>12} {:>12} {:>10} {:>21}\n",
        "state", "estimator", "RMSE", "max |e|", "NEES", "95% band"
    );
    for s in &scores.states {
        let (nees, band) = match s.nees {
            Some((n, (lo, hi))) => (format!("{n:.3}"), format!("[{lo:.3}, {hi:.3}]")),
            None => ("-".into(), "-".into()),
        };
        out += &format!(
            "{:<18} {:<14} {:>12.4e} {:>12.4e} {:>10} {:>21}  {}\n",
            s.label, s.estimator, s.rmse, s.max_abs, nees, band, s.unit
        );
    }
    for n in &scores.nis {
        out += &format!(
            "NIS {:<14} mean {:.3} (mean dof {:.2}, 95% band [{:.3}, {:.3}], {} updates)\n",
            n.estimator, n.mean_nis, n.mean_dof, n.band.0, n.band.1, n.updates
        );
    }
    for (instance, seconds) in &scores.step_wall_time {
        out += &format!("doStep wall time {instance:<14} {:.2} us\n", seconds * 1e6);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_archive_is_named_with_the_command_that_builds_it() {
        // Removed when the test ends, also when it fails.
        let scratch = WorkFolder::new(
            std::env::temp_dir().join(format!("runner-packaged-{}", std::process::id())),
        );
        let dir = scratch.path().to_path_buf();
        std::fs::create_dir_all(&dir).unwrap();
        let missing = format!("{:#}", packaged_fmus_in(&dir).unwrap_err());
        assert!(
            missing.contains("ReferenceVehicle.fmu missing"),
            "{missing}"
        );
        assert!(
            missing.contains("cargo run --release -p packaging"),
            "{missing}"
        );
        std::fs::write(dir.join(PACKAGED_FMUS[0]), b"").unwrap();
        let missing = format!("{:#}", packaged_fmus_in(&dir).unwrap_err());
        assert!(
            missing.contains("VehicleStateEstimator.fmu missing"),
            "{missing}"
        );
        std::fs::write(dir.join(PACKAGED_FMUS[1]), b"").unwrap();
        assert_eq!(packaged_fmus_in(&dir).unwrap(), dir);
    }
}
