//! The estimator's parameters (XML: the parameter variables) turned into the `estimation`
//! crate's settings. The vehicle and tyre parameters are shared with the ReferenceVehicle and
//! read by `vehicle_models::parameters`.

use estimation::kalman::{SettingsError, SigmaPoints};
use estimation::particle::{ParticleFilterConfig, ResamplingPolicy, ResamplingScheme};
use estimation::registry::EstimatorChoice;
use vehicle_models::parameters::ParameterSource;
use vehicle_models::Integrator;

use crate::model_description::{
    EstimatorKind, EstimatorModel, Integrator as IntegratorItem, ParticleResampling, Variables,
};

pub use vehicle_models::parameters::positive;

/// The shared vehicle and tyre parameters of `v`, by name.
pub fn source(v: &Variables) -> ParameterSource<impl Fn(&str) -> Option<f64> + '_> {
    ParameterSource::new(|name| v.real_by_name(name))
}

/// The `model` parameter.
pub fn estimator_model(v: &Variables) -> Result<EstimatorModel, String> {
    EstimatorModel::from_parameter("model", v.model)
}

/// The `estimator` parameter, as the registry's choice of the same name.
pub fn estimator_choice(v: &Variables) -> Result<(EstimatorKind, EstimatorChoice), String> {
    let kind = EstimatorKind::from_parameter("estimator", v.estimator)?;
    let choice = EstimatorChoice::from_name(kind.name()).map_err(|e| e.0)?;
    Ok((kind, choice))
}

/// The discretisation of the estimator's model.
pub fn integrator(v: &Variables) -> Result<Integrator, String> {
    Ok(match IntegratorItem::from_parameter("integrator", v.integrator)? {
        IntegratorItem::SemiImplicitEuler => Integrator::SemiImplicitEuler,
        IntegratorItem::RungeKutta4 => Integrator::RungeKutta4,
    })
}

/// The scaled UKF's sigma points (`ukf_alpha`, `ukf_beta`, `ukf_kappa`).
pub fn scaled_sigma_points(v: &Variables) -> SigmaPoints {
    SigmaPoints::scaled(v.ukf_alpha, v.ukf_beta, v.ukf_kappa)
}

/// The particle filter's configuration (resampling every step, 003: §2.2.4).
pub fn particle_config(v: &Variables) -> Result<ParticleFilterConfig, SettingsError> {
    let scheme = match ParticleResampling::from_parameter("particle_resampling", v.particle_resampling)
        .map_err(SettingsError)? {
        ParticleResampling::Multinomial => ResamplingScheme::Multinomial,
        ParticleResampling::Systematic => ResamplingScheme::Systematic,
        ParticleResampling::Stratified => ResamplingScheme::Stratified,
    };
    let particle_count = usize::try_from(v.particle_count)
        .ok()
        .filter(|&n| n >= 2)
        .ok_or_else(|| {
            SettingsError(format!(
                "parameter particle_count = {}; expected at least 2",
                v.particle_count
            ))
        })?;
    let seed = u64::try_from(v.seed).map_err(|_| {
        SettingsError(format!(
            "parameter seed = {}; expected a value >= 0",
            v.seed
        ))
    })?;
    Ok(ParticleFilterConfig {
        particle_count,
        scheme,
        policy: ResamplingPolicy::EveryStep,
        seed,
    })
}

/// Standard deviations, each a positive parameter, squared: `Q = diag(std²)`, `R = diag(std²)`
/// (000: ch. 7).
pub fn variances<const K: usize>(stds: [(&str, f64); K]) -> Result<[f64; K], String> {
    let mut variances = [0.0; K];
    for (variance, (name, std)) in variances.iter_mut().zip(stds) {
        let std = positive(name, std)?;
        *variance = std * std;
    }
    Ok(variances)
}
