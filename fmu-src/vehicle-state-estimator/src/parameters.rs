//! The estimator's parameters (XML: the parameter variables) turned into the `estimation`
//! crate's settings. The vehicle and tyre parameters are shared with the ReferenceVehicle and
//! read by `vehicle_models::parameters`.

use estimation::adaptive::{AdaptationConfig, MAX_WINDOW};
use estimation::kalman::{SettingsError, SigmaPoints};
use estimation::particle::{ParticleFilterConfig, Proposal, ResamplingPolicy, ResamplingScheme};
use estimation::registry::EstimatorChoice;
use vehicle_models::parameters::ParameterSource;
use vehicle_models::Integrator;

use crate::model_description::{
    EstimatorKind, EstimatorModel, Integrator as IntegratorItem, ParticleProposal,
    ParticleResampling, Variables,
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

/// Whether the `estimator` parameter selects the Luenberger observer, which keeps seed 000's
/// wheels and linearisation on the single-track models (see `model_a` and `model_grip`).
pub fn runs_luenberger(v: &Variables) -> bool {
    matches!(estimator_choice(v), Ok((_, EstimatorChoice::Luenberger)))
}

/// Whether the `estimator` parameter selects the particle filter, which keeps the grip model's
/// accelerometer gain at 0 (see `model_grip`).
pub fn runs_particle_filter(v: &Variables) -> bool {
    matches!(
        estimator_choice(v),
        Ok((_, EstimatorChoice::ParticleFilter))
    )
}

/// The discretisation of the estimator's model.
pub fn integrator(v: &Variables) -> Result<Integrator, String> {
    Ok(
        match IntegratorItem::from_parameter("integrator", v.integrator)? {
            IntegratorItem::SemiImplicitEuler => Integrator::SemiImplicitEuler,
            IntegratorItem::RungeKutta4 => Integrator::RungeKutta4,
        },
    )
}

/// The scaled UKF's sigma points (`ukf_alpha`, `ukf_beta`, `ukf_kappa`).
pub fn scaled_sigma_points(v: &Variables) -> SigmaPoints {
    SigmaPoints::scaled(v.ukf_alpha, v.ukf_beta, v.ukf_kappa)
}

/// The particle filter's configuration (resampling every step, 003: §2.2.4; `particle_proposal`).
pub fn particle_config(v: &Variables) -> Result<ParticleFilterConfig, SettingsError> {
    let scheme =
        match ParticleResampling::from_parameter("particle_resampling", v.particle_resampling)
            .map_err(SettingsError)?
        {
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
    let proposal = match ParticleProposal::from_parameter("particle_proposal", v.particle_proposal)
        .map_err(SettingsError)?
    {
        ParticleProposal::Bootstrap => Proposal::Bootstrap,
        ParticleProposal::LinearisedOptimal => Proposal::LinearisedOptimal,
        ParticleProposal::Marginalised => Proposal::Marginalised,
    };
    Ok(ParticleFilterConfig {
        particle_count,
        scheme,
        policy: ResamplingPolicy::EveryStep,
        seed,
        proposal,
    })
}

/// The parameters with every per-sample process noise `process_noise_std_*` replaced by the one
/// its spectral density `process_noise_psd_*` gives where that is above 0: `Q = q T`, the white
/// noise rate `q` integrated over one sample `T` (first order in `T`; Van Loan, "Computing
/// integrals involving the matrix exponential", IEEE TAC 23, 1978), so a tuning holds across
/// sample times. `R` stays per sample: a sampled sensor's noise variance belongs to the sensor,
/// not to the filter's sample time.
pub fn with_spectral_densities(v: &Variables) -> Result<Variables, String> {
    let sample_time = positive("sample_time", v.sample_time)?;
    // The std per sample the state's density gives, or `std` where the density is 0.
    let per_sample = |state: &str, std: f64| -> Result<f64, String> {
        let name = format!("process_noise_psd_{state}");
        match v.real_by_name(&name).unwrap_or(f64::NAN) {
            q if q > 0.0 && q.is_finite() => Ok((q * sample_time).sqrt()),
            0.0 => Ok(std),
            q => Err(format!(
                "parameter {name} = {q}; expected a finite value >= 0 (0: process_noise_std_{state})"
            )),
        }
    };
    Ok(Variables {
        process_noise_std_vx: per_sample("vx", v.process_noise_std_vx)?,
        process_noise_std_vy: per_sample("vy", v.process_noise_std_vy)?,
        process_noise_std_yaw_rate: per_sample("yaw_rate", v.process_noise_std_yaw_rate)?,
        process_noise_std_omega_front: per_sample("omega_front", v.process_noise_std_omega_front)?,
        process_noise_std_omega_rear: per_sample("omega_rear", v.process_noise_std_omega_rear)?,
        process_noise_std_sideslip: per_sample("sideslip", v.process_noise_std_sideslip)?,
        process_noise_std_ay: per_sample("ay", v.process_noise_std_ay)?,
        ..v.clone()
    })
}

/// The adaptation of `Q` (`adaptive_process_noise`), or `None` when it is off: the window in
/// samples from `adaptation_window` seconds.
pub fn adaptation(v: &Variables) -> Result<Option<AdaptationConfig>, String> {
    if !v.adaptive_process_noise {
        return Ok(None);
    }
    let window = positive("adaptation_window", v.adaptation_window)?;
    let samples = (window / positive("sample_time", v.sample_time)?).round();
    let config = AdaptationConfig {
        // Saturating: NaN gives 0 and a huge window more than MAX_WINDOW, both refused below.
        window: samples.min(MAX_WINDOW as f64 + 1.0) as usize,
        max_scale: v.adaptation_max_scale,
    };
    config.validate().map_err(|e| {
        format!(
            "parameters adaptation_window = {} s with sample_time = {} s and adaptation_max_scale = {}: {}",
            v.adaptation_window, v.sample_time, v.adaptation_max_scale, e.0
        )
    })?;
    Ok(Some(config))
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
