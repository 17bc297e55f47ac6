//! Model C — the rear-axle-referenced single-track model with load transfer of seed 003 (§2.1,
//! 003: 2.18-2.21, implemented in `vehicle_models::rear_axle`) — as a
//! [`StateSpaceModel<3, 3, 3>`], with its uncertain parameter vector `p = [Csf, Csr, m/J, lf]`
//! settable ([`Parameterised`], for the EM identification, 003: §3.1-3.2).
//!
//! State `x = [Vy_ref, ω, φ]`, input `u = [dVx_ref/dt, δ, Vx_ref]`, all states measured: `y = x`
//! (003: 2.22-2.23). The discrete step is the classical Runge-Kutta method (003: A.25-A.32) with
//! the input held over the sample, as the seed's simulator and filter do (003: §3.1,
//! `runge_kutta4_vmodel`); its Jacobians are the exact ones of the discrete map.

use nalgebra::{SMatrix, SVector};
use vehicle_models::rear_axle as model_c;
use vehicle_models::Integrator;

use crate::identification::Parameterised;
use crate::model::StateSpaceModel;

pub use vehicle_models::rear_axle::{RearAxleParameterVector, RearAxleParams};

/// Names of the entries of `p`.
pub const PARAMETER_NAMES: [&str; 4] = ["Csf", "Csr", "m/J", "lf"];

/// The simulation vehicle of 003: 3.14-3.18: `p = [8.36, 7.78, 0.62, 1.014]`.
pub fn seed_parameters() -> RearAxleParameterVector {
    RearAxleParams::default().parameter_vector()
}

/// The deliberately wrong start of the seed's identification (003: §3.2):
/// `p = [7.942, 7.386, 0.56, 0.91]`.
pub fn seed_identification_start() -> RearAxleParameterVector {
    RearAxleParameterVector::new(7.942, 7.386, 0.56, 0.91)
}

/// Measurement noise standard deviations of 003: §3.2: `0.005 m/s`, `0.02°/s`, `0.005°`.
pub fn seed_measurement_noise_std() -> SVector<f64, 3> {
    SVector::<f64, 3>::new(0.005, 0.02_f64.to_radians(), 0.005_f64.to_radians())
}

/// The process noise the seed assumes for the identification from the wrong start (003: §3.2):
/// `Ξ = diag(0.02², 0.003², 0.003²)`.
pub fn seed_identification_process_noise_std() -> SVector<f64, 3> {
    SVector::<f64, 3>::new(0.02, 0.003, 0.003)
}

/// `diag(std²)`.
pub fn diagonal_covariance(std: &SVector<f64, 3>) -> SMatrix<f64, 3, 3> {
    SMatrix::from_diagonal(&std.component_mul(std))
}

/// Bad model-C settings.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RearAxleModelError {
    #[error("sample_time must be a positive finite number of seconds, got {0}")]
    SampleTime(f64),
    #[error("wheelbase must be positive and finite, got {0} m")]
    Wheelbase(f64),
    #[error(
        "lf (cog_to_front_axle) must lie strictly between 0 and the wheelbase {1} m, got {0} m"
    )]
    FrontAxleDistance(f64, f64),
    #[error("parameter {0} must be finite, got {1}")]
    NonFinite(&'static str, f64),
    #[error("{0} must be symmetric positive semi-definite with finite entries")]
    Covariance(&'static str),
}

/// Model C with its sample time, integrator and noise covariances.
#[derive(Debug, Clone, PartialEq)]
pub struct RearAxleModel {
    pub vehicle: model_c::RearAxleModel,
    /// Sample time of the discrete model, s.
    pub sample_time: f64,
    /// RK4 as in the seed; explicit Euler is available for comparison.
    pub integrator: Integrator,
    /// Process noise covariance `Ξ` (003: 2.24).
    pub process_noise: SMatrix<f64, 3, 3>,
    /// Measurement noise covariance `Θ` (003: 2.25).
    pub measurement_noise: SMatrix<f64, 3, 3>,
}

impl RearAxleModel {
    /// The seed's simulation vehicle (003: 3.14-3.18) at `sample_time`, RK4, with measurement
    /// noise `Θ` of §3.2 and `Ξ = Θ` as the seed sets for its filter/smoother test (003: §3.2,
    /// before table 3.1).
    pub fn seed_vehicle(sample_time: f64) -> Result<Self, RearAxleModelError> {
        let theta = diagonal_covariance(&seed_measurement_noise_std());
        Self::new(RearAxleParams::default(), sample_time, theta, theta)
    }

    /// Model C with explicit data; checks what the equations need.
    pub fn new(
        params: RearAxleParams,
        sample_time: f64,
        process_noise: SMatrix<f64, 3, 3>,
        measurement_noise: SMatrix<f64, 3, 3>,
    ) -> Result<Self, RearAxleModelError> {
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(RearAxleModelError::SampleTime(sample_time));
        }
        if !(params.wheelbase.is_finite() && params.wheelbase > 0.0) {
            return Err(RearAxleModelError::Wheelbase(params.wheelbase));
        }
        for (name, value) in [
            ("cog_height", params.cog_height),
            ("gravity", params.gravity),
            ("low_speed_guard", params.low_speed_guard),
        ] {
            if !value.is_finite() {
                return Err(RearAxleModelError::NonFinite(name, value));
            }
        }
        for (name, covariance) in [
            ("process_noise", &process_noise),
            ("measurement_noise", &measurement_noise),
        ] {
            let symmetric = (covariance - covariance.transpose()).amax()
                <= 1e-12 * covariance.amax().max(f64::MIN_POSITIVE);
            let finite = covariance.iter().all(|v| v.is_finite());
            let diagonal_ok = covariance.diagonal().iter().all(|&v| v >= 0.0);
            if !(symmetric && finite && diagonal_ok) {
                return Err(RearAxleModelError::Covariance(name));
            }
        }
        let model = Self {
            vehicle: model_c::RearAxleModel::new(params),
            sample_time,
            integrator: Integrator::RungeKutta4,
            process_noise,
            measurement_noise,
        };
        model.check_parameters(&model.vehicle.parameter_vector())?;
        Ok(model)
    }

    /// The same model with other parameters `p = [Csf, Csr, m/J, lf]`.
    pub fn with_parameter_values(
        &self,
        parameters: &RearAxleParameterVector,
    ) -> Result<Self, RearAxleModelError> {
        self.check_parameters(parameters)?;
        Ok(Self {
            vehicle: self.vehicle.with_parameter_vector(parameters),
            ..self.clone()
        })
    }

    fn check_parameters(
        &self,
        parameters: &RearAxleParameterVector,
    ) -> Result<(), RearAxleModelError> {
        for (name, value) in PARAMETER_NAMES.iter().zip(parameters.iter()) {
            if !value.is_finite() {
                return Err(RearAxleModelError::NonFinite(name, *value));
            }
        }
        let lf = parameters[3];
        let wheelbase = self.vehicle.params.wheelbase;
        if !(lf > 0.0 && lf < wheelbase) {
            return Err(RearAxleModelError::FrontAxleDistance(lf, wheelbase));
        }
        Ok(())
    }
}

impl StateSpaceModel<3, 3, 3> for RearAxleModel {
    fn state_names(&self) -> [&'static str; 3] {
        ["lateral_velocity_rear_axle", "yaw_rate", "yaw_angle"]
    }

    fn measurement_names(&self) -> [&'static str; 3] {
        [
            "measured_lateral_velocity_rear_axle",
            "measured_yaw_rate",
            "measured_yaw_angle",
        ]
    }

    fn transition(&self, state: &SVector<f64, 3>, input: &SVector<f64, 3>) -> SVector<f64, 3> {
        self.vehicle
            .step(state, input, self.sample_time, self.integrator)
    }

    fn transition_jacobian(
        &self,
        state: &SVector<f64, 3>,
        input: &SVector<f64, 3>,
    ) -> SMatrix<f64, 3, 3> {
        self.vehicle
            .step_jacobians(state, input, self.sample_time, self.integrator)
            .0
    }

    fn transition_input_jacobian(
        &self,
        state: &SVector<f64, 3>,
        input: &SVector<f64, 3>,
    ) -> SMatrix<f64, 3, 3> {
        self.vehicle
            .step_jacobians(state, input, self.sample_time, self.integrator)
            .1
    }

    /// All states measured: `y = cᵀ x` with `cᵀ = I` (003: 2.22-2.23).
    fn measurement(&self, state: &SVector<f64, 3>, input: &SVector<f64, 3>) -> SVector<f64, 3> {
        self.vehicle.measurement(state, input)
    }

    fn measurement_jacobian(
        &self,
        _state: &SVector<f64, 3>,
        _input: &SVector<f64, 3>,
    ) -> SMatrix<f64, 3, 3> {
        self.vehicle.measurement_jacobian()
    }

    fn measurement_input_jacobian(
        &self,
        _state: &SVector<f64, 3>,
        _input: &SVector<f64, 3>,
    ) -> SMatrix<f64, 3, 3> {
        SMatrix::zeros()
    }

    fn process_noise(&self) -> SMatrix<f64, 3, 3> {
        self.process_noise
    }

    fn measurement_noise(&self) -> SMatrix<f64, 3, 3> {
        self.measurement_noise
    }
}

impl Parameterised<4> for RearAxleModel {
    fn parameter_names(&self) -> [&'static str; 4] {
        PARAMETER_NAMES
    }

    fn parameters(&self) -> SVector<f64, 4> {
        self.vehicle.parameter_vector()
    }

    fn with_parameters(&self, parameters: &SVector<f64, 4>) -> Option<Self> {
        self.with_parameter_values(parameters).ok()
    }

    /// `y = x` with a fixed `Θ`: `I_1` and `I_3` do not depend on `p` (003: §3.1, before 3.3).
    fn measurement_depends_on_parameters(&self) -> bool {
        false
    }
}
