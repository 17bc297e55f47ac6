//! Steady-state handling diagram on a circle of R = 100 m (000: fig. 5.7-5.10): stationary
//! solutions of model A's equations of motion (000: 5.42-5.46) with `v² = vx² + vy²` and
//! `r = v / R`, solved by Newton's method for `[vx, vy, r, ωF, ωR, δ, M_A]` at given normal
//! acceleration `an = v² / R`, for the HSRI tyre and for its linearisation.

use nalgebra::{SMatrix, SVector};
use vehicle_models::single_track::state_index;
use vehicle_models::tyre::{LinearTyre, TyreModel};
use vehicle_models::{Dual, SingleTrackHsri, SingleTrackModel, SingleTrackParams};

const RADIUS: f64 = 100.0;
const UNKNOWNS: usize = 7;
type Unknowns = SVector<f64, UNKNOWNS>;
type D = Dual<f64, UNKNOWNS>;

/// One point of the handling diagram.
#[derive(Clone, Copy, Debug)]
struct SteadyState {
    normal_acceleration: f64,
    steering_angle: f64,
    sideslip: f64,
    slip_angle_front: f64,
    slip_angle_rear: f64,
}

fn residual<T: TyreModel>(
    model: &SingleTrackModel<T>,
    z: &[D; UNKNOWNS],
    speed: f64,
) -> [D; UNKNOWNS] {
    let state = [z[0], z[1], z[2], z[3], z[4]];
    let input = [z[5], z[6], D::from_value(0.0)];
    let rates = model.derivatives_generic(&state, &input);
    [
        rates[0],
        rates[1],
        rates[2],
        rates[3],
        rates[4],
        z[0] * z[0] + z[1] * z[1] - speed * speed,
        z[2] - speed / RADIUS,
    ]
}

fn solve<T: TyreModel>(model: &SingleTrackModel<T>, speed: f64, start: Unknowns) -> Unknowns {
    let mut z = start;
    for _ in 0..50 {
        let seeded: [D; UNKNOWNS] = core::array::from_fn(|i| D::variable(z[i], i));
        let f = residual(model, &seeded, speed);
        let values = Unknowns::from_fn(|i, _| f[i].value);
        if values.amax() < 1e-10 {
            return z;
        }
        let jacobian = SMatrix::<f64, UNKNOWNS, UNKNOWNS>::from_fn(|i, j| f[i].gradient[j]);
        let step = jacobian
            .lu()
            .solve(&values)
            .expect("regular steady-state Jacobian");
        z -= step;
    }
    panic!("steady state at v = {speed} did not converge: {z}");
}

fn handling_diagram<T: TyreModel>(
    model: &SingleTrackModel<T>,
    accelerations: &[f64],
) -> Vec<SteadyState> {
    let r_w = model.vehicle.chassis.front_wheel_radius;
    let wheelbase =
        model.vehicle.chassis.cog_to_front_axle + model.vehicle.chassis.cog_to_rear_axle;
    let first_speed = (accelerations[0] * RADIUS).sqrt();
    let mut z = Unknowns::from([
        first_speed,
        0.0,
        first_speed / RADIUS,
        first_speed / r_w,
        first_speed / r_w,
        wheelbase / RADIUS,
        0.0,
    ]);
    let mut diagram = Vec::new();
    for &an in accelerations {
        let speed = (an * RADIUS).sqrt();
        // continuation: scale the previous solution to the new speed
        let scale = speed / (z[0] * z[0] + z[1] * z[1]).sqrt();
        let start = Unknowns::from([
            z[0] * scale,
            z[1] * scale,
            z[2] * scale,
            z[3] * scale,
            z[4] * scale,
            z[5],
            z[6] * scale * scale,
        ]);
        z = solve(model, speed, start);
        let x = SVector::<f64, 5>::from([z[0], z[1], z[2], z[3], z[4]]);
        let u = SVector::<f64, 3>::new(z[5], z[6], 0.0);
        let o = model.outputs(&x, &u);
        // steady circle: ay = vx r = an cos β (000: 5.40 with v̇y = 0)
        let sideslip = z[1].atan2(z[0]);
        assert!((o.lateral_acceleration - an * sideslip.cos()).abs() < 1e-8);
        diagram.push(SteadyState {
            normal_acceleration: an,
            steering_angle: z[5],
            sideslip,
            slip_angle_front: o.slip_angle_front,
            slip_angle_rear: o.slip_angle_rear,
        });
        assert!(x[state_index::YAW_RATE] > 0.0);
    }
    diagram
}

fn accelerations() -> Vec<f64> {
    (2..=28).map(|i| 0.25 * i as f64).collect() // 0.5 ... 7.0 m/s²
}

#[test]
fn linear_and_nonlinear_handling_diagrams_agree_up_to_about_6_mps2() {
    let nonlinear = handling_diagram(&SingleTrackHsri::default(), &accelerations());
    let linear = handling_diagram(
        &SingleTrackModel::new(SingleTrackParams::default(), LinearTyre::default()),
        &accelerations(),
    );
    for (n, l) in nonlinear.iter().zip(&linear) {
        let steer_error = (n.steering_angle - l.steering_angle).abs() / l.steering_angle;
        let front_error = (n.slip_angle_front - l.slip_angle_front).abs() / l.slip_angle_front;
        let rear_error = (n.slip_angle_rear - l.slip_angle_rear).abs() / l.slip_angle_rear;
        println!(
            "an {:4.2}: delta {:.5} / {:.5} rad, beta {:+.4} / {:+.4} deg, alphaF err {:.3}, alphaR err {:.3}",
            n.normal_acceleration,
            n.steering_angle,
            l.steering_angle,
            n.sideslip.to_degrees(),
            l.sideslip.to_degrees(),
            front_error,
            rear_error
        );
        if n.normal_acceleration <= 6.0 {
            // (000: fig. 5.7-5.10) "sehr gute Übereinstimmung ... bis etwa an = 6 m/s²"
            assert!(
                steer_error < 0.03,
                "delta at {}: {steer_error}",
                n.normal_acceleration
            );
            assert!(front_error < 0.05 && rear_error < 0.05);
            assert!((n.sideslip - l.sideslip).abs() < 0.05_f64.to_radians());
        }
    }
    // beyond that the tyres saturate and the models part
    let last = nonlinear.last().unwrap();
    let last_linear = linear.last().unwrap();
    assert!(last.slip_angle_front > last_linear.slip_angle_front * 1.05);
}

#[test]
fn the_car_understeers_and_its_sideslip_changes_sign_near_3_mps2() {
    let diagram = handling_diagram(&SingleTrackHsri::default(), &accelerations());
    let params = SingleTrackParams::default();
    let ackermann = (params.chassis.cog_to_front_axle + params.chassis.cog_to_rear_axle) / RADIUS;
    // understeer: the steering angle needed on the circle grows with an beyond Ackermann
    // (000: fig. 5.7), and the front slip angle exceeds the rear one (000: fig. 5.9-5.10)
    for pair in diagram.windows(2) {
        assert!(pair[1].steering_angle > pair[0].steering_angle);
    }
    for point in &diagram {
        assert!(point.steering_angle > ackermann);
        assert!(point.slip_angle_front > point.slip_angle_rear);
    }
    // (000: fig. 5.8) sideslip positive at first, negative from about an = 3 m/s²
    let crossing = diagram
        .windows(2)
        .find(|p| p[0].sideslip > 0.0 && p[1].sideslip <= 0.0)
        .map(|p| p[1].normal_acceleration)
        .expect("sideslip changes sign");
    assert!((2.5..=3.5).contains(&crossing), "crossing at {crossing}");
}
