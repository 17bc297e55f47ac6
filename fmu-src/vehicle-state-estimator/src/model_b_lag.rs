//! Model 4: model B with tyres that lag by their relaxation length (`TwoTrackLagModel` of the
//! estimation crate) as the FMU runs it. Everything the two transient slip angles do not change
//! is model B's ([`crate::model_b`]): the car and noise parameters, the sensors' rows, the
//! speed input, the plausibility limits, the start from the measurements, `ay_model_error` and
//! the outputs (from the first three states). The transient slip angles start at the kinematic
//! ones of the start state (straight running: 0) and are kept when the filter re-seeds.

use estimation::kalman::InitialEstimate;
use estimation::models::two_track_lag::{
    LagState, TwoTrackLagModel, LAG_STATE_DIM, TRANSIENT_SLIP_FRONT, TRANSIENT_SLIP_REAR,
};
use estimation::registry::EstimatorSettings;
use estimation::StateSpaceModel;
use fmi_export::{StateError, StateReader, StateWriter};
use nalgebra::{SMatrix, SVector};
use vehicle_models::two_track_lateral::{
    input_index, measurement_index, INPUT_DIM, MEASUREMENT_DIM, STATE_DIM,
};
use vehicle_models::MagicFormulaTyre;

use crate::model_b::{
    two_track_measured_start, two_track_outputs, two_track_sample, ModelB, PassedThrough,
    TwoTrackForm,
};
use crate::model_description::{RealOutputs, Variables};
use crate::runner::{ay_model_error_noise, EstimationModel, OutputSample, Runner, Sample, Sensors};

/// Model 4 as the filters see it.
pub type ModelBLag = TwoTrackLagModel<MagicFormulaTyre>;

/// The running estimator on model 4.
pub type RunnerBLag = Runner<ModelBLag, LAG_STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>;

impl TwoTrackForm for ModelBLag {
    fn two_track(&self) -> &ModelB {
        self.two_track()
    }
}

/// Model B's part `[β, r, ay]` of a Gaussian.
fn body_estimate(estimate: &InitialEstimate<LAG_STATE_DIM>) -> InitialEstimate<STATE_DIM> {
    InitialEstimate {
        state: estimate.state.fixed_rows::<STATE_DIM>(0).into_owned(),
        covariance: estimate
            .covariance
            .fixed_view::<STATE_DIM, STATE_DIM>(0, 0)
            .into_owned(),
    }
}

/// Straight running at `speed` (the input the transient slip angles start from).
fn straight_input(speed: f64) -> SVector<f64, INPUT_DIM> {
    let mut input = SVector::<f64, INPUT_DIM>::zeros();
    input[input_index::LONGITUDINAL_VELOCITY] = speed;
    input
}

impl EstimationModel<LAG_STATE_DIM, MEASUREMENT_DIM, INPUT_DIM> for ModelBLag {
    type Extra = PassedThrough;

    fn from_parameters(v: &Variables) -> Result<Self, String> {
        TwoTrackLagModel::new(ModelB::from_parameters(v)?, v.tyre_relaxation_length)
            .map_err(|error| format!("estimator set-up: {}", error.0))
    }

    fn initial_estimate(v: &Variables) -> Result<InitialEstimate<LAG_STATE_DIM>, String> {
        let model = Self::from_parameters(v)?;
        Ok(model.extend_initial(&ModelB::initial_estimate(v)?, &straight_input(v.vx_initial)))
    }

    /// Model B's settings at its operating point (straight driving: the transient slip angles
    /// 0).
    fn registry_settings(&self, v: &Variables) -> EstimatorSettings<LAG_STATE_DIM, INPUT_DIM> {
        let b = self.two_track().registry_settings(v);
        EstimatorSettings {
            operating_point: b
                .operating_point
                .map(|(state, input)| (self.extend_state(&state, &input), input)),
            scaled_sigma_points: b.scaled_sigma_points,
            observer_design: Err(estimation::kalman::SettingsError(String::from(
                "the Luenberger observer has no design for model B (seed 002 designs it for the \
                 single-track model only)",
            ))),
            particles: b.particles,
        }
    }

    fn start_extra(v: &Variables, min_speed: f64) -> PassedThrough {
        ModelB::start_extra(v, min_speed)
    }

    fn sample(
        runner: &mut RunnerBLag,
        sensors: &Sensors,
    ) -> Result<Sample<MEASUREMENT_DIM, INPUT_DIM>, i32> {
        two_track_sample(runner, sensors)
    }

    fn plausible(&self, sensors: &Sensors, state: &LagState, min_speed: f64) -> [bool; 2] {
        let body = state.fixed_rows::<STATE_DIM>(0).into_owned();
        self.two_track().plausible(sensors, &body, min_speed)
    }

    fn model_error_rows(&self) -> [bool; MEASUREMENT_DIM] {
        self.two_track().model_error_rows()
    }

    fn measured_start(
        runner: &RunnerBLag,
        sensors: &Sensors,
    ) -> Option<InitialEstimate<LAG_STATE_DIM>> {
        two_track_measured_start(&runner.parameters, runner.min_speed, sensors).map(|start| {
            let speed = runner.extra.speed;
            runner.model.extend_initial(&start, &straight_input(speed))
        })
    }

    /// The tyres' transient slip angles are kept (as the grip model keeps them).
    fn readmitted_start(&self, current: &LagState, start: &mut InitialEstimate<LAG_STATE_DIM>) {
        for i in [TRANSIENT_SLIP_FRONT, TRANSIENT_SLIP_REAR] {
            start.state[i] = current[i];
        }
    }

    /// Model B's `ay` model error on the `ay` row.
    fn extra_measurement_noise(
        &self,
        state: &LagState,
        input: &SVector<f64, INPUT_DIM>,
        v: &Variables,
    ) -> Option<SMatrix<f64, MEASUREMENT_DIM, MEASUREMENT_DIM>> {
        let row = measurement_index::LATERAL_ACCELERATION;
        ay_model_error_noise(v, row, || self.measurement(state, input)[row])
    }

    /// Model B's outputs from the first three states and their covariance.
    fn outputs(
        &self,
        sample: &OutputSample<LAG_STATE_DIM, PassedThrough>,
        v: &Variables,
    ) -> RealOutputs {
        let body = body_estimate(&InitialEstimate {
            state: sample.state,
            covariance: sample.covariance,
        });
        two_track_outputs(
            self.two_track(),
            &OutputSample {
                state: body.state,
                covariance: body.covariance,
                input: sample.input,
                extra: sample.extra,
                nis: sample.nis,
                rows_used: sample.rows_used,
                holding: sample.holding,
                held_speed: sample.held_speed,
            },
            v,
        )
    }

    fn write_extra(passed: &PassedThrough, writer: &mut StateWriter) {
        ModelB::write_extra(passed, writer)
    }

    fn read_extra(
        passed: &mut PassedThrough,
        reader: &mut StateReader<'_>,
    ) -> Result<(), StateError> {
        ModelB::read_extra(passed, reader)
    }
}
