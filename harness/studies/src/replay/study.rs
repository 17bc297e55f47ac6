//! The replay study on the real track recording (`harness replay-study`): the MBDS log
//! (`harness/logs/mbds/`) through the estimator FMU, per model and estimator, with and without
//! wheel speeds, scored on laps 2-6 beside the answers that need no filter (zero sideslip, the
//! steady-state linear single-track formula with the source's stiffnesses) and the source's
//! published estimators (`harness/logs/mbds/baselines.toml`).
//!
//! The car gets only its basic data (the map's `[estimator.parameters]`); every other parameter
//! is the FMU's default, as a new user meets it. The recording has no wheel speeds: "without"
//! feeds them as missing (the map leaves them out), "with" feeds free-rolling ones synthesised
//! from the INS speed, yaw rate and road-wheel angle (`[wheel_speeds]` of the baselines file).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use rayon::prelude::*;
use serde::Deserialize;

use fmi_master::cosim::ParameterValue;
use fmi_master::fmu::LoadedFmu;
use fmi_master::runner::workspace_root;
use fmi_master::scoring::score_state;
use fmi_master::yardstick::SingleTrackData;

use super::drive::{self, Feed};
use super::{parameters, prepare, Prepared};

/// The committed copy of the full study's CSV, relative to the workspace.
pub const COMMITTED_CSV: &str = "docs/data/mbds_replay.csv";

/// The study's log, map and facts, relative to the workspace.
const LOG: &str = "harness/logs/mbds/mbds_20140222_01_01_03_250lm.csv.gz";
const MAP: &str = "harness/logs/mbds/mbds.toml";
const BASELINES: &str = "harness/logs/mbds/baselines.toml";

/// The estimator models, by the study's name and the FMU's `model` item; the default first.
pub const MODELS: [(&str, &str); 3] = [
    ("grip", "single_track_grip"),
    ("model_a", "single_track_5_state"),
    ("model_b", "two_track_3_state"),
];

/// The grip model with the parameters `harness fit` writes when trained and validated on lap 1
/// alone (the first two thirds and the last third of it, no wheel speeds: what the log has),
/// replayed with the EKF on laps 2-6, which the fit never sees.
pub const FITTED_MODEL: &str = "grip_fitted_on_lap_1";

/// The estimators (the FMU's `estimator` items) of every study; the particle filter, at about
/// 1.8 ms a step, only in the full one.
pub const ESTIMATORS: [&str; 5] = ["lkf", "ekf", "ukf", "ukf_scaled", "luenberger"];
pub const FULL_ONLY_ESTIMATORS: [&str; 1] = ["particle_filter"];

/// One replay of the study.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Case {
    /// A name of [`MODELS`].
    pub model: String,
    /// An FMU `estimator` item.
    pub estimator: String,
    pub wheel_speeds: bool,
}

impl Case {
    pub fn new(model: &str, estimator: &str, wheel_speeds: bool) -> Case {
        Case {
            model: model.to_string(),
            estimator: estimator.to_string(),
            wheel_speeds,
        }
    }

    /// `with` or `without`, as the CSV writes it.
    pub fn wheel_speeds_label(&self) -> &'static str {
        if self.wheel_speeds {
            "with"
        } else {
            "without"
        }
    }
}

/// Every case of the study: the grip model fitted on lap 1 with the EKF, then each model with
/// each estimator, with and without wheel speeds.
pub fn cases(full: bool) -> Vec<Case> {
    let estimators = ESTIMATORS
        .iter()
        .chain(if full { &FULL_ONLY_ESTIMATORS[..] } else { &[] });
    let mut out = vec![
        Case::new(FITTED_MODEL, "ekf", true),
        Case::new(FITTED_MODEL, "ekf", false),
    ];
    for estimator in estimators {
        for (model, _) in MODELS {
            for wheel_speeds in [true, false] {
                out.push(Case::new(model, estimator, wheel_speeds));
            }
        }
    }
    out
}

/// The facts of `baselines.toml`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Baselines {
    pub laps_2_6_from_s: f64,
    pub yardstick: YardstickStiffness,
    pub published: Published,
    pub wheel_speeds: WheelSpeeds,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YardstickStiffness {
    pub cornering_stiffness_front: f64,
    pub cornering_stiffness_rear: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Published {
    pub zero_deg: f64,
    pub linear_kalman_filter_deg: f64,
    pub factor_graph_deg: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelSpeeds {
    pub radius: f64,
}

impl Baselines {
    pub fn read(path: &Path) -> Result<Baselines> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        toml::from_str(&text).with_context(|| format!("{}", path.display()))
    }
}

/// The figures of one case on laps 2-6.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub case: Case,
    /// Sideslip RMSE, deg; NaN when an estimate or its std was not finite on some row.
    pub rmse_deg: f64,
    /// Mean sideslip NEES (1 degree of freedom); NaN as `rmse_deg`.
    pub nees: f64,
    pub zero_rmse_deg: f64,
    pub yardstick_rmse_deg: f64,
    /// Largest |vx_est − INS vx|, m/s; NaN when vx_est was not finite on some row.
    pub max_vx_error_mps: f64,
    /// The FMU's error when it refused the configuration or failed (the figures are then NaN).
    pub error: Option<String>,
}

impl Row {
    /// The row as the CSV writes it (four decimals; `nan` for a non-finite figure; the
    /// estimator's figures empty where the FMU refused the configuration).
    pub fn csv_line(&self) -> String {
        let f = |x: f64| {
            if self.error.is_some() && x.is_nan() {
                String::new()
            } else if x.is_finite() {
                format!("{x:.4}")
            } else {
                String::from("nan")
            }
        };
        format!(
            "real,mbds_laps_2_6,{},{},{},{},{},{},{},{}",
            self.case.model,
            self.case.estimator,
            self.case.wheel_speeds_label(),
            f(self.rmse_deg),
            f(self.nees),
            f(self.zero_rmse_deg),
            f(self.yardstick_rmse_deg),
            f(self.max_vx_error_mps)
        )
    }
}

/// The recording read through its map, with everything the cases share.
pub struct Study {
    fmu: LoadedFmu,
    prepared: Prepared,
    pub baselines: Baselines,
    /// Laps 2-6.
    rows: std::ops::Range<usize>,
    /// The feeds with synthesised free-rolling wheel speeds.
    with_wheel_speeds: Vec<Feed>,
    pub zero_rmse_deg: f64,
    pub yardstick_rmse_deg: f64,
    /// The parameter file of [`FITTED_MODEL`] and the fit's summary, once [`Study::fit_on_lap_1`]
    /// ran.
    pub fitted: Option<(PathBuf, String)>,
    _work: fmi_master::runner::WorkFolder,
}

impl Study {
    /// Loads the estimator FMU at `fmu_path` (unpacked under `work`) and reads the recording.
    pub fn load(fmu_path: &Path, work: &Path) -> Result<Study> {
        let root = workspace_root();
        let work = fmi_master::runner::WorkFolder::new(work.to_path_buf());
        let fmu = LoadedFmu::load(fmu_path, work.path())?;
        let prepared = prepare(&root.join(LOG), &root.join(MAP), &fmu)?;
        let baselines = Baselines::read(&root.join(BASELINES))?;
        let grid = &prepared.grid;
        let first = (0..grid.rows)
            .find(|&n| grid.time(n) >= baselines.laps_2_6_from_s - 1e-6)
            .ok_or_else(|| anyhow!("the recording ends before laps 2-6"))?;
        let rows = first..grid.rows;
        let feed = |name: &str| -> Result<&[f64]> {
            prepared
                .feeds
                .iter()
                .find(|f| f.input == name)
                .map(|f| f.values.as_slice())
                .ok_or_else(|| anyhow!("map {MAP} feeds no {name}"))
        };
        let (delta, vx, yaw_rate) = (
            feed("steering_angle")?,
            feed("vx_meas")?,
            feed("yaw_rate_meas")?,
        );
        let car = car_data(&prepared, &baselines)?;
        let with_wheel_speeds = synthesised_wheel_speeds(
            &prepared.feeds,
            (delta, vx, yaw_rate),
            car.lf,
            baselines.wheel_speeds.radius,
        );
        let truth = reference(&prepared, "sideslip")?;
        let zero = vec![0.0; rows.len()];
        let yardstick: Vec<f64> = rows
            .clone()
            .map(|n| car.steady_state_sideslip(vx[n], delta[n]))
            .collect();
        let rmse = |estimate: &[f64]| {
            score_state(
                "sideslip",
                "",
                "deg",
                &truth[rows.clone()],
                estimate,
                None,
                180.0 / std::f64::consts::PI,
            )
            .rmse
        };
        Ok(Study {
            zero_rmse_deg: rmse(&zero),
            yardstick_rmse_deg: rmse(&yardstick),
            fmu,
            prepared,
            baselines,
            rows,
            with_wheel_speeds,
            fitted: None,
            _work: work,
        })
    }

    /// `harness fit` of the default model trained and validated on lap 1 alone, writing
    /// `fitted_on_lap_1.ssv` into `out` (the [`FITTED_MODEL`] cases replay it).
    pub fn fit_on_lap_1(&mut self, out: &Path) -> Result<()> {
        let root = workspace_root();
        let (start, end) = (self.prepared.grid.start, self.baselines.laps_2_6_from_s);
        let split = start + (end - start) * 2.0 / 3.0;
        let path = out.join("fitted_on_lap_1.ssv");
        let outcome = super::fit::fit(&super::fit::FitOptions {
            log: root.join(LOG),
            map: root.join(MAP),
            parameters: None,
            fmu: self.fmu.path.clone(),
            model: super::fit::FitModel::Grip,
            out: path.clone(),
            train: Some((start, split)),
            validate: Some((split, end - 0.5 * self.prepared.grid.step)),
        })?;
        self.fitted = Some((path, outcome.summary()));
        Ok(())
    }

    /// Replays `case` and scores it on laps 2-6.
    pub fn run(&self, case: &Case) -> Result<Row> {
        let estimator = self.enumeration("estimator", &case.estimator)?;
        let values = if case.model == FITTED_MODEL {
            let (file, _) = self.fitted.as_ref().ok_or_else(|| {
                anyhow!("{FITTED_MODEL}: run Study::fit_on_lap_1 before its cases")
            })?;
            parameters(&self.fmu, &self.prepared, Some(file), &[estimator])?
        } else {
            let model = MODELS
                .iter()
                .find(|(name, _)| *name == case.model)
                .map(|(_, item)| *item)
                .ok_or_else(|| anyhow!("model {:?}: expected one of {MODELS:?}", case.model))?;
            let extra = [self.enumeration("model", model)?, estimator];
            parameters(&self.fmu, &self.prepared, None, &extra)?
        };
        let feeds = if case.wheel_speeds {
            &self.with_wheel_speeds
        } else {
            &self.prepared.feeds
        };
        let recording = drive::run(&self.fmu, &values, &self.prepared.grid, feeds)
            .with_context(|| format!("{case:?}"))?;
        let column = |name: &str| {
            recording
                .column(name)
                .map(|c| &c[self.rows.clone()])
                .ok_or_else(|| anyhow!("the estimator FMU has no output {name}"))
        };
        let truth = &reference(&self.prepared, "sideslip")?[self.rows.clone()];
        let sideslip = score_state(
            "sideslip",
            &case.estimator,
            "deg",
            truth,
            column("sideslip_est")?,
            Some(column("sideslip_std")?),
            180.0 / std::f64::consts::PI,
        );
        let finite = sideslip.non_finite == 0;
        let vx_truth = &reference(&self.prepared, "vx")?[self.rows.clone()];
        let max_vx_error = column("vx_est")?
            .iter()
            .zip(vx_truth)
            .map(|(e, t)| (e - t).abs())
            .try_fold(0.0f64, |m, e| e.is_finite().then(|| m.max(e)))
            .unwrap_or(f64::NAN);
        Ok(Row {
            case: case.clone(),
            rmse_deg: if finite { sideslip.rmse } else { f64::NAN },
            nees: match sideslip.nees {
                Some((nees, _)) if finite => nees,
                _ => f64::NAN,
            },
            zero_rmse_deg: self.zero_rmse_deg,
            yardstick_rmse_deg: self.yardstick_rmse_deg,
            max_vx_error_mps: max_vx_error,
            error: None,
        })
    }

    /// [`Study::run`], with an FMU error recorded in the row instead of ending the study (a
    /// configuration the FMU refuses, such as an observer its pole placement cannot design).
    pub fn run_or_record(&self, case: &Case) -> Row {
        self.run(case).unwrap_or_else(|e| Row {
            case: case.clone(),
            rmse_deg: f64::NAN,
            nees: f64::NAN,
            zero_rmse_deg: self.zero_rmse_deg,
            yardstick_rmse_deg: self.yardstick_rmse_deg,
            max_vx_error_mps: f64::NAN,
            error: Some(fmu_error(&format!("{e:#}"))),
        })
    }

    /// Every case, two at a time (the machine's cores), in the order given.
    pub fn run_all(&self, cases: &[Case]) -> Result<Vec<Row>> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .map_err(|e| anyhow!("thread pool: {e}"))?;
        Ok(pool.install(|| {
            cases
                .par_iter()
                .map(|case| self.run_or_record(case))
                .collect()
        }))
    }

    fn enumeration(
        &self,
        name: &str,
        item: &str,
    ) -> Result<(fmi_master::fmu::VariableInfo, ParameterValue)> {
        let var = drive::parameter(&self.fmu, name)?.clone();
        let number = self
            .fmu
            .enumeration_items(name)
            .iter()
            .find(|(n, _)| n == item)
            .map(|&(_, number)| number)
            .ok_or_else(|| anyhow!("the estimator FMU has no {name} {item:?}"))?;
        Ok((var, ParameterValue::Integer(number)))
    }
}

/// The FMU's own words from a failed run's error: its last `ERROR:` message, else the error.
fn fmu_error(text: &str) -> String {
    text.rsplit_once("ERROR: ")
        .map_or(text, |(_, message)| message)
        .trim()
        .to_string()
}

/// The reference channel `name` of the map, SI, on every grid row.
fn reference<'a>(prepared: &'a Prepared, name: &str) -> Result<&'a [f64]> {
    prepared
        .references
        .iter()
        .find(|(c, _)| c.target == name)
        .map(|(_, v)| v.as_slice())
        .ok_or_else(|| anyhow!("map {MAP} has no reference.{name}"))
}

/// The car's linear single-track data: mass and axle distances from the map, the yardstick's
/// cornering stiffnesses from the baselines file.
fn car_data(prepared: &Prepared, baselines: &Baselines) -> Result<SingleTrackData> {
    let value = |name: &str| {
        prepared
            .map
            .parameters
            .get(name)
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            .ok_or_else(|| anyhow!("map {MAP}: [estimator.parameters] has no number {name}"))
    };
    Ok(SingleTrackData {
        mass: value("mass")?,
        lf: value("cog_to_front_axle")?,
        lr: value("cog_to_rear_axle")?,
        cf: baselines.yardstick.cornering_stiffness_front,
        cr: baselines.yardstick.cornering_stiffness_rear,
    })
}

/// `feeds` with free-rolling wheel speeds from the INS in place of the missing ones:
/// ω_front = (vx cos δ + lf r sin δ) / radius, ω_rear = vx / radius (the front wheel's speed
/// along its own heading, the rear's the CoG's, both without slip).
fn synthesised_wheel_speeds(
    feeds: &[Feed],
    (delta, vx, yaw_rate): (&[f64], &[f64], &[f64]),
    lf: f64,
    radius: f64,
) -> Vec<Feed> {
    let front: Vec<f64> = (0..vx.len())
        .map(|n| (vx[n] * delta[n].cos() + lf * yaw_rate[n] * delta[n].sin()) / radius)
        .collect();
    let rear: Vec<f64> = vx.iter().map(|v| v / radius).collect();
    let mut out: Vec<Feed> = feeds
        .iter()
        .filter(|f| f.input != "omega_front_meas" && f.input != "omega_rear_meas")
        .cloned()
        .collect();
    out.push(Feed {
        input: "omega_front_meas".to_string(),
        values: front,
    });
    out.push(Feed {
        input: "omega_rear_meas".to_string(),
        values: rear,
    });
    out
}

/// The CSV text of `rows` (the accuracy CSV's [`crate::summary::HEADER`] first).
pub fn csv_text(rows: &[Row]) -> String {
    let mut text = format!("{}\n", crate::summary::HEADER.join(","));
    for row in rows {
        text += &row.csv_line();
        text.push('\n');
    }
    text
}

/// The markdown section of the study.
pub fn markdown(study: &Study, rows: &[Row]) -> String {
    let p = &study.baselines.published;
    let f = |x: f64, digits: usize| {
        if x.is_finite() {
            format!("{x:.digits$}")
        } else {
            String::from("not finite")
        }
    };
    let mut text = String::from("## The real track recording (MBDS), laps 2-6\n\n");
    text += &format!(
        "The MBDS recording (982 kg car, 5.5 fast laps, INS sideslip reference; harness/logs/mbds/) \
         through the estimator FMU with the car's basic data and every other parameter at its \
         default, scored on laps 2-6 (t >= {} s). Wheel speeds \"with\": free-rolling ones \
         synthesised from the INS; \"without\": missing. Beside it, answers with no filter: zero \
         sideslip {} deg (published {:.2}), the steady-state linear single-track formula with the \
         source's cornering stiffnesses {:.0}/{:.0} kN/rad and the INS speed {} deg; the source's \
         published estimators: linear Kalman filter {:.2} deg, batch factor graph {:.2} deg.\n\n",
        study.baselines.laps_2_6_from_s,
        f(study.zero_rmse_deg, 2),
        p.zero_deg,
        study.baselines.yardstick.cornering_stiffness_front / 1000.0,
        study.baselines.yardstick.cornering_stiffness_rear / 1000.0,
        f(study.yardstick_rmse_deg, 2),
        p.linear_kalman_filter_deg,
        p.factor_graph_deg,
    );
    if let Some((file, _)) = &study.fitted {
        text += &format!(
            "`{FITTED_MODEL}`: the grip model with the parameters `harness fit` wrote when trained \
             and validated on lap 1 alone (`{}`; its summary: `fit_on_lap_1.txt`); laps 2-6 stay \
             unseen by the fit.\n\n",
            file.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned())
        );
    }
    text += "| model | estimator | wheel speeds | sideslip RMSE (deg) | NEES | max \\|vx error\\| (m/s) | vs zero | vs formula |\n";
    text += "| :--- | :--- | :--- | ---: | ---: | ---: | :--- | :--- |\n";
    for row in rows {
        if let Some(error) = &row.error {
            text += &format!(
                "| {} | {} | {} | - | - | - | FMU error: {} | |\n",
                row.case.model,
                row.case.estimator,
                row.case.wheel_speeds_label(),
                error.replace('|', "/")
            );
            continue;
        }
        let versus = |baseline: f64| {
            if !row.rmse_deg.is_finite() {
                "diverged"
            } else if row.rmse_deg <= baseline {
                "better"
            } else {
                "worse"
            }
        };
        text += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            row.case.model,
            row.case.estimator,
            row.case.wheel_speeds_label(),
            f(row.rmse_deg, 2),
            f(row.nees, 2),
            f(row.max_vx_error_mps, 2),
            versus(row.zero_rmse_deg),
            versus(row.yardstick_rmse_deg),
        );
    }
    text
}

/// What `harness replay-study` is given.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    pub fmu: PathBuf,
    pub out: PathBuf,
    /// The particle filter too (slow: about 1.8 ms a step).
    pub full: bool,
    /// Also write the CSV to [`COMMITTED_CSV`].
    pub update_committed: bool,
}

/// What the study wrote.
pub struct StudyOutcome {
    pub rows: Vec<Row>,
    pub markdown: PathBuf,
    pub csv: PathBuf,
    pub markdown_text: String,
}

/// `harness replay-study`: writes `mbds_replay.md` and `mbds_replay.csv` to `options.out`.
pub fn run_study(options: &StudyOptions) -> Result<StudyOutcome> {
    if options.update_committed && !options.full {
        bail!("--update-committed writes the full study's rows: add --full");
    }
    std::fs::create_dir_all(&options.out)
        .with_context(|| format!("creating {}", options.out.display()))?;
    let mut study = Study::load(&options.fmu, &options.out.join(".fmu-work"))?;
    study.fit_on_lap_1(&options.out)?;
    let rows = study.run_all(&cases(options.full))?;
    let markdown_text = markdown(&study, &rows);
    let markdown_path = options.out.join("mbds_replay.md");
    let csv_path = options.out.join("mbds_replay.csv");
    write_file(&markdown_path, &markdown_text)?;
    if let Some((_, summary)) = &study.fitted {
        write_file(&options.out.join("fit_on_lap_1.txt"), summary)?;
    }
    let csv = csv_text(&rows);
    write_file(&csv_path, &csv)?;
    if options.update_committed {
        write_file(&workspace_root().join(COMMITTED_CSV), &csv)?;
    }
    Ok(StudyOutcome {
        rows,
        markdown: markdown_path,
        csv: csv_path,
        markdown_text,
    })
}

/// Writes under a temporary name, renamed when complete.
fn write_file(path: &Path, text: &str) -> Result<()> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    let partial = fmi_master::recording::partial_name(path);
    std::fs::write(&partial, text).with_context(|| format!("writing {}", partial.display()))?;
    std::fs::rename(&partial, path)
        .with_context(|| format!("renaming {} to {}", partial.display(), path.display()))
}

/// `harness replay-study` on the command line: runs the study and prints its section.
pub fn command(
    fmu_dir: &Path,
    out: PathBuf,
    full: bool,
    update_committed: bool,
    stdout: &mut dyn std::io::Write,
) -> Result<()> {
    let outcome = run_study(&StudyOptions {
        fmu: super::estimator_path(None, fmu_dir),
        out,
        full,
        update_committed,
    })?;
    write!(stdout, "{}", outcome.markdown_text)?;
    writeln!(stdout, "markdown: {}", outcome.markdown.display())?;
    writeln!(stdout, "csv: {}", outcome.csv.display())?;
    if update_committed {
        writeln!(stdout, "committed copy: {COMMITTED_CSV}")?;
    }
    Ok(())
}
