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
use crate::snapshot::{read_gaussian, save_gaussian, SnapshotError, SnapshotSink, SnapshotSource};
use crate::{Estimator, StateSpaceModel, UpdateReport};

/// A model the registry can build estimators on: any [`StateSpaceModel`] that can be cloned
/// (a filter owns its model) and sent to another thread (an FMU instance may move).
pub trait RegistryModel<const N: usize, const M: usize, const U: usize>:
    StateSpaceModel<N, M, U> + Clone + Debug + Send + 'static
{
}

impl<T, const N: usize, const M: usize, const U: usize> RegistryModel<N, M, U> for T where
    T: StateSpaceModel<N, M, U> + Clone + Debug + Send + 'static
{
}

/// What reading a stored state gave (see [`RunningEstimator::restore`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Restored<const N: usize> {
    /// The estimator continues from the stored state itself.
    InPlace,
    /// The estimator is fully described by this Gaussian and its settings: building it again
    /// from them continues bit-identically.
    Rebuild(InitialEstimate<N>),
}

/// An estimator as the registry hands it out.
pub trait RunningEstimator<const N: usize, const M: usize, const U: usize>:
    Estimator<N, M, U> + CloneEstimator<N, M, U> + Debug + Send
{
    /// The report of the last measurement update, also after an update that returned a
    /// [`crate::FilterIssue`] but still corrected the estimate.
    fn last_report(&self) -> UpdateReport<M>;

    /// Writes what [`Self::restore`] needs to continue bit-identically. Kalman-type estimators
    /// are fully described by `(x̂, P)` and their settings, which is the default.
    fn save(&self, sink: &mut dyn SnapshotSink) {
        save_gaussian(sink, self.state(), self.covariance());
    }

    /// Reads what [`Self::save`] wrote, into an estimator built with the same settings.
    fn restore(&mut self, source: &mut dyn SnapshotSource) -> Result<Restored<N>, SnapshotError> {
        let (state, covariance) = read_gaussian(source)?;
        Ok(Restored::Rebuild(InitialEstimate { state, covariance }))
    }
}

/// Cloning behind the box (implemented for every `Clone` estimator).
pub trait CloneEstimator<const N: usize, const M: usize, const U: usize> {
    fn clone_boxed(&self) -> BoxedEstimator<N, M, U>;
}

impl<T, const N: usize, const M: usize, const U: usize> CloneEstimator<N, M, U> for T
where
    T: RunningEstimator<N, M, U> + Clone + 'static,
{
    fn clone_boxed(&self) -> BoxedEstimator<N, M, U> {
        Box::new(self.clone())
    }
}

/// Any estimator of the registry.
pub type BoxedEstimator<const N: usize, const M: usize, const U: usize> =
    Box<dyn RunningEstimator<N, M, U>>;

impl<const N: usize, const M: usize, const U: usize> Clone for BoxedEstimator<N, M, U> {
    fn clone(&self) -> Self {
        self.clone_boxed()
    }
}

/// A boxed estimator is an estimator, so generic code (`impl Estimator`) takes it as it is.
impl<const N: usize, const M: usize, const U: usize> Estimator<N, M, U>
    for BoxedEstimator<N, M, U>
{
    fn predict(&mut self, input: &SVector<f64, U>) -> Result<(), crate::FilterIssue> {
        (**self).predict(input)
    }

    fn update(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &crate::MeasurementMask<M>,
    ) -> Result<UpdateReport<M>, crate::FilterIssue> {
        (**self).update(measurement, input, mask)
    }

    fn state(&self) -> &SVector<f64, N> {
        (**self).state()
    }

    fn covariance(&self) -> &nalgebra::SMatrix<f64, N, N> {
        (**self).covariance()
    }
}

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
