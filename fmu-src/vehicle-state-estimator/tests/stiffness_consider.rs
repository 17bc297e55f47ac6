//! `cornering_stiffness_uncertainty` (models A and B): the rear tyre's stiffness uncertainty
//! enters the reported sideslip and lateral-velocity standard deviations as a consider term
//! `σ |αR|`, and nothing else; the grip model, whose grip states estimate its tyres' scale,
//! leaves it out. Truth: the two-track Magic Formula reference vehicle (lateral load
//! transfer, another tyre law: not model A) on a 2.5° road-wheel step at 65 km/h, noise-free
//! sensors; the EKF at its defaults.

use fmi_export::ffi::Fmi2Status;
use fmi_export::fmi2_api_of;
use fmi_export::testing::Slave;
use vehicle_models::{
    DriverInputVector, ReferenceModelKind, ReferenceVehicle, ReferenceVehicleParams,
};
use VehicleStateEstimator::model_description::{vr, EstimatorKind, EstimatorModel, GUID};

use crate::model_grip::set_sensors;

const SAMPLE_TIME: f64 = 0.01;
const SPEED: f64 = 65.0 / 3.6;
const SAMPLES: usize = 300;
/// `[sideslip_est, vy_est, vx_est, yaw_rate_est, sideslip_std, vy_std, slip_angle_rear_est]`.
const OUTPUTS: [u32; 7] = [
    vr::SIDESLIP_EST,
    vr::VY_EST,
    vr::VX_EST,
    vr::YAW_RATE_EST,
    vr::SIDESLIP_STD,
    vr::VY_STD,
    vr::SLIP_ANGLE_REAR_EST,
];

/// The EKF on `model` at its defaults, with `uncertainty` as the parameter when given.
fn estimator(model: EstimatorModel, uncertainty: Option<f64>) -> Slave {
    estimator_of_kind(EstimatorKind::Ekf, model, uncertainty)
}

/// The estimator `kind` on `model` at its defaults, with `uncertainty` as the parameter when
/// given.
pub(crate) fn estimator_of_kind(
    kind: EstimatorKind,
    model: EstimatorModel,
    uncertainty: Option<f64>,
) -> Slave {
    estimator_with_lag(kind, model, uncertainty, None)
}

/// [`estimator_of_kind`] with `tyre_relaxation_length` set when given (model A's lag term).
fn estimator_with_lag(
    kind: EstimatorKind,
    model: EstimatorModel,
    uncertainty: Option<f64>,
    relaxation_length: Option<f64>,
) -> Slave {
    let lag = relaxation_length.map(|length| (vr::TYRE_RELAXATION_LENGTH, length));
    estimator_with(kind, model, uncertainty, lag.as_slice())
}

/// [`estimator_of_kind`] with the real parameters `settings` set.
pub(crate) fn estimator_with(
    kind: EstimatorKind,
    model: EstimatorModel,
    uncertainty: Option<f64>,
    settings: &[(u32, f64)],
) -> Slave {
    let mut s = Slave::instantiate(fmi2_api_of!(VehicleStateEstimator), "consider", GUID)
        .expect("instantiate");
    for &(reference, value) in settings {
        assert_eq!(s.set_real(reference, value), Fmi2Status::Ok);
    }
    assert_eq!(s.set_integer(vr::MODEL, model as i32), Fmi2Status::Ok);
    assert_eq!(s.set_integer(vr::ESTIMATOR, kind as i32), Fmi2Status::Ok);
    assert_eq!(s.set_real(vr::SAMPLE_TIME, SAMPLE_TIME), Fmi2Status::Ok);
    if let Some(sigma) = uncertainty {
        assert_eq!(
            s.set_real(vr::CORNERING_STIFFNESS_UNCERTAINTY, sigma),
            Fmi2Status::Ok
        );
    }
    assert_eq!(s.initialize(0.0), Fmi2Status::Ok, "{:?}", s.log.last());
    s
}

/// Every step's outputs ([`OUTPUTS`]) and true sideslip of `s` on the step steer.
fn run(s: &mut Slave) -> Vec<([f64; 7], f64)> {
    run_with_status(s, ReferenceModelKind::TwoTrack, 2.5)
        .into_iter()
        .map(|step| (step.outputs, step.truth))
        .collect()
}

/// One step of [`run_with_status`].
pub(crate) struct Step {
    /// [`OUTPUTS`].
    pub outputs: [f64; 7],
    /// The true sideslip.
    pub truth: f64,
    pub status: i32,
    pub nis: f64,
    pub rows_used: i32,
}

/// Every step of `s` on a step steer of `step_degrees` road-wheel angle, the truth from the
/// reference vehicle's `truth` model.
pub(crate) fn run_with_status(
    s: &mut Slave,
    truth: ReferenceModelKind,
    step_degrees: f64,
) -> Vec<Step> {
    let params = ReferenceVehicleParams {
        model: truth,
        ..ReferenceVehicleParams::default()
    };
    let mut truth = ReferenceVehicle::new(&params, SPEED);
    let mut trace = Vec::new();
    for k in 0..SAMPLES {
        let t = k as f64 * SAMPLE_TIME;
        let steering = step_degrees.to_radians() * ((t - 1.0) / 0.1).clamp(0.0, 1.0);
        let input = DriverInputVector::new(steering, 0.0, 0.0);
        set_sensors(s, steering, &truth.truth(&input));
        assert_eq!(s.do_step(t, SAMPLE_TIME), Fmi2Status::Ok);
        for _ in 0..10 {
            truth.step(&input, 0.001).expect("reference step");
        }
        let outputs: [f64; 7] = s.reals(&OUTPUTS).try_into().expect("seven outputs");
        trace.push(Step {
            outputs,
            truth: truth.truth(&input).sideslip,
            status: s.get_integer(vr::STATUS).1,
            nis: s.get_real(vr::NIS).1,
            rows_used: s.get_integer(vr::ROWS_USED).1,
        });
    }
    trace
}

#[test]
fn the_consider_term_widens_the_reported_std_and_leaves_the_estimate_alone() {
    for model in [
        EstimatorModel::SingleTrack5State,
        EstimatorModel::TwoTrack3State,
    ] {
        widens_the_reported_std_and_leaves_the_estimate_alone(model);
    }
}

/// The covariance of the grip model's EKF, UKFs and gain-scheduled LKF (the default) holds its
/// tyres' scale uncertainty (the grip states): every output is the same to the bit whatever the
/// parameter. Its LKF linearised once (`schedule_threshold` 0) and its particle filter, whose
/// covariances do not follow the grip, report the term.
#[test]
fn the_grip_models_ekf_and_ukfs_report_their_own_covariance() {
    let model = EstimatorModel::SingleTrackGrip;
    let linearised_once = [(vr::SCHEDULE_THRESHOLD, 0.0)];
    for kind in [
        EstimatorKind::Ekf,
        EstimatorKind::Ukf,
        EstimatorKind::UkfScaled,
        EstimatorKind::Lkf,
    ] {
        let with = run(&mut estimator_of_kind(kind, model, Some(0.25)));
        let without = run(&mut estimator_of_kind(kind, model, Some(0.0)));
        for (k, ((w, _), (o, _))) in with.iter().zip(&without).enumerate() {
            for i in 0..w.len() {
                assert_eq!(
                    w[i].to_bits(),
                    o[i].to_bits(),
                    "{kind:?} k = {k}, output {i}"
                );
            }
        }
        // and a sideslip std is reported (the filter's own, not 0)
        assert!(with[200..].iter().all(|(w, _)| w[4] > 0.0), "{kind:?}");
    }
    for (kind, settings) in [
        (EstimatorKind::Lkf, &linearised_once[..]),
        (EstimatorKind::ParticleFilter, &[]),
    ] {
        let with = run(&mut estimator_with(kind, model, Some(0.25), settings));
        let without = run(&mut estimator_with(kind, model, Some(0.0), settings));
        // in the corner the rear slip angle is not 0, so the term widens the std
        let wider = with[200..]
            .iter()
            .zip(&without[200..])
            .all(|((w, _), (o, _))| w[4] > o[4]);
        assert!(wider, "{kind:?}");
    }
}

/// The stiffness term alone: model A's lag term off (relaxation length 0; model B has none).
fn widens_the_reported_std_and_leaves_the_estimate_alone(model: EstimatorModel) {
    let sigma = 0.2;
    let ekf = |uncertainty| {
        run(&mut estimator_with_lag(
            EstimatorKind::Ekf,
            model,
            uncertainty,
            Some(0.0),
        ))
    };
    let with = ekf(Some(sigma));
    let without = ekf(Some(0.0));
    let default = ekf(None);
    // The speed filter both models report vx from weighs the lateral estimate's reported
    // uncertainty, the consider term included (speed_filter's prediction_variance): vx, and
    // vy = vx tan β, move by far less than the speed sensor's noise (measured: at most 2e-4
    // m/s), and so does model B's lateral estimate, whose input the speed is (2e-8 rad).
    // Model A's lateral estimate does not depend on it.
    let mut speed_moved = false;
    for (k, ((w, _), (o, _))) in with.iter().zip(&without).enumerate() {
        for i in [0, 3, 6] {
            match model {
                EstimatorModel::TwoTrack3State => {
                    assert!((w[i] - o[i]).abs() < 1e-6, "{model:?} k = {k}, output {i}")
                }
                _ => assert_eq!(
                    w[i].to_bits(),
                    o[i].to_bits(),
                    "{model:?} k = {k}, output {i}"
                ),
            }
        }
        assert!((w[2] - o[2]).abs() < 1e-3, "{model:?} k = {k}: vx");
        assert!(
            (w[1] - w[2] * w[0].tan()).abs() <= 1e-12 * w[1].abs().max(1e-9),
            "{model:?} k = {k}: vy = vx tan β"
        );
        speed_moved |= w[2] != o[2];
        // std² = P + (σ αR)², and vy's with vx times that (first order through β = vy / vx;
        // the speed filter's own std enters vy's only through tan β, 1e-4 of it here).
        // (Model B's covariance moves with its speed input, by 1e-6 of it at most.)
        let tolerance = match model {
            EstimatorModel::TwoTrack3State => 1e-6,
            _ => 1e-12,
        };
        let consider = sigma * w[6].abs();
        let expected = o[4].hypot(consider);
        assert!(
            (w[4] - expected).abs() <= tolerance * expected.max(1e-9),
            "{model:?} k = {k}"
        );
        let expected_vy = o[5].hypot(w[2].abs() * consider);
        assert!(
            (w[5] - expected_vy).abs() <= 1e-4 * expected_vy.max(1e-9),
            "{model:?} k = {k}: {} against {expected_vy}",
            w[5]
        );
    }
    assert!(
        speed_moved,
        "{model:?}: the speed filter sees the consider term"
    );
    // The default is the documented 0.2.
    assert!(with.iter().zip(&default).all(|(a, b)| a.0 == b.0));
}

#[test]
fn in_the_corner_the_consider_term_covers_the_error_the_filter_covariance_does_not() {
    let covered = |trace: &[([f64; 7], f64)]| {
        let corner = &trace[200..];
        let inside = corner
            .iter()
            .filter(|(outputs, truth)| (outputs[0] - truth).abs() <= 1.96 * outputs[4])
            .count();
        inside as f64 / corner.len() as f64
    };
    let model = EstimatorModel::SingleTrack5State;
    let with = covered(&run(&mut estimator(model, None)));
    let without = covered(&run(&mut estimator(model, Some(0.0))));
    println!("inside the 95 % bound in the corner: {with:.2} with, {without:.2} without");
    assert!(
        with >= 0.9,
        "with the consider term {with:.2} inside the 95 % bound"
    );
    assert!(
        without < 0.5,
        "the filter's covariance alone {without:.2} inside"
    );
}

/// Model A's second term, the tyre lag it leaves out ((σr / |vx|) |α̇R|, in quadrature; see
/// `with_stiffness_consider`): the estimate is the same to the bit, the reported sideslip std is
/// wider while the slip angle moves (the step at 1.0-1.1 s and the yaw response after it) and
/// the same in the steady corner, where the slip angle stands still; `cornering_stiffness_
/// uncertainty` = 0 turns it off with the stiffness term.
#[test]
fn model_a_reports_its_tyre_lag_while_the_slip_angle_moves() {
    let model = EstimatorModel::SingleTrack5State;
    let ekf = |uncertainty, length| {
        run(&mut estimator_with_lag(
            EstimatorKind::Ekf,
            model,
            uncertainty,
            Some(length),
        ))
    };
    let lagging = ekf(None, 0.5);
    let instantaneous = ekf(None, 0.0);
    for (k, ((l, _), (i, _))) in lagging.iter().zip(&instantaneous).enumerate() {
        for j in [0, 1, 2, 3, 6] {
            assert_eq!(l[j].to_bits(), i[j].to_bits(), "k = {k}, output {j}");
        }
        assert!(l[4] >= i[4] && l[5] >= i[5], "k = {k}");
    }
    let widening = |k: usize| lagging[k].0[4] / instantaneous[k].0[4];
    let transient = (100..160).map(widening).fold(0.0f64, f64::max);
    assert!(
        transient > 1.5,
        "largest widening in the transient {transient}"
    );
    let steady = (250..300).map(widening).fold(0.0f64, f64::max);
    println!("sideslip std widened by the lag term: up to {transient:.2} x in the transient, {steady:.4} x steady");
    assert!(steady < 1.01, "widening in the steady corner {steady}");
    let off = ekf(Some(0.0), 0.5);
    let none = ekf(Some(0.0), 0.0);
    assert!(off.iter().zip(&none).all(|(a, b)| a.0 == b.0));
}
