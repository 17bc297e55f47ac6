//! Model A (the 5-state single-track model with HSRI tyres of seed 000,
//! `SingleTrackEstimationModel`) as the FMU runs it: `y = [yaw_rate, ay, omega_front,
//! omega_rear]` from the sensors, `u` = the driver input, outputs from the state and one model
//! evaluation; re-seeded from the wheel speeds when the speed estimate falls below `min_speed`.

use estimation::kalman::InitialEstimate;
use estimation::models::single_track::SingleTrackEstimationModel;
use estimation::registry::EstimatorSettings;
use fmi_export::{StateError, StateReader, StateWriter};
use nalgebra::SVector;
use vehicle_models::driver_input::INPUT_DIM;
use vehicle_models::single_track::{state_index, SingleTrackParams, MEASUREMENT_DIM, STATE_DIM};
use vehicle_models::{HsriTyre, SingleTrackModel};

use crate::model_description::{RealOutputs, Variables};
use crate::parameters::{self, positive, variances};
use crate::runner::{finite_or, EstimationModel, OutputSample, Runner, Sample, Sensors};
use crate::status;

/// Model A as the filters see it.
pub type ModelA = SingleTrackEstimationModel<HsriTyre>;
type StateA = SVector<f64, STATE_DIM>;

/// The running estimator on model A.
pub type RunnerA = Runner<ModelA, STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>;

impl EstimationModel<STATE_DIM, MEASUREMENT_DIM, INPUT_DIM> for ModelA {
    type Extra = ();

    fn from_parameters(v: &Variables) -> Result<Self, String> {
        let source = parameters::source(v);
        let vehicle = SingleTrackParams {
            chassis: source.chassis()?,
            // Beyond the seeds: per-axle factors on Cα (000: 5.70), 1 = the seed's model A.
            cornering_stiffness_scale_front: positive(
                "cornering_stiffness_scale_front",
                v.cornering_stiffness_scale_front,
            )?,
            cornering_stiffness_scale_rear: positive(
                "cornering_stiffness_scale_rear",
                v.cornering_stiffness_scale_rear,
            )?,
            ..SingleTrackParams::default()
        };
        let tyre = HsriTyre::new(source.hsri()?);
        let integrator = parameters::integrator(v)?;
        // Q = diag(std²) per sample, R = diag(std²) (000: ch. 7 uses Q = diag(w²), R = diag(v²)).
        let process = variances([
            ("process_noise_std_vx", v.process_noise_std_vx),
            ("process_noise_std_vy", v.process_noise_std_vy),
            ("process_noise_std_yaw_rate", v.process_noise_std_yaw_rate),
            (
                "process_noise_std_omega_front",
                v.process_noise_std_omega_front,
            ),
            (
                "process_noise_std_omega_rear",
                v.process_noise_std_omega_rear,
            ),
        ])?;
        let measurement = variances([
            (
                "measurement_noise_std_yaw_rate",
                v.measurement_noise_std_yaw_rate,
            ),
            ("measurement_noise_std_ay", v.measurement_noise_std_ay),
            (
                "measurement_noise_std_omega_front",
                v.measurement_noise_std_omega_front,
            ),
            (
                "measurement_noise_std_omega_rear",
                v.measurement_noise_std_omega_rear,
            ),
        ])?;
        SingleTrackEstimationModel::new(
            SingleTrackModel::new(vehicle, tyre),
            positive("sample_time", v.sample_time)?,
            integrator,
            process,
            measurement,
        )
        .map_err(|error| format!("estimator set-up: {}", error.0))
    }

    fn initial_estimate(v: &Variables) -> Result<InitialEstimate<STATE_DIM>, String> {
        let variances = variances([
            ("initial_std_vx", v.initial_std_vx),
            ("initial_std_vy", v.initial_std_vy),
            ("initial_std_yaw_rate", v.initial_std_yaw_rate),
            ("initial_std_omega_front", v.initial_std_omega_front),
            ("initial_std_omega_rear", v.initial_std_omega_rear),
        ])?;
        Ok(InitialEstimate::diagonal(
            StateA::from([
                v.vx_initial,
                v.vy_initial,
                v.yaw_rate_initial,
                v.omega_front_initial,
                v.omega_rear_initial,
            ]),
            StateA::from(variances),
        ))
    }

    fn registry_settings(&self, v: &Variables) -> EstimatorSettings<STATE_DIM, INPUT_DIM> {
        // The LKF/Luenberger operating point: straight driving, zero inputs (000: 5.58-5.62).
        let operating_state = StateA::from([
            v.lkf_vx,
            v.lkf_vy,
            v.lkf_yaw_rate,
            v.lkf_omega_front,
            v.lkf_omega_rear,
        ]);
        self.estimator_settings(
            (operating_state, SVector::zeros()),
            parameters::scaled_sigma_points(v),
            parameters::particle_config(v),
        )
    }

    fn start_extra(_: &Variables, _: f64) -> Self::Extra {}

    fn sample(
        runner: &mut Runner<Self, STATE_DIM, MEASUREMENT_DIM, INPUT_DIM>,
        sensors: &Sensors,
    ) -> Result<Sample<MEASUREMENT_DIM, INPUT_DIM>, i32> {
        let mut bits = 0;
        if runner.filter.state()[state_index::VX] < runner.min_speed {
            if !reseed(runner, sensors) {
                // The slip quantities are singular at standstill and the wheels confirm it:
                // hold instead of guessing.
                return Err(status::BELOW_MIN_SPEED);
            }
            bits |= status::BELOW_MIN_SPEED | status::STATE_RESET;
        }
        Ok(Sample {
            measurement: SVector::from([
                sensors.yaw_rate,
                sensors.ay,
                sensors.omega_front,
                sensors.omega_rear,
            ]),
            input: runner.input,
            bits,
        })
    }

    fn outputs(&self, sample: &OutputSample<STATE_DIM, ()>, _: &Variables) -> RealOutputs {
        let x = sample.state;
        let variances = sample.covariance.diagonal();
        let u = sample.input;
        // One model evaluation for every derived output: its ay is v̇y + vx r (000: 5.40), the
        // measurement function h(x, u) of the ay row in exact arithmetic, so evaluating h again
        // would only repeat the tyre forces.
        let derived = self.vehicle().outputs(&x, &u);
        let std = |i: usize| variances[i].max(0.0).sqrt();
        // First-order propagation of P through atan2(vy, vx).
        let (vx, vy) = (x[state_index::VX], x[state_index::VY]);
        let speed_squared = vx * vx + vy * vy;
        let gradient = [-vy / speed_squared, vx / speed_squared];
        let covariance_vx_vy = sample.covariance[(state_index::VX, state_index::VY)];
        let sideslip_variance = gradient[0] * gradient[0] * variances[state_index::VX]
            + 2.0 * gradient[0] * gradient[1] * covariance_vx_vy
            + gradient[1] * gradient[1] * variances[state_index::VY];
        RealOutputs {
            vx_est: x[state_index::VX],
            vy_est: x[state_index::VY],
            yaw_rate_est: x[state_index::YAW_RATE],
            omega_front_est: x[state_index::OMEGA_FRONT],
            omega_rear_est: x[state_index::OMEGA_REAR],
            sideslip_est: derived.sideslip,
            ay_est: derived.lateral_acceleration,
            slip_angle_front_est: derived.slip_angle_front,
            slip_angle_rear_est: derived.slip_angle_rear,
            slip_front_est: derived.slip_front,
            slip_rear_est: derived.slip_rear,
            vx_std: std(state_index::VX),
            vy_std: std(state_index::VY),
            yaw_rate_std: std(state_index::YAW_RATE),
            omega_front_std: std(state_index::OMEGA_FRONT),
            omega_rear_std: std(state_index::OMEGA_REAR),
            sideslip_std: sideslip_variance.max(0.0).sqrt(),
            nis: sample.nis,
        }
    }

    fn write_extra(_: &(), _: &mut StateWriter) {}

    fn read_extra(_: &mut (), _: &mut StateReader<'_>) -> Result<(), StateError> {
        Ok(())
    }
}

/// Re-seeds the filter from the measurements when its speed estimate fell below `min_speed`
/// but the wheel-speed sensors report a speed above it: the estimate is lost (e.g. after zero
/// sensor signals before the bus delivered data) and waiting for the filter to find back is
/// hopeless, because the model is singular near standstill. The new start is
/// `vx = r_w · mean(ωF, ωR)`, `vy = 0`, `r` = measured yaw rate, wheel speeds as measured, with
/// the initial covariance of the parameters. Returns whether it re-seeded.
fn reseed(runner: &mut RunnerA, sensors: &Sensors) -> bool {
    let wheel_radius = runner.parameters.wheel_radius;
    let Some(speed) = sensors.wheel_speed(wheel_radius) else {
        return false;
    };
    if !(speed >= runner.min_speed && speed.is_finite()) {
        return false;
    }
    let free_rolling = speed / wheel_radius;
    let Ok(mut initial) = ModelA::initial_estimate(&runner.parameters) else {
        return false;
    };
    initial.state = StateA::from([
        speed,
        0.0,
        finite_or(sensors.yaw_rate, 0.0),
        finite_or(sensors.omega_front, free_rolling),
        finite_or(sensors.omega_rear, free_rolling),
    ]);
    runner.rebuild(&initial)
}
