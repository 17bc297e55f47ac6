//! Model B's part of `harness fit` (module text of [`super`]): the tyre level by the log's
//! sideslip reference where it has one, and one common factor on every covariance.

use std::ops::Range;

use anyhow::{bail, Result};

use fmi_master::cosim::ParameterValue;
use fmi_master::fmu::{LoadedFmu, VariableInfo};

use super::super::reference_fit::{TyreFit, FITTED_LEVEL_UNCERTAINTY};
use super::super::{drive, Prepared};
use super::{
    fit_tyre_level, nis_per_dof, real_value, scale_values, segment, with_reals, FitContext, Found,
    ModelFit,
};

/// Model B: the 3-state two-track model of seed 001.
pub struct ModelB;

impl ModelFit for ModelB {
    fn item(&self) -> &'static str {
        "two_track_3_state"
    }

    fn fit(&self, cx: &FitContext) -> Result<Found> {
        let (fmu, prepared, start) = (cx.fmu, cx.prepared, cx.start);
        let mut fitted = Vec::new();
        let tyre_fit = fit_tyre_level(fmu, prepared, start, cx.train_rows.clone())?;
        if let TyreFit::Fitted(f) = tyre_fit {
            fitted.extend(scale_values(f.scales));
            let uncertainty = real_value(fmu, start, "cornering_stiffness_uncertainty")?;
            fitted.push((
                "cornering_stiffness_uncertainty".to_string(),
                uncertainty.min(FITTED_LEVEL_UNCERTAINTY),
            ));
        }
        let with_scales = with_reals(fmu, start, &fitted)?;
        let s = common_noise_scale(fmu, prepared, &with_scales, cx.train_rows.clone())?;
        for name in MODEL_B_COVARIANCE_PARAMETERS {
            fitted.push((name.to_string(), real_value(fmu, &with_scales, name)? * s));
        }
        Ok(Found {
            fitted,
            tyre_fit: Some(tyre_fit),
            noise_factors: (s, s),
            ..Found::default()
        })
    }
}

/// Model B: every standard deviation behind its filter's covariances, which the common factor
/// scales together so that the gains, and so the estimate, stay (see the module text): the
/// noise of the states and sensors, the initial state's, and `ay_model_error`, whose term
/// `(k ay)²` is added to the ay row's `R`. Without the last two the factor changed the estimate:
/// on the example log (--train 2:8 --validate 8:14) the held-out sideslip went 0.16 -> 0.21 deg
/// and the held-out NIS per degree of freedom 0.79 -> 1.52.
const MODEL_B_COVARIANCE_PARAMETERS: [&str; 9] = [
    "process_noise_std_yaw_rate",
    "process_noise_std_sideslip",
    "process_noise_std_ay",
    "measurement_noise_std_yaw_rate",
    "measurement_noise_std_ay",
    "initial_std_sideslip",
    "initial_std_yaw_rate",
    "initial_std_ay",
    "ay_model_error",
];

/// Model B: the common noise factor `sqrt(Σ NIS / Σ dof)` of an FMU run on the training rows.
fn common_noise_scale(
    fmu: &LoadedFmu,
    prepared: &Prepared,
    values: &[(VariableInfo, ParameterValue)],
    rows: Range<usize>,
) -> Result<f64> {
    let (grid, feeds) = segment(prepared, rows);
    let scale = nis_per_dof(&drive::run(fmu, values, &grid, &feeds)?, 0..grid.rows).sqrt();
    if !(scale.is_finite() && scale > 0.0) {
        bail!("the training segment gave no measurement update (NIS per degree of freedom {scale}); choose a segment where the car drives");
    }
    Ok(scale)
}
