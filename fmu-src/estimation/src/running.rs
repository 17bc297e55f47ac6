//! What a host needs to run an estimator for a long time, beyond the [`Estimator`] interface:
//! the last update's report and a stored state to continue from ([`RunningEstimator`]), behind
//! a box that clones ([`BoxedEstimator`]). Every estimator implements it in its own file; the
//! [`crate::registry`] builds them. Kept apart from the registry so that the estimators do not
//! import the file that imports them.

use std::fmt::Debug;

use nalgebra::SVector;

use crate::kalman::InitialEstimate;
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

    /// Adds `extra` (symmetric positive semi-definite) to the error covariance after a
    /// prediction, which is that prediction with `Q + extra` (the adaptive process noise of
    /// [`crate::adaptive`]). Returns `false`, changing nothing, where the covariance is not a
    /// free parameter of the estimator (the particle filter's sample covariance, the fixed-gain
    /// observer's).
    fn inflate_covariance(&mut self, _extra: &nalgebra::SMatrix<f64, N, N>) -> bool {
        false
    }

    /// The measurement update with `extra` (symmetric positive semi-definite) added to `R` for
    /// this update only: a state-dependent measurement noise, such as a model error that grows
    /// with the predicted measurement: the uncertainty of a model parameter the filter does not
    /// estimate (Schmidt's "consider" parameters, S. F. Schmidt, NASA Ames, mid-1960s; Zanetti &
    /// D'Souza, "Recursive implementations of the consider filter", AAS 12-619, 2012), carried
    /// here as white noise on the rows it enters instead of as a cross-covariance with the
    /// state. The filter's own `R` is unchanged
    /// afterwards. The default ignores `extra`; every estimator of this crate overrides it (the
    /// Luenberger observer's gain is fixed, so there only its reported covariance sees `extra`).
    fn update_with_extra_noise(
        &mut self,
        measurement: &SVector<f64, M>,
        input: &SVector<f64, U>,
        mask: &crate::MeasurementMask<M>,
        _extra: &nalgebra::SMatrix<f64, M, M>,
    ) -> Result<UpdateReport<M>, crate::FilterIssue> {
        self.update(measurement, input, mask)
    }

    /// Conditions the estimate on one scalar linear pseudo-measurement: `h x` is known to be
    /// `h x̂ + residual` within `variance` (a soft state constraint, Simon, "Kalman filtering
    /// with state constraints: a survey of linear and nonlinear algorithms", IET Control Theory
    /// & Applications 4(8), 2010, sect. 2.3), with the Kalman gain and the Joseph form.
    /// Returns `false`, changing nothing, where the covariance is not a free parameter of the
    /// estimator (as [`Self::inflate_covariance`]) or the update is not finite.
    fn condition_on(&mut self, _h: &SVector<f64, N>, _residual: f64, _variance: f64) -> bool {
        false
    }

    /// Gain scheduling of the linear estimators (LKF, Luenberger observer), which run on one
    /// linearisation: re-linearises about the current estimate and `input` (and re-places the
    /// observer gain) when that linearisation's error there,
    /// [`crate::kalman::LinearisedModel::normalised_error`], exceeds `threshold` noise standard
    /// deviations; between re-schedules the estimator stays a linear one (Rugh & Shamma,
    /// "Research on gain scheduling", Automatica 36, 2000, §3: linearise about a family of
    /// operating points and schedule on where the system is). Returns whether it re-linearised.
    /// Costs one evaluation of `f` and `h`, plus the Jacobians when it re-linearises. The other
    /// estimators linearise at every step or not at all: `false`.
    fn reschedule(&mut self, _input: &SVector<f64, U>, _threshold: f64) -> bool {
        false
    }

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
