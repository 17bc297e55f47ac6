//! The estimator registry: every estimator of this crate, built by name or by
//! [`EstimatorChoice`] on any model from one set of [`EstimatorSettings`]. The FMU, the tests,
//! the benchmarks and the studies build their estimators here, so an estimator is listed in
//! exactly one place (the `registry!` invocation below; see the crate docs, "Adding an
//! estimator").
//!
//! The registry hands out a [`BoxedEstimator`]: the [`Estimator`] interface plus what a host
//! needs to run one for a long time ([`RunningEstimator`]: the last update's report and a stored
//! state to continue from).

use std::fmt::Debug;

use nalgebra::SVector;

use crate::kalman::{
    ExtendedKalmanFilter, InitialEstimate, LinearKalmanFilter, SettingsError, SigmaPoints,
    UnscentedKalmanFilter,
};
use crate::luenberger::{LuenbergerObserver, ObserverDesign};
use crate::particle::{ParticleFilter, ParticleFilterConfig};
use crate::snapshot::{SnapshotError, SnapshotSource};

pub use crate::running::{
    BoxedEstimator, CloneEstimator, RegistryModel, Restored, RunningEstimator,
};

/// The linearisation point of the linear estimators: `(x₀, u₀)`.
pub type OperatingPoint<const N: usize, const U: usize> = (SVector<f64, N>, SVector<f64, U>);

/// Everything an estimator of the registry may need beyond the model and the start. Settings
/// that not every model or host can give are `Result`s: their error is reported only when an
/// estimator that needs them is chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatorSettings<const N: usize, const U: usize> {
    /// The LKF's and the Luenberger observer's linearisation point.
    pub operating_point: Result<OperatingPoint<N, U>, SettingsError>,
    /// The sigma points of the scaled UKF (`ukf_scaled`).
    pub scaled_sigma_points: SigmaPoints,
    /// The Luenberger observer's pole placement; an error when the model has no design.
    pub observer_design: Result<ObserverDesign, SettingsError>,
    /// The particle filter's count, resampling and seed.
    pub particles: Result<ParticleFilterConfig, SettingsError>,
}

/// How one registry line builds its estimator.
type Builder<Model, const N: usize, const M: usize, const U: usize> =
    fn(
        Model,
        &EstimatorSettings<N, U>,
        &InitialEstimate<N>,
    ) -> Result<BoxedEstimator<N, M, U>, SettingsError>;

/// Boxes a built estimator (the registry lines' common tail).
fn boxed<E, const N: usize, const M: usize, const U: usize>(
    estimator: Result<E, SettingsError>,
) -> Result<BoxedEstimator<N, M, U>, SettingsError>
where
    E: RunningEstimator<N, M, U> + 'static,
{
    estimator.map(|e| Box::new(e) as BoxedEstimator<N, M, U>)
}

macro_rules! registry {
    ($($(#[doc = $doc:literal])* $variant:ident = $name:literal => $build:expr;)+) => {
        /// Which estimator the registry builds; the names are the FMU's `EstimatorKind` items.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum EstimatorChoice {
            $($(#[doc = $doc])* $variant,)+
        }

        impl EstimatorChoice {
            /// Every estimator, in registry order.
            pub const ALL: &'static [Self] = &[$(Self::$variant),+];

            /// The estimator's name (the FMU's enumeration item name).
            pub const fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $name,)+
                }
            }

            fn builder<Model, const N: usize, const M: usize, const U: usize>(
                self,
            ) -> Builder<Model, N, M, U>
            where
                Model: RegistryModel<N, M, U>,
            {
                match self {
                    $(Self::$variant => $build,)+
                }
            }
        }
    };
}

registry! {
    /// Linear Kalman filter on the linearisation about the operating point (000: 4.64-4.75).
    Lkf = "lkf" => |model, settings, initial| {
        let (state, input) = settings.operating_point.clone()?;
        boxed(LinearKalmanFilter::new(model, &state, &input, initial))
    };
    /// Extended Kalman filter (000: 4.99-4.113).
    Ekf = "ekf" => |model, _, initial| boxed(ExtendedKalmanFilter::new(model, initial));
    /// Unscented Kalman filter with the seed's 2n sigma points (000: 4.114-4.144).
    Ukf = "ukf" => |model, _, initial| {
        boxed(UnscentedKalmanFilter::new(model, SigmaPoints::Symmetric, initial))
    };
    /// Unscented Kalman filter with the scaled 2n+1 sigma points (001 [13, 16]).
    UkfScaled = "ukf_scaled" => |model, settings, initial| {
        boxed(UnscentedKalmanFilter::new(model, settings.scaled_sigma_points, initial))
    };
    /// SIR particle filter (003: §2.2.4, A.4), drawing its particles from the start.
    ParticleFilter = "particle_filter" => |model, settings, initial| {
        let config = settings.particles.clone()?;
        boxed(
            ParticleFilter::new(model, config, initial.state, initial.covariance)
                .map_err(|error| SettingsError(format!("particle filter set-up: {error}"))),
        )
    };
    /// Luenberger observer with pole placement on the linearisation (002: §4).
    Luenberger = "luenberger" => |model, settings, initial| {
        let (state, input) = settings.operating_point.clone()?;
        let design = settings.observer_design.clone()?;
        boxed(LuenbergerObserver::new(model, &state, &input, &design, initial))
    };
}

impl EstimatorChoice {
    /// The estimator with this name; the error lists the registered names.
    pub fn from_name(name: &str) -> Result<Self, SettingsError> {
        Self::ALL
            .iter()
            .copied()
            .find(|choice| choice.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|c| c.name()).collect();
                SettingsError(format!(
                    "unknown estimator '{name}'; expected one of {}",
                    names.join(", ")
                ))
            })
    }
}

/// Builds the estimator `choice` on `model`, starting from `initial`.
pub fn build<Model, const N: usize, const M: usize, const U: usize>(
    model: Model,
    choice: EstimatorChoice,
    settings: &EstimatorSettings<N, U>,
    initial: &InitialEstimate<N>,
) -> Result<BoxedEstimator<N, M, U>, SettingsError>
where
    Model: RegistryModel<N, M, U>,
{
    choice.builder::<Model, N, M, U>()(model, settings, initial)
}

/// Builds the estimator `choice` as [`build`] does and continues it from a state that
/// [`RunningEstimator::save`] wrote: a Kalman-type estimator is built again from the stored
/// `(x̂, P)`, the particle filter restores its particles and generator.
pub fn restore<Model, const N: usize, const M: usize, const U: usize>(
    model: Model,
    choice: EstimatorChoice,
    settings: &EstimatorSettings<N, U>,
    initial: &InitialEstimate<N>,
    source: &mut dyn SnapshotSource,
) -> Result<BoxedEstimator<N, M, U>, SnapshotError>
where
    Model: RegistryModel<N, M, U>,
{
    let settings_error = |error: SettingsError| SnapshotError(error.to_string());
    let mut estimator = build(model.clone(), choice, settings, initial).map_err(settings_error)?;
    match estimator.restore(source)? {
        Restored::InPlace => Ok(estimator),
        Restored::Rebuild(stored) => {
            build(model, choice, settings, &stored).map_err(settings_error)
        }
    }
}
