//! Mismatch campaigns: every estimator on both of its
//! models against the ReferenceVehicle's full vehicle (model 3) with real cars' parameter files,
//! on the manoeuvres where a filter's model stops being right: a step steer, the ISO 3888-2 lane
//! change, a slow ramp to the limit, a sine with dwell and braking in a turn.
//!
//! `harness/scenarios/campaigns/campaigns.toml` lists the cars and manoeuvres; every row is the
//! base scenario `base.toml` (one truth, every estimator instance at its defaults) with the car's
//! parameter file on the vehicle and the car's basic data on the estimators ([`car`]), run
//! through the master. Per estimator: the sideslip RMSE and largest error, the time-averaged
//! NEES and the share of samples inside the chi-square(1) 95 % bound (the consistency
//! consistency targets), beside the zero-sideslip baseline (the RMSE of reporting 0).

pub mod accuracy;
pub mod car;
pub mod metrics;
pub mod yardstick;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use rayon::prelude::*;
use serde::Deserialize;

use fmi_master::cosim::ParameterValue;
use fmi_master::fmu::LoadedFmu;
use fmi_master::plot;
use fmi_master::report::Document;
use fmi_master::runner::{
    angle_at_03g, parse_override, run_scenario, scenario_dir, Environment, RunOutput, WorkFolder,
};
use fmi_master::scenario::{ManoeuvreSection, Scenario, VarRef};
use manoeuvres::Manoeuvre;

use metrics::Track;

/// The campaign file of the demo, below `harness/scenarios`.
pub const SHIPPED_CAMPAIGNS: &str = "campaigns/campaigns.toml";
/// The ReferenceVehicle instance of the base scenario; every other instance is an estimator.
pub const VEHICLE: &str = "vehicle";
/// A filter whose speed estimate leaves the truth by more than half (a run-away vx, a known
/// failure) or whose output is not finite has diverged.
const DIVERGED_SPEED_ERROR: f64 = 0.5;
/// The accuracy asked of the best estimator of a run: a sideslip RMSE of at most 0.3 deg.
const TARGET_RMSE_DEG: f64 = 0.3;
/// FMVSS 126 S7.6: the sine-with-dwell amplitude is capped at 270 deg of steering wheel.
const MAX_AMPLITUDE_DEG: f64 = 270.0;
/// The estimator instance of the FMU's default configuration (the grip model, the EKF): the one
/// a new user gets, judged per run against zero and the steady-state yardstick.
pub const DEFAULT_ESTIMATOR: &str = "EKF_G";
/// How far, deg, the default configuration may fall behind the steady-state yardstick on a run.
pub const YARDSTICK_MARGIN_DEG: f64 = 0.02;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampaignFile {
    pub base: String,
    pub cars: Vec<String>,
    /// The ReferenceVehicle models every car runs on, in order; the base scenario's (the car
    /// file's full vehicle) when not given.
    #[serde(default = "ReferenceModel::car_files_own")]
    pub reference_models: Vec<ReferenceModel>,
    #[serde(rename = "manoeuvre")]
    pub manoeuvres: Vec<CampaignManoeuvre>,
    #[serde(skip)]
    pub dir: PathBuf,
}

/// A ReferenceVehicle model the cars run on: `model` is its `model` parameter's value; `label`
/// names it in the tables and file names (none for the car files' own full vehicle).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceModel {
    pub model: i64,
    #[serde(default)]
    pub label: Option<String>,
}

impl ReferenceModel {
    /// The ReferenceVehicle's full vehicle, the model the car files select.
    const FULL_VEHICLE: i64 = 3;

    fn car_files_own() -> Vec<Self> {
        vec![Self {
            model: Self::FULL_VEHICLE,
            label: None,
        }]
    }

    /// The truth's name in the accuracy rows: its label, or "full vehicle" for the car files'
    /// own model.
    pub fn truth_name(&self) -> String {
        self.label
            .clone()
            .unwrap_or_else(|| "full vehicle".to_string())
    }

    /// The car's name in the tables on this model: the file's stem, with the label.
    pub fn car_label(&self, car_file: &Path) -> String {
        match &self.label {
            Some(label) => format!("{} ({label})", car_name(car_file)),
            None => car_name(car_file),
        }
    }

    /// The run's name part: the file's stem, with the label.
    fn file_label(&self, car_file: &Path) -> String {
        match &self.label {
            Some(label) => format!("{}_{}", car_name(car_file), label.replace(' ', "_")),
            None => car_name(car_file),
        }
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampaignManoeuvre {
    pub name: String,
    pub title: String,
    pub section: ManoeuvreSection,
    /// Sine with dwell: the slowly increasing steer row whose 0.3 g angle sets the amplitude.
    #[serde(default)]
    pub amplitude_from: Option<String>,
    #[serde(default)]
    pub scale: Option<f64>,
    /// Parameters of the vehicle for this manoeuvre only, set after the base scenario's and the
    /// car's (e.g. the sensors' faults).
    #[serde(default)]
    pub vehicle_parameters: toml::Table,
    /// Whether the population study runs it by default (`harness population` without
    /// `--manoeuvres`); long manoeuvres stay out of its hundreds of runs.
    #[serde(default = "yes")]
    pub in_population: bool,
    /// The ReferenceVehicle models (their `model` numbers) it runs on; every model of the
    /// campaign's `reference_models` when not given.
    #[serde(default)]
    pub models: Option<Vec<i64>>,
}

impl CampaignManoeuvre {
    /// Whether it runs on the ReferenceVehicle model `reference`.
    pub fn runs_on(&self, reference: &ReferenceModel) -> bool {
        self.models
            .as_ref()
            .is_none_or(|models| models.contains(&reference.model))
    }
}

fn yes() -> bool {
    true
}

impl CampaignFile {
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading the campaign file {}", path.display()))?;
        let mut file: CampaignFile =
            toml::from_str(&text).with_context(|| format!("campaign file {}", path.display()))?;
        file.dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        if file.reference_models.is_empty() {
            bail!(
                "campaign file {}: reference_models is empty; expected at least one ReferenceVehicle model",
                path.display()
            );
        }
        for (i, m) in file.manoeuvres.iter().enumerate() {
            if let Some(source) = &m.amplitude_from {
                let earlier = file.manoeuvres[..i]
                    .iter()
                    .find(|e| &e.name == source)
                    .is_some_and(|e| e.models.is_none() || e.models == m.models);
                if !earlier || m.scale.is_none() {
                    bail!(
                        "campaign file {}: manoeuvre {:?}: amplitude_from {source:?} must name a manoeuvre listed before it that runs on the same models, and `scale` must be given",
                        path.display(),
                        m.name
                    );
                }
            }
        }
        Ok(file)
    }
}

/// One estimator on one manoeuvre and car.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub manoeuvre: String,
    pub car: String,
    /// The truth's [`ReferenceModel::truth_name`].
    pub truth: String,
    /// The instance name, e.g. `UKF_scaled_B`.
    pub estimator: String,
    /// "A", "B" or "A+grip" (the instance's `model` parameter: 1, 2 or 3).
    pub model: &'static str,
    /// The estimator FMU's item names of the instance's `estimator` and `model` parameters
    /// (`ukf_scaled`, `two_track_3_state`).
    pub estimator_item: String,
    pub model_item: String,
    /// Sideslip RMSE and largest |error|, rad.
    pub rmse: f64,
    pub max_error: f64,
    pub mean_nees: f64,
    /// Share of samples with e²/σ² inside the chi-square(1) 95 % bound.
    pub share_inside: f64,
    /// RMS of the true sideslip (the RMSE of reporting 0) and its peak, rad.
    pub zero_baseline: f64,
    /// The steady-state single-track yardstick's sideslip RMSE on the run, rad ([`yardstick`]).
    pub yardstick: f64,
    pub peak_sideslip: f64,
    /// Largest relative error of `vx_est` after the first sample, where the true speed is at
    /// least [`metrics::RELATIVE_SPEED_FLOOR`] (2 % is asked for with the torques unknown).
    pub max_speed_error: f64,
    /// Largest |vx_est − true vx|, m/s, from the first estimate on; infinite for a non-finite
    /// estimate there.
    pub max_vx_error: f64,
    /// Time-averaged NEES of `vx_est` against `vx_std` and the share of samples inside the
    /// chi-square(1) 95 % bound, from the first estimate on (the guide's honest numbers for the
    /// speed as for the sideslip).
    pub speed_nees: f64,
    pub speed_share_inside: f64,
    pub diverged: bool,
}

/// Where a row's reported sideslip std stands against the consistency band.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Consistency {
    /// Time-averaged NEES 0.5-2 with at least 90 % of the samples inside the 95 % bound.
    InBand,
    /// NEES below 0.5 with at least 90 % inside: the std covers the error with room to spare.
    Conservative,
    /// NEES above 2 or fewer than 90 % inside: the std falls short of the error.
    Short,
}

impl Row {
    /// The row's [`Consistency`].
    pub fn consistency(&self) -> Consistency {
        if self.share_inside >= 0.9 && (0.5..=2.0).contains(&self.mean_nees) {
            Consistency::InBand
        } else if self.share_inside >= 0.9 && self.mean_nees < 0.5 {
            Consistency::Conservative
        } else {
            Consistency::Short
        }
    }

    pub fn worse_than_baseline(&self) -> bool {
        self.diverged || self.rmse.is_nan() || self.rmse > self.zero_baseline
    }

    /// More than [`YARDSTICK_MARGIN_DEG`] worse than the steady-state yardstick (or diverged).
    pub fn worse_than_yardstick(&self) -> bool {
        self.diverged
            || self.rmse.is_nan()
            || self.rmse > self.yardstick + YARDSTICK_MARGIN_DEG.to_radians()
    }

    /// How the row stands against zero and the yardstick: "ok", or what it fails.
    pub fn yardstick_verdict(&self) -> &'static str {
        match (self.worse_than_baseline(), self.worse_than_yardstick()) {
            (false, false) => "ok",
            (true, false) => "worse than 0",
            (false, true) => "worse than the yardstick",
            (true, true) => "worse than 0 and the yardstick",
        }
    }

    /// "diverged", "worse than 0" or "".
    pub fn flag(&self) -> &'static str {
        if self.diverged {
            "DIVERGED"
        } else if self.worse_than_baseline() {
            "WORSE THAN 0"
        } else {
            ""
        }
    }
}

#[derive(Debug, Clone)]
pub struct CampaignReport {
    pub rows: Vec<Row>,
    /// (caption, plot) per manoeuvre and car.
    pub plots: Vec<(String, PathBuf)>,
    /// Sine-with-dwell amplitude per car, deg of steering wheel.
    pub amplitudes: Vec<(String, f64)>,
    pub manoeuvres: Vec<(String, String)>,
    pub seconds: f64,
    /// The parameters set on the command line (`harness robustness --set`), as given.
    pub overrides: Vec<String>,
    /// The cars the command line kept (`--cars`); empty: every car of the campaign file.
    pub cars: Vec<String>,
}

/// What one car on one reference model contributes to a [`CampaignReport`].
#[derive(Default)]
struct CarOutcome {
    rows: Vec<Row>,
    plots: Vec<(String, PathBuf)>,
    amplitudes: Vec<(String, f64)>,
}

/// A parameter set on every run of a campaign, after the car's (`harness robustness --set`).
pub type Override = (VarRef, ParameterValue);

/// What the command line changes in the shipped campaign: the parameters set on every run
/// (`--set instance.variable=value`), parsed and as given (for the report), and the cars kept
/// (`--cars`, file stems; empty keeps every car).
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    pub parsed: Vec<Override>,
    pub given: Vec<String>,
    pub cars: Vec<String>,
}

impl Overrides {
    /// `given` parsed as `harness run --set` parses its values; an error names the text.
    pub fn parse(given: &[String]) -> Result<Self> {
        Ok(Self {
            parsed: given
                .iter()
                .map(|text| parse_override(text))
                .collect::<Result<_>>()?,
            given: given.to_vec(),
            cars: Vec::new(),
        })
    }

    /// These overrides with only the cars named in `cars` (file stems) kept.
    pub fn with_cars(mut self, cars: &[String]) -> Self {
        self.cars = cars.to_vec();
        self
    }

    /// Whether the campaign run differs from the shipped one (a parameter set or a car left out).
    pub fn changes_the_campaign(&self) -> bool {
        !self.given.is_empty() || !self.cars.is_empty()
    }
}

/// A campaign file with its base scenario and estimator instances resolved.
#[derive(Debug, Clone)]
pub struct Campaign {
    pub file: CampaignFile,
    pub base: Scenario,
    /// Every instance of the base scenario but the vehicle.
    pub estimators: Vec<String>,
    /// Parameters set on every run after the car's ([`Campaign::with_overrides`]).
    pub overrides: Vec<Override>,
}

impl Campaign {
    pub fn load(path: &Path) -> Result<Self> {
        let file = CampaignFile::from_file(path)?;
        let base = Scenario::from_file(&file.dir.join(&file.base))?;
        let estimators: Vec<String> = base
            .fmus
            .iter()
            .map(|f| f.name.clone())
            .filter(|n| n != VEHICLE)
            .collect();
        if estimators.is_empty() || file.cars.is_empty() || file.manoeuvres.is_empty() {
            bail!(
                "campaign file {}: needs cars, manoeuvres and a base scenario with estimator instances besides {VEHICLE:?}",
                path.display()
            );
        }
        check_estimator_models(&base)?;
        Ok(Campaign {
            file,
            base,
            estimators,
            overrides: Vec::new(),
        })
    }

    /// The campaign with `overrides` set on every run after the car's parameters; each must
    /// name an instance of the base scenario (the vehicle or an estimator).
    pub fn with_overrides(mut self, overrides: &[Override]) -> Result<Self> {
        for (target, _) in overrides {
            if !self.base.fmus.iter().any(|f| f.name == target.instance) {
                bail!(
                    "--set {}.{}: the campaigns' base scenario {} has no instance {:?}; expected one of {}",
                    target.instance,
                    target.variable,
                    self.file.base,
                    target.instance,
                    self.base
                        .fmus
                        .iter()
                        .map(|f| f.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
        self.overrides = overrides.to_vec();
        Ok(self)
    }

    /// The campaign on the cars `keep` alone (their files' stems, such as `ford_escort`), in
    /// the file's order; empty keeps every car. Each must name a car of the campaign file.
    pub fn with_cars(mut self, keep: &[String]) -> Result<Self> {
        if keep.is_empty() {
            return Ok(self);
        }
        let stems = self.car_stems();
        if let Some(unknown) = keep.iter().find(|k| !stems.contains(k)) {
            bail!(
                "--cars {unknown}: the campaign file lists no such car; expected one of {}",
                stems.join(", ")
            );
        }
        self.file
            .cars
            .retain(|car| keep.contains(&car_name(Path::new(car))));
        Ok(self)
    }

    /// The names of the campaign's cars, their files' stems, in the file's order.
    pub fn car_stems(&self) -> Vec<String> {
        self.file
            .cars
            .iter()
            .map(|car| car_name(Path::new(car)))
            .collect()
    }

    /// The campaign with the estimator instances `keep` alone (and the vehicle): a quick subset.
    /// Each must name an estimator instance of the base scenario.
    pub fn with_estimators(mut self, keep: &[&str]) -> Result<Self> {
        if let Some(unknown) = keep
            .iter()
            .find(|k| !self.estimators.iter().any(|e| e == *k))
        {
            bail!(
                "estimator {unknown:?}: the campaigns' base scenario {} has no such instance; expected one of {}",
                self.file.base,
                self.estimators.join(", ")
            );
        }
        let kept = |name: &str| name == VEHICLE || keep.contains(&name);
        self.base.fmus.retain(|f| kept(&f.name));
        self.base
            .connections
            .retain(|c| kept(&c.from) && kept(&c.to));
        self.estimators.retain(|e| keep.contains(&e.as_str()));
        Ok(self)
    }

    /// The estimator FMU of the base scenario, loaded to read its parameters.
    pub fn estimator_fmu(&self, env: &Environment) -> Result<LoadedFmu> {
        car::load_fmu_of(
            &self.base,
            &self.estimators[0],
            &env.fmu_dir,
            &env.work_dir(),
        )
    }

    /// The campaign's first reference model (the car files' full vehicle in the shipped one).
    pub fn first_reference(&self) -> &ReferenceModel {
        &self.file.reference_models[0]
    }

    /// Manoeuvre `m` (with its [manoeuvre] `section`) on the car of `car_file` on the
    /// ReferenceVehicle model `reference` through the master: the run and one [`Row`] per
    /// estimator. For a model other than the full vehicle the vehicle gets that `model`; the car
    /// file holds the static wheel loads models 1 and 2 take.
    pub fn run_one(
        &self,
        reference: &ReferenceModel,
        car_file: &Path,
        m: &CampaignManoeuvre,
        section: ManoeuvreSection,
        env: &Environment,
        estimator_fmu: &LoadedFmu,
    ) -> Result<(RunOutput, Vec<Row>)> {
        let name = reference.car_label(car_file);
        let mut scenario = self.base.clone();
        scenario.name = format!("campaign_{}_{}", m.name, reference.file_label(car_file));
        scenario.manoeuvre = Some(section);
        let vehicle = scenario
            .fmus
            .iter_mut()
            .find(|f| f.name == VEHICLE)
            .ok_or_else(|| {
                anyhow!(
                    "base scenario {}: no [[fmu]] named {VEHICLE:?}",
                    self.file.base
                )
            })?;
        vehicle.parameter_files = vec![car_file.to_string_lossy().into_owned()];
        if reference.model != ReferenceModel::FULL_VEHICLE {
            vehicle
                .parameters
                .insert("model".into(), toml::Value::Integer(reference.model));
        }
        for (name, value) in &m.vehicle_parameters {
            vehicle.parameters.insert(name.clone(), value.clone());
        }
        scenario.validate()?;
        let vehicle_values: Vec<(String, f64)> = m
            .vehicle_parameters
            .iter()
            .filter_map(|(name, value)| Some((name.clone(), value.as_float()?)))
            .chain(self.overrides.iter().filter_map(|(target, value)| {
                let number = match value {
                    ParameterValue::Real(x) => *x,
                    ParameterValue::Integer(x) => *x as f64,
                    _ => return None,
                };
                (target.instance == VEHICLE).then(|| (target.variable.clone(), number))
            }))
            .collect();
        let car_data = yardstick::single_track_data(car_file, reference.model, &vehicle_values)?;
        let mut overrides = car::estimator_overrides(car_file, &self.estimators, estimator_fmu)?;
        overrides.extend(self.overrides.iter().cloned());
        let output = run_scenario(scenario, env, &overrides, false, |_| {})
            .with_context(|| format!("campaign row {} on {name}", m.name))?;
        let yardstick = yardstick::rmse(&output.result, VEHICLE, &car_data)?;
        let run = RunNames {
            manoeuvre: &m.name,
            car: &name,
            truth: &reference.truth_name(),
        };
        let rows = self
            .estimators
            .iter()
            .map(|estimator| {
                row(&output, &run, estimator, estimator_fmu).map(|row| Row { yardstick, ..row })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok((output, rows))
    }

    /// The manoeuvre of the campaign file named `name`.
    pub fn manoeuvre(&self, name: &str) -> Result<&CampaignManoeuvre> {
        self.file
            .manoeuvres
            .iter()
            .find(|m| m.name == name)
            .ok_or_else(|| {
                anyhow!(
                    "campaign file {}: no manoeuvre {name:?}",
                    self.file.dir.display()
                )
            })
    }

    /// The campaign's tasks: every car (its file) on every reference model, in the file's order.
    pub fn cars_on_models(&self) -> Vec<(&ReferenceModel, PathBuf)> {
        let file = &self.file;
        file.reference_models
            .iter()
            .flat_map(|reference| {
                file.cars
                    .iter()
                    .map(move |car| (reference, file.dir.join(car)))
            })
            .collect()
    }

    /// Every manoeuvre of the campaign on the car of `car_file` on `reference`, in the file's
    /// order (a sine with dwell after the run its amplitude comes from), each handed to `each`
    /// with its sine-with-dwell amplitude (rad), its run and its rows: the runs of [`run`]'s
    /// task, for every study that runs the campaign.
    pub fn for_each_run(
        &self,
        reference: &ReferenceModel,
        car_file: &Path,
        env: &Environment,
        estimator_fmu: &LoadedFmu,
        mut each: impl FnMut(&CampaignManoeuvre, Option<f64>, RunOutput, Vec<Row>) -> Result<()>,
    ) -> Result<()> {
        let mut angles_at_03g: HashMap<String, f64> = HashMap::new();
        for m in self.file.manoeuvres.iter().filter(|m| m.runs_on(reference)) {
            let (section, amplitude) = manoeuvre_section(m, &angles_at_03g)?;
            let (output, rows) =
                self.run_one(reference, car_file, m, section, env, estimator_fmu)?;
            let is_source = self
                .file
                .manoeuvres
                .iter()
                .any(|o| o.amplitude_from.as_ref() == Some(&m.name));
            if is_source {
                angles_at_03g.insert(m.name.clone(), angle_at_03g(&output.result, "vehicle.ay")?);
            }
            each(m, amplitude, output, rows)?;
        }
        Ok(())
    }

    /// Every manoeuvre of the campaign on the car of `car_file` on `reference` ([`run`]'s task).
    fn run_car(
        &self,
        reference: &ReferenceModel,
        car_file: &Path,
        env: &Environment,
        estimator_fmu: &LoadedFmu,
        plots: bool,
    ) -> Result<CarOutcome> {
        let mut outcome = CarOutcome::default();
        let car = reference.car_label(car_file);
        self.for_each_run(
            reference,
            car_file,
            env,
            estimator_fmu,
            |m, amplitude, output, rows| {
                if let Some(amplitude) = amplitude {
                    outcome
                        .amplitudes
                        .push((car.clone(), amplitude.to_degrees()));
                }
                if plots {
                    outcome
                        .plots
                        .push(draw(&output, &rows, &m.title, &car, &env.out_dir)?);
                }
                outcome.rows.extend(rows);
                Ok(())
            },
        )?;
        Ok(outcome)
    }

    /// Manoeuvre `name` on the car of `car_file` as [`run`] runs it: a sine with dwell after the
    /// manoeuvre its amplitude comes from (whose rows are dropped). One [`Row`] per estimator.
    pub fn run_as_listed(
        &self,
        car_file: &Path,
        name: &str,
        env: &Environment,
        estimator_fmu: &LoadedFmu,
    ) -> Result<Vec<Row>> {
        let m = self.manoeuvre(name)?;
        let mut angles_at_03g = HashMap::new();
        if let Some(source) = &m.amplitude_from {
            let earlier = self.manoeuvre(source)?;
            let (output, _) = self.run_one(
                self.first_reference(),
                car_file,
                earlier,
                earlier.section.clone(),
                env,
                estimator_fmu,
            )?;
            angles_at_03g.insert(source.clone(), angle_at_03g(&output.result, "vehicle.ay")?);
        }
        let (section, _) = manoeuvre_section(m, &angles_at_03g)?;
        Ok(self
            .run_one(
                self.first_reference(),
                car_file,
                m,
                section,
                env,
                estimator_fmu,
            )?
            .1)
    }
}

/// The distinct names in the order they first appear.
pub(crate) fn distinct<'a>(names: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut seen: Vec<&str> = Vec::new();
    for name in names {
        if !seen.contains(&name) {
            seen.push(name);
        }
    }
    seen
}

/// A car's name in the tables: its parameter file's stem.
fn car_name(car_file: &Path) -> String {
    car_file.file_stem().map_or_else(
        || car_file.display().to_string(),
        |s| s.to_string_lossy().into_owned(),
    )
}

/// Runs every manoeuvre on every car of `file` (CSV of every run and, with `plots`, a sideslip
/// plot per run below `env.out_dir`), with `overrides` set on every run after the car's
/// parameters.
pub fn run(
    file: &Path,
    env: &Environment,
    plots: bool,
    overrides: &Overrides,
) -> Result<CampaignReport> {
    let started = Instant::now();
    let campaign = Campaign::load(file)?
        .with_overrides(&overrides.parsed)?
        .with_cars(&overrides.cars)?;
    let _work = WorkFolder::new(env.work_dir());
    let estimator_fmu = campaign.estimator_fmu(env)?;
    let mut report = CampaignReport {
        rows: Vec::new(),
        plots: Vec::new(),
        amplitudes: Vec::new(),
        manoeuvres: campaign
            .file
            .manoeuvres
            .iter()
            .map(|m| (m.name.clone(), m.title.clone()))
            .collect(),
        seconds: 0.0,
        overrides: overrides.given.clone(),
        cars: overrides.cars.clone(),
    };
    let runs = campaign.cars_on_models();
    // One car on one reference model per task: its manoeuvres run in order (a sine with dwell
    // takes its amplitude from the slow ramp before it), the tasks on rayon's threads. Every run
    // is seeded by its scenario alone and the results are collected in the order of `runs`, so
    // the report is the same with any number of threads.
    let outcomes = runs
        .par_iter()
        .map(|(reference, car_file)| {
            campaign.run_car(reference, car_file, env, &estimator_fmu, plots)
        })
        .collect::<Result<Vec<_>>>()?;
    for outcome in outcomes {
        report.amplitudes.extend(outcome.amplitudes);
        report.plots.extend(outcome.plots);
        report.rows.extend(outcome.rows);
    }
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// The sideslip of every estimator of one run against the truth, as a PNG, one panel per
/// estimator model (the run's `rows` name each estimator's) so that its six estimators and the
/// truth stay apart in colour and legend; (caption, path).
fn draw(
    output: &RunOutput,
    rows: &[Row],
    title: &str,
    car: &str,
    out: &Path,
) -> Result<(String, PathBuf)> {
    let path = out.join(format!("{}.png", output.scenario.name));
    let mut panels = Vec::new();
    for all in plot::estimate_panels(&output.scenario, &output.result, &["sideslip".into()]) {
        let mut models: Vec<&str> = Vec::new();
        for row in rows {
            if !models.contains(&row.model) {
                models.push(row.model);
            }
        }
        for model in models {
            let series = all
                .series
                .iter()
                .filter(|s| {
                    s.is_truth
                        || rows
                            .iter()
                            .any(|r| r.model == model && r.estimator == s.name)
                })
                .cloned()
                .collect();
            panels.push(plot::Panel {
                title: format!("{}, model {model}", all.title),
                x_label: all.x_label.clone(),
                y_label: all.y_label.clone(),
                series,
            });
        }
    }
    let caption = format!("{title} on the {car}: sideslip");
    // The full caption is wider than one panel: the plot's own title is the run's name.
    plot::draw_panels(&path, &output.scenario.name, &panels, 1)?;
    Ok((caption, path))
}

/// The row's [manoeuvre]: as written, or a sine with dwell with its amplitude (returned too,
/// rad) from the car's slowly increasing steer (`scale` × the 0.3 g angle, FMVSS 126 S7.6,
/// capped at 270 deg).
fn manoeuvre_section(
    m: &CampaignManoeuvre,
    angles_at_03g: &HashMap<String, f64>,
) -> Result<(ManoeuvreSection, Option<f64>)> {
    let mut section = m.section.clone();
    let (Some(source), Some(scale)) = (&m.amplitude_from, m.scale) else {
        return Ok((section, None));
    };
    let manoeuvre = match (&section.library, &section.custom) {
        (Some(name), None) => manoeuvres::library(name),
        (None, Some(custom)) => Some(custom.clone()),
        _ => None,
    };
    let Some(Manoeuvre::SineWithDwell(mut swd)) = manoeuvre else {
        bail!(
            "campaign manoeuvre {:?}: amplitude_from needs a sine with dwell",
            m.name
        );
    };
    let angle = angles_at_03g[source];
    swd.amplitude = (scale * angle.abs()).min(MAX_AMPLITUDE_DEG.to_radians());
    let amplitude = swd.amplitude;
    section.library = None;
    section.custom = Some(Manoeuvre::SineWithDwell(swd));
    Ok((section, Some(amplitude)))
}

/// Every estimator instance of `base` names its `model` (1, 2 or 3) and its `estimator` (an
/// integer, one of the FMU's items when it runs): the rows are labelled by them (A, B, A+grip;
/// the accuracy rows by the items), and an instance left at the FMU's default would need the
/// default written here a second time.
fn check_estimator_models(base: &Scenario) -> Result<()> {
    for fmu in base.fmus.iter().filter(|f| f.name != VEHICLE) {
        let model = fmu.parameters.get("model").and_then(|v| v.as_integer());
        let estimator = fmu.parameters.get("estimator").and_then(|v| v.as_integer());
        if !matches!(model, Some(1..=3)) || estimator.is_none() {
            bail!(
                "campaign base scenario {}: instance {:?} sets model = {:?} and estimator = {:?}; \
                 expected a `model` of 1, 2 or 3 and an integer `estimator`: the campaign labels \
                 its rows by them",
                base.source.display(),
                fmu.name,
                fmu.parameters.get("model"),
                fmu.parameters.get("estimator")
            );
        }
    }
    Ok(())
}

/// How the rows of one run name it.
struct RunNames<'a> {
    manoeuvre: &'a str,
    car: &'a str,
    truth: &'a str,
}

/// The item name of the estimator FMU's enumeration parameter `name` as `instance` of
/// `scenario` sets it.
fn item_of(scenario: &Scenario, fmu: &LoadedFmu, instance: &str, name: &str) -> Result<String> {
    let value = scenario
        .fmus
        .iter()
        .find(|f| f.name == instance)
        .and_then(|f| f.parameters.get(name))
        .and_then(|v| v.as_integer());
    let items = fmu.enumeration_items(name);
    items
        .iter()
        .find(|(_, number)| Some(i64::from(*number)) == value)
        .map(|(item, _)| item.clone())
        .ok_or_else(|| {
            anyhow!(
                "scenario {}: instance {instance:?} sets {name} = {value:?}; expected one of the estimator FMU's items {:?}",
                scenario.source.display(),
                items
            )
        })
}

/// The figures of `estimator` in one run.
fn row(output: &RunOutput, run: &RunNames, estimator: &str, fmu: &LoadedFmu) -> Result<Row> {
    let (scenario, result) = (&output.scenario, &output.result);
    let sideslip = Track::sideslip(result, VEHICLE, estimator)?;
    let vx = Track::of(result, VEHICLE, estimator, "vx")?;
    let (mean_nees, share_inside) = sideslip.consistency();
    // from the first estimate on, as max_speed_error
    let (speed_nees, speed_share_inside) = vx.consistency_from(scenario.step);
    let model = scenario
        .fmus
        .iter()
        .find(|f| f.name == estimator)
        .and_then(|f| f.parameters.get("model"))
        .and_then(|v| v.as_integer());
    Ok(Row {
        manoeuvre: run.manoeuvre.to_string(),
        car: run.car.to_string(),
        truth: run.truth.to_string(),
        estimator: estimator.to_string(),
        // 1, 2 or 3: `check_estimator_models`
        model: match model {
            Some(2) => "B",
            Some(3) => "A+grip",
            _ => "A",
        },
        estimator_item: item_of(scenario, fmu, estimator, "estimator")?,
        model_item: item_of(scenario, fmu, estimator, "model")?,
        rmse: sideslip.rmse(),
        max_error: sideslip.max_error_from(f64::NEG_INFINITY),
        mean_nees,
        share_inside,
        zero_baseline: sideslip.zero_baseline(),
        // set by the caller, which knows the car
        yardstick: f64::NAN,
        peak_sideslip: sideslip
            .from_time(f64::NEG_INFINITY)
            .fold(0.0f64, |p, k| p.max(sideslip.truth[k].abs())),
        // from the first estimate on: the instant before it is the start value of vx_initial
        max_speed_error: vx.max_relative_error_from(scenario.step, metrics::RELATIVE_SPEED_FLOOR),
        max_vx_error: vx.max_error_from(scenario.step),
        speed_nees,
        speed_share_inside,
        diverged: !sideslip.all_finite()
            || vx.max_relative_error_from(f64::NEG_INFINITY, 1.0) > DIVERGED_SPEED_ERROR,
    })
}

/// The shipped campaigns ([`SHIPPED_CAMPAIGNS`]) with the FMUs of `fmu_dir`, output below
/// `out_dir`, `overrides` set on every run.
pub fn run_shipped(
    fmu_dir: &Path,
    out_dir: &Path,
    plots: bool,
    overrides: &Overrides,
) -> Result<CampaignReport> {
    run(
        &scenario_dir().join(SHIPPED_CAMPAIGNS),
        &Environment {
            fmu_dir: fmu_dir.to_path_buf(),
            out_dir: out_dir.to_path_buf(),
        },
        plots,
        overrides,
    )
}

/// Fixed-point degrees of an angle in radians; "∞" for a non-finite one.
fn degrees(radians: f64, decimals: usize) -> String {
    let value = radians.to_degrees();
    if value.is_finite() {
        format!("{value:.decimals$}")
    } else {
        "∞".into()
    }
}

/// The median of sorted values (the mean of the middle two for an even count); NaN for none.
fn median_of_sorted(values: &[f64]) -> f64 {
    match values.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => values[n / 2],
        n => 0.5 * (values[n / 2 - 1] + values[n / 2]),
    }
}

/// One estimator instance over every run of the campaign.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatorSummary {
    pub estimator: String,
    pub model: &'static str,
    /// Sum of its sideslip RMSEs, rad.
    pub rmse_sum: f64,
    /// Median over its runs of the sideslip RMSE over the zero baseline (1: no better than
    /// reporting zero).
    pub median_baseline_ratio: f64,
    pub best_of_run: usize,
    pub worse_than_baseline: usize,
    pub in_band: usize,
    pub conservative: usize,
    pub short: usize,
    pub runs: usize,
}

/// The best estimator of one manoeuvre on one car, with the run's baseline.
pub struct RunSummary<'a> {
    pub best: &'a Row,
    /// The default configuration's row ([`DEFAULT_ESTIMATOR`]), where the campaign runs it.
    pub default: Option<&'a Row>,
    pub worse_than_baseline: usize,
    pub estimators: usize,
}

impl CampaignReport {
    /// The runs (manoeuvre × car) in order, each with its rows.
    pub fn runs(&self) -> Vec<&[Row]> {
        self.rows
            .chunk_by(|a, b| a.manoeuvre == b.manoeuvre && a.car == b.car)
            .collect()
    }

    /// Per run: the lowest sideslip RMSE among the estimators that did not diverge (or the
    /// first row if all did) and how many rows lose to the baseline.
    pub fn run_summaries(&self) -> Vec<RunSummary<'_>> {
        self.runs()
            .into_iter()
            .map(|rows| RunSummary {
                best: rows
                    .iter()
                    .filter(|r| !r.diverged)
                    .min_by(|a, b| a.rmse.total_cmp(&b.rmse))
                    .unwrap_or(&rows[0]),
                default: rows.iter().find(|r| r.estimator == DEFAULT_ESTIMATOR),
                worse_than_baseline: rows.iter().filter(|r| r.worse_than_baseline()).count(),
                estimators: rows.len(),
            })
            .collect()
    }

    /// How often each estimator instance is the best of a run, most wins first.
    pub fn wins(&self) -> Vec<(String, usize)> {
        let mut wins: Vec<(String, usize)> = Vec::new();
        for summary in self.run_summaries() {
            match wins
                .iter_mut()
                .find(|(name, _)| *name == summary.best.estimator)
            {
                Some((_, count)) => *count += 1,
                None => wins.push((summary.best.estimator.clone(), 1)),
            }
        }
        wins.sort_by_key(|(_, count)| std::cmp::Reverse(*count));
        wins
    }

    /// Per estimator instance, in the campaign's order: accuracy, wins and consistency over
    /// all runs.
    pub fn estimator_summaries(&self) -> Vec<EstimatorSummary> {
        let wins = self.wins();
        let mut names: Vec<&str> = Vec::new();
        for row in &self.rows {
            if !names.contains(&row.estimator.as_str()) {
                names.push(&row.estimator);
            }
        }
        names
            .into_iter()
            .map(|name| {
                let rows: Vec<&Row> = self.rows.iter().filter(|r| r.estimator == name).collect();
                let count = |c: Consistency| rows.iter().filter(|r| r.consistency() == c).count();
                let mut ratios: Vec<f64> = rows.iter().map(|r| r.rmse / r.zero_baseline).collect();
                ratios.sort_by(f64::total_cmp);
                EstimatorSummary {
                    estimator: name.to_string(),
                    model: rows[0].model,
                    rmse_sum: rows.iter().map(|r| r.rmse).sum(),
                    median_baseline_ratio: median_of_sorted(&ratios),
                    best_of_run: wins.iter().find(|(n, _)| n == name).map_or(0, |(_, c)| *c),
                    worse_than_baseline: rows.iter().filter(|r| r.worse_than_baseline()).count(),
                    in_band: count(Consistency::InBand),
                    conservative: count(Consistency::Conservative),
                    short: count(Consistency::Short),
                    runs: rows.len(),
                }
            })
            .collect()
    }

    fn estimator_rows(&self) -> Vec<Vec<String>> {
        self.estimator_summaries()
            .into_iter()
            .map(|e| {
                vec![
                    e.estimator,
                    e.model.into(),
                    degrees(e.rmse_sum, 2),
                    format!("{:.2}", e.median_baseline_ratio),
                    e.best_of_run.to_string(),
                    e.worse_than_baseline.to_string(),
                    format!("{} of {}", e.in_band, e.runs),
                    e.conservative.to_string(),
                    e.short.to_string(),
                ]
            })
            .collect()
    }

    fn summary_rows(&self) -> Vec<Vec<String>> {
        self.run_summaries()
            .iter()
            .map(|s| {
                let best = s.best;
                vec![
                    best.manoeuvre.clone(),
                    best.car.clone(),
                    degrees(best.peak_sideslip, 2),
                    degrees(best.zero_baseline, 3),
                    best.estimator.clone(),
                    degrees(best.rmse, 3),
                    if best.rmse.to_degrees() <= TARGET_RMSE_DEG {
                        "yes"
                    } else {
                        "no"
                    }
                    .into(),
                    format!("{} of {}", s.worse_than_baseline, s.estimators),
                    degrees(best.yardstick, 3),
                    s.default.map_or("-".into(), |d| degrees(d.rmse, 3)),
                    s.default.map_or("-", |d| d.yardstick_verdict()).into(),
                ]
            })
            .collect()
    }

    fn detail_rows(&self) -> Vec<Vec<String>> {
        self.rows
            .iter()
            .map(|r| {
                vec![
                    r.manoeuvre.clone(),
                    r.car.clone(),
                    r.estimator.clone(),
                    r.model.into(),
                    degrees(r.rmse, 3),
                    degrees(r.max_error, 2),
                    format!("{:.2}", r.mean_nees),
                    format!("{:.0} %", 100.0 * r.share_inside),
                    degrees(r.zero_baseline, 3),
                    degrees(r.yardstick, 3),
                    format!("{:.1} %", 100.0 * r.max_speed_error),
                    format!(
                        "{:.2} ({:.0} %)",
                        r.speed_nees,
                        100.0 * r.speed_share_inside
                    ),
                    r.flag().into(),
                ]
            })
            .collect()
    }

    /// The targets counted over the rows: the best RMSE at most 0.3 deg, no row
    /// worse than reporting zero, NEES 0.5-2 with at least 90 % inside the 95 % bound.
    pub fn verdict(&self) -> String {
        let summaries = self.run_summaries();
        let on_target = summaries
            .iter()
            .filter(|s| s.best.rmse.to_degrees() <= TARGET_RMSE_DEG)
            .count();
        let worse = self.rows.iter().filter(|r| r.worse_than_baseline()).count();
        let diverged = self.rows.iter().filter(|r| r.diverged).count();
        let consistent = self
            .rows
            .iter()
            .filter(|r| r.consistency() == Consistency::InBand)
            .count();
        let speed_off = self
            .rows
            .iter()
            .filter(|r| r.max_speed_error > metrics::SPEED_LIMIT)
            .count();
        let speed_overconfident = self
            .rows
            .iter()
            .filter(|r| !(r.speed_nees <= 2.0 && r.speed_share_inside >= 0.9))
            .count();
        let default_failing = summaries
            .iter()
            .filter_map(|s| s.default)
            .filter(|d| d.worse_than_baseline() || d.worse_than_yardstick())
            .count();
        let default_runs = summaries.iter().filter(|s| s.default.is_some()).count();
        format!(
            "The default configuration ({DEFAULT_ESTIMATOR}) is worse than reporting zero or more than \
             {YARDSTICK_MARGIN_DEG} deg worse than the steady-state yardstick in {default_failing} of \
             {default_runs} runs. \
             The best RMSE is at most {TARGET_RMSE_DEG} deg in {on_target} of {} runs; \
             {worse} of {} rows are worse than reporting zero ({diverged} diverged); {consistent} rows meet \
             the consistency band (NEES 0.5-2 with at least 90 % inside the bound). With the torques unknown, vx more \
             than {:.0} % off in {speed_off} rows; vx's reported std short of its error (NEES above 2 or \
             less than 90 % inside) in {speed_overconfident} rows.",
            summaries.len(),
            self.rows.len(),
            100.0 * metrics::SPEED_LIMIT
        )
    }

    /// Plain-text summary for the terminal: the best estimator per run and the wins.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        for row in self.summary_rows() {
            out += &format!("  {}\n", row.join(" | "));
        }
        let wins: Vec<String> = self
            .wins()
            .iter()
            .map(|(n, c)| format!("{n} {c}"))
            .collect();
        out += &format!(
            "  best of a run: {}\n  {}\n",
            wins.join(", "),
            self.verdict()
        );
        out
    }

    /// The demo report's section "Mismatch campaigns".
    pub fn section(&self, doc: &mut Document, out: &Path) {
        doc.heading(2, "Mismatch campaigns");
        doc.paragraph(format!(
            "The truth is the ReferenceVehicle's full vehicle \
             (model 3: roll, load transfer, combined-slip MF 5.2 tyres with relaxation) with a real car's parameter \
             file and series-production sensor noise at 10 ms, and \
             the same car on its model 1 (single track with the seed's HSRI tyres, the car marked `(model 1)`) and \
             model 2 (two track with load transfer and Magic Formula tyres matched to them, `(model 2)`), both with \
             the car's static wheel loads; every estimator kind on models A and B and on model A \
             with grip states (A+grip), at the FMU's defaults, told only the car's mass, yaw \
             inertia, axle distances, wheel radii and inertias, brake split and static wheel loads (a new \
             user's set-up), and not the torques. Cars, reference models, manoeuvres and the base scenario: \
             `harness/scenarios/campaigns/`. {} runs of {} estimators in {:.1} s.",
            self.runs().len(),
            self.runs().first().map_or(0, |r| r.len()),
            self.seconds
        ));
        if !self.overrides.is_empty() {
            doc.paragraph(format!(
                "**Not the shipped campaigns**: set on every run after the car's parameters \
                 (`harness robustness --set`): {}.",
                self.overrides
                    .iter()
                    .map(|text| format!("`{text}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if !self.cars.is_empty() {
            doc.paragraph(format!(
                "**Not the shipped campaigns**: on {} only (`--cars`).",
                self.cars.join(", ")
            ));
        }
        doc.list(
            self.manoeuvres
                .iter()
                .map(|(name, title)| format!("`{name}`: {title}"))
                .chain(self.amplitudes.iter().map(|(car, amplitude)| {
                    format!("sine with dwell on the {car}: amplitude {amplitude:.0} deg of steering wheel")
                }))
                .collect(),
        );
        doc.paragraph(format!(
            "Per run, the best estimator (lowest sideslip RMSE among those that did not diverge) against the \
             zero-sideslip baseline and the target of {TARGET_RMSE_DEG} deg; beside them the steady-state \
             single-track yardstick (no filter: the linear single-track model's steady sideslip at the \
             road-wheel angle and the measured speed, with the car's true cornering stiffness at static load \
             per axle) and the default configuration ({DEFAULT_ESTIMATOR}: the grip model's EKF), flagged \
             where it is worse than reporting zero or more than {YARDSTICK_MARGIN_DEG} deg worse than the \
             yardstick. Sideslip is scored where the true speed is at least {} m/s.",
            metrics::SIDESLIP_MIN_SPEED
        ));
        doc.table(
            [
                "manoeuvre",
                "car",
                "peak true sideslip (deg)",
                "zero baseline (deg)",
                "best estimator",
                "its RMSE (deg)",
                "<= 0.3 deg",
                "rows worse than 0",
                "yardstick (deg)",
                "EKF_G (deg)",
                "EKF_G against 0 and the yardstick",
            ]
            .map(String::from)
            .to_vec(),
            self.summary_rows(),
        );
        let wins: Vec<String> = self
            .wins()
            .iter()
            .map(|(n, c)| format!("{n} {c}×"))
            .collect();
        doc.paragraph(format!(
            "Best of a run: {}. {}",
            wins.join(", "),
            self.verdict()
        ));
        doc.paragraph(format!(
            "Per estimator over the {} runs: its sideslip RMSEs summed, the median of RMSE over the zero \
             baseline (below 1: better than reporting zero), how often it is the best of a run, its rows worse \
             than reporting zero, and where its reported std stands: in the consistency band (NEES 0.5-2, at \
             least 90 % inside the 95 % bound), conservative (NEES below 0.5, at least 90 % inside) or short of \
             its error (NEES above 2 or fewer than 90 % inside). A row is one car: where the \
             sensors do not see the tyres' level (a steady corner), an honest filter's NEES on \
             a car is about chi-square(1), in the band for a third of the cars; whether the std \
             can be believed is measured over a population of cars by `harness population` \
             (fmu-src/vehicle-state-estimator/README.md, \"Honest over a population of cars\").",
            self.runs().len()
        ));
        doc.table(
            [
                "estimator",
                "model",
                "sideslip RMSE summed (deg)",
                "median RMSE / zero baseline",
                "best of a run",
                "worse than 0",
                "NEES in band",
                "conservative",
                "short of its error",
            ]
            .map(String::from)
            .to_vec(),
            self.estimator_rows(),
        );
        doc.paragraph(
            "Every row: sideslip RMSE and largest error, time-averaged NEES (1 for an honest filter), the share \
             of samples inside the chi-square(1) 95 % bound (an honest filter: NEES 0.5-2 and at least \
             90 %), the zero baseline, the largest relative vx error after the first sample (2 % is \
             asked for with the torques unknown, as here), the time-averaged NEES of vx with its share inside \
             the 95 % bound (from the first sample on); flagged when worse than reporting zero or \
             diverged (a non-finite output, or vx off by more than half).",
        );
        doc.table(
            [
                "manoeuvre",
                "car",
                "estimator",
                "model",
                "sideslip RMSE (deg)",
                "max error (deg)",
                "mean NEES",
                "inside 95 % bound",
                "zero baseline (deg)",
                "yardstick (deg)",
                "max vx error",
                "vx NEES (inside)",
                "flag",
            ]
            .map(String::from)
            .to_vec(),
            self.detail_rows(),
        );
        for (caption, path) in &self.plots {
            let relative = path.strip_prefix(out).unwrap_or(path);
            doc.image(relative.to_string_lossy().into_owned(), caption.clone());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(estimator: &str, car: &str, rmse: f64, nees: f64, inside: f64) -> Row {
        Row {
            manoeuvre: "step_steer".into(),
            car: car.into(),
            truth: "full vehicle".into(),
            estimator: estimator.into(),
            model: "A",
            estimator_item: "ekf".into(),
            model_item: "single_track_5_state".into(),
            rmse,
            max_error: rmse,
            mean_nees: nees,
            share_inside: inside,
            zero_baseline: 1.0,
            yardstick: 0.5,
            peak_sideslip: 2.0,
            max_speed_error: 0.0,
            max_vx_error: 0.0,
            speed_nees: 1.0,
            speed_share_inside: 1.0,
            diverged: false,
        }
    }

    /// `reference_models`: the car files' full vehicle when not given; an empty list is
    /// refused with the file and the field named; labels mark the car in tables and file names.
    /// `harness robustness --set`: a value for an instance of the base scenario is taken, one
    /// for an instance it does not have is refused with the instance and the choices named, and
    /// a text without `=` with the text named.
    #[test]
    fn command_line_overrides_must_name_an_instance_of_the_base_scenario() {
        let shipped = || Campaign::load(&scenario_dir().join(SHIPPED_CAMPAIGNS)).unwrap();
        let given = |texts: &[&str]| {
            Overrides::parse(&texts.iter().map(|t| t.to_string()).collect::<Vec<_>>())
        };
        let taken = given(&[
            "vehicle.gravity_in_accelerometers=true",
            "EKF_G.ay_gain_std=0.1",
        ])
        .unwrap();
        let campaign = shipped().with_overrides(&taken.parsed).unwrap();
        assert_eq!(campaign.overrides.len(), 2);
        assert_eq!(campaign.overrides[1].1, ParameterValue::Real(0.1));
        let unknown = given(&["EKF_X.ay_gain_std=0.1"]).unwrap();
        let error = format!(
            "{:#}",
            shipped().with_overrides(&unknown.parsed).err().unwrap()
        );
        assert!(
            error.contains("\"EKF_X\"") && error.contains("EKF_G"),
            "{error}"
        );
        let error = format!("{:#}", given(&["EKF_G.ay_gain_std"]).unwrap_err());
        assert!(error.contains("EKF_G.ay_gain_std"), "{error}");
    }

    /// `--cars`: the named cars stay in the file's order, on every reference model; a name the
    /// file does not list is refused with the name and the choices; none keeps every car.
    #[test]
    fn a_car_selection_keeps_the_named_cars_and_refuses_an_unknown_one() {
        let shipped = || Campaign::load(&scenario_dir().join(SHIPPED_CAMPAIGNS)).unwrap();
        let every = shipped().cars_on_models().len();
        let names = |texts: &[&str]| texts.iter().map(|t| t.to_string()).collect::<Vec<_>>();
        let kept = shipped()
            .with_cars(&names(&["vw_vanagon", "ford_escort"]))
            .unwrap();
        assert_eq!(kept.car_stems(), ["ford_escort", "vw_vanagon"]);
        assert_eq!(kept.cars_on_models().len() * 3, every * 2);
        assert_eq!(
            shipped().with_cars(&[]).unwrap().cars_on_models().len(),
            every
        );
        let error = format!(
            "{:#}",
            shipped().with_cars(&names(&["trabant"])).err().unwrap()
        );
        assert!(
            error.contains("trabant") && error.contains("bmw_320i"),
            "{error}"
        );
    }

    /// A subset of the estimators keeps the vehicle, the named instances and their connections;
    /// a name the base scenario does not have is refused, naming it and the choices.
    #[test]
    fn a_subset_of_estimators_keeps_the_vehicle_and_their_connections() {
        let shipped = || Campaign::load(&scenario_dir().join(SHIPPED_CAMPAIGNS)).unwrap();
        let subset = shipped().with_estimators(&["EKF_G", "PF_A"]).unwrap();
        assert_eq!(subset.estimators, ["PF_A", "EKF_G"]);
        let instances: Vec<&str> = subset.base.fmus.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(instances, [VEHICLE, "PF_A", "EKF_G"]);
        let connections: Vec<(&str, &str)> = subset
            .base
            .connections
            .iter()
            .map(|c| (c.from.as_str(), c.to.as_str()))
            .collect();
        assert_eq!(connections, [(VEHICLE, "PF_A"), (VEHICLE, "EKF_G")]);
        let error = format!("{:#}", shipped().with_estimators(&["EKF_X"]).unwrap_err());
        assert!(
            error.contains("\"EKF_X\"") && error.contains("EKF_G"),
            "{error}"
        );
    }

    #[test]
    fn reference_models_default_to_the_full_vehicle_and_label_the_car() {
        let dir = std::env::temp_dir().join(format!("campaign_file_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("campaigns.toml");
        let text = |models: &str| {
            format!(
                "base = \"base.toml\"\ncars = [\"car.ssv\"]\n{models}\n[[manoeuvre]]\nname = \"m\"\n\
                 title = \"t\"\nsection = {{ library = \"seed001_step_steer_40deg\" }}\n"
            )
        };
        std::fs::write(&path, text("")).unwrap();
        let file = CampaignFile::from_file(&path).unwrap();
        assert_eq!(file.reference_models, ReferenceModel::car_files_own());
        std::fs::write(&path, text("reference_models = []")).unwrap();
        let error = format!("{:#}", CampaignFile::from_file(&path).unwrap_err());
        assert!(
            error.contains("reference_models") && error.contains(&path.display().to_string()),
            "{error}"
        );
        std::fs::write(
            &path,
            text("reference_models = [{ model = 1, label = \"model 1\" }]"),
        )
        .unwrap();
        let file = CampaignFile::from_file(&path).unwrap();
        let car = Path::new("cars/ford_escort.ssv");
        assert_eq!(
            file.reference_models[0].car_label(car),
            "ford_escort (model 1)"
        );
        assert_eq!(
            file.reference_models[0].file_label(car),
            "ford_escort_model_1"
        );
        assert_eq!(file.reference_models[0].model, 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The shipped low-speed courses run on the full vehicle alone, every other manoeuvre on
    /// every reference model; the population leaves the courses out.
    #[test]
    fn a_manoeuvre_runs_on_its_models_only() {
        let campaign = Campaign::load(&scenario_dir().join(SHIPPED_CAMPAIGNS)).unwrap();
        let models = &campaign.file.reference_models;
        for m in &campaign.file.manoeuvres {
            let on: Vec<i64> = models
                .iter()
                .filter(|r| m.runs_on(r))
                .map(|r| r.model)
                .collect();
            if m.name.starts_with("low_speed_course") {
                assert_eq!(on, [3], "{}", m.name);
                assert!(!m.in_population, "{}", m.name);
            } else {
                assert_eq!(on.len(), models.len(), "{}", m.name);
                assert!(m.in_population, "{}", m.name);
            }
        }
    }

    /// An estimator instance without `model` or `estimator` is refused, naming the base scenario
    /// and the instance: the rows' labels would otherwise repeat the FMU's default.
    #[test]
    fn an_estimator_instance_must_name_its_model_and_estimator() {
        let base = |parameters: &str| {
            let text = format!(
                "name = \"b\"\nstep = 0.01\n[manoeuvre]\nlibrary = \"seed001_step_steer_40deg\"\n\
                 [[fmu]]\nname = \"vehicle\"\npath = \"v.fmu\"\n\
                 [[fmu]]\nname = \"EKF\"\npath = \"e.fmu\"\nparameters = {{ {parameters} }}\n"
            );
            Scenario::from_str_at(&text, Path::new("base.toml"), Path::new(".")).unwrap()
        };
        assert!(check_estimator_models(&base("estimator = 2, model = 3")).is_ok());
        for parameters in ["estimator = 2", "estimator = 2, model = 4", "model = 3"] {
            let error = format!(
                "{:#}",
                check_estimator_models(&base(parameters)).unwrap_err()
            );
            assert!(
                error.contains("base.toml")
                    && error.contains("\"EKF\"")
                    && error.contains("`model`")
                    && error.contains("`estimator`"),
                "{error}"
            );
        }
    }

    #[test]
    fn a_row_is_in_the_band_conservative_or_short() {
        // (NEES, share inside, expected)
        let cases = [
            (1.0, 0.95, Consistency::InBand),
            (0.3, 1.0, Consistency::Conservative),
            (2.5, 0.95, Consistency::Short),
            (1.0, 0.85, Consistency::Short),
            (0.3, 0.85, Consistency::Short),
        ];
        for (nees, inside, expected) in cases {
            assert_eq!(
                row("E", "c", 0.1, nees, inside).consistency(),
                expected,
                "NEES {nees}, {inside} inside"
            );
        }
    }

    #[test]
    fn the_estimator_summary_counts_each_estimators_rows() {
        let report = CampaignReport {
            rows: vec![
                row("EKF", "a", 0.2, 1.0, 0.95),
                row("UKF", "a", 0.1, 0.3, 1.0),
                row("PF", "a", 1.5, 5.0, 0.5),
                row("EKF", "b", 0.4, 1.2, 0.92),
                row("UKF", "b", 0.6, 0.2, 1.0),
                row("PF", "b", 0.3, 1.5, 0.8),
            ],
            plots: Vec::new(),
            amplitudes: Vec::new(),
            manoeuvres: Vec::new(),
            seconds: 0.0,
            overrides: Vec::new(),
            cars: Vec::new(),
        };
        let summaries = report.estimator_summaries();
        let names: Vec<&str> = summaries.iter().map(|e| e.estimator.as_str()).collect();
        assert_eq!(names, ["EKF", "UKF", "PF"]);
        let [ekf, ukf, pf] = [&summaries[0], &summaries[1], &summaries[2]];
        assert!((ekf.rmse_sum - 0.6).abs() < 1e-12);
        assert!((ekf.median_baseline_ratio - 0.3).abs() < 1e-12);
        assert_eq!((ekf.best_of_run, ekf.in_band, ekf.runs), (0, 2, 2));
        assert_eq!((ukf.best_of_run, ukf.conservative), (1, 2));
        assert_eq!(
            (pf.best_of_run, pf.worse_than_baseline, pf.short),
            (1, 1, 2)
        );
    }
}
