//! The manoeuvre library produces the signals the seeds describe.

use approx::assert_relative_eq;
use manoeuvres::{
    library, Channel, Manoeuvre, ManoeuvreRun, VehicleMotion, LIBRARY, STEERING_RATIO,
};

fn values(name: &str, channel: Channel, times: &[f64]) -> Vec<f64> {
    let mut run = ManoeuvreRun::new(library(name).unwrap());
    times
        .iter()
        .map(|&t| {
            run.update(t, None);
            run.value(channel, t)
        })
        .collect()
}

#[test]
fn every_library_name_resolves_and_validates() {
    for name in LIBRARY {
        let m = library(name).unwrap_or_else(|| panic!("{name}"));
        m.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(manoeuvres::describe(name).is_some());
    }
    assert!(library("nope").is_none());
}

#[test]
fn seed000_ramps_start_at_4s_with_0_07_rad_per_s() {
    let s = values(
        "seed000_ramp_moderate_ay",
        Channel::SteeringAngle,
        &[0.0, 4.0, 4.25, 4.5, 8.0],
    );
    assert_eq!(s[0], 0.0);
    assert_eq!(s[1], 0.0);
    assert_relative_eq!(s[2], 0.07 * 0.25, max_relative = 1e-12);
    assert_relative_eq!(s[3], 0.035, max_relative = 1e-12);
    assert_relative_eq!(s[4], 0.035, max_relative = 1e-12);
    let high = values("seed000_ramp_high_ay", Channel::SteeringAngle, &[5.0, 10.0]);
    assert_relative_eq!(high[0], 0.07, max_relative = 1e-12);
    assert_relative_eq!(high[1], 0.122, max_relative = 1e-12);
    let wheel = values("seed000_ramp_high_ay", Channel::SteeringWheelAngle, &[10.0]);
    assert_relative_eq!(wheel[0], 0.122 * STEERING_RATIO, max_relative = 1e-12);
}

#[test]
fn seed000_brake_ramps_to_2000_between_9_and_11_s_and_holds_to_12() {
    let b = values(
        "seed000_ramp_high_ay_braking",
        Channel::BrakeTorque,
        &[8.9, 9.0, 10.0, 11.0, 11.9, 12.0],
    );
    assert_eq!(b[0], 0.0);
    assert_eq!(b[1], 0.0);
    assert_relative_eq!(b[2], 1000.0, max_relative = 1e-12);
    assert_relative_eq!(b[3], 2000.0, max_relative = 1e-12);
    assert_relative_eq!(b[4], 2000.0);
    assert_relative_eq!(b[5], 2000.0);
    // No braking in the plain ramp, and magnitudes are never negative.
    assert!(
        values("seed000_ramp_high_ay", Channel::BrakeTorque, &[10.0, 11.5])
            .iter()
            .all(|&v| v == 0.0)
    );
}

#[test]
fn seed000_step_is_two_degrees_at_four_seconds() {
    let s = values(
        "seed000_step_steer_2deg",
        Channel::SteeringAngle,
        &[3.999, 4.0, 6.0],
    );
    assert_eq!(s[0], 0.0);
    assert_relative_eq!(s[1], 2f64.to_radians(), max_relative = 1e-12);
    assert_relative_eq!(s[2], 2f64.to_radians(), max_relative = 1e-12);
}

#[test]
fn seed001_step_is_40_degrees_at_the_steering_wheel_and_65_kmh() {
    let w = values(
        "seed001_step_steer_40deg",
        Channel::SteeringWheelAngle,
        &[0.5, 1.05, 2.0],
    );
    assert_eq!(w[0], 0.0);
    assert_relative_eq!(w[1], 20f64.to_radians(), max_relative = 1e-9);
    assert_relative_eq!(w[2], 40f64.to_radians(), max_relative = 1e-12);
    let v = values("seed001_step_steer_40deg", Channel::InitialSpeed, &[0.0]);
    assert_relative_eq!(v[0] * 3.6, 65.0, max_relative = 1e-12);
}

#[test]
fn wobble_goes_150_left_then_225_right() {
    let m = library("seed001_wobble").unwrap();
    let Manoeuvre::Wobble(w) = &m else { panic!() };
    let quarter = 0.25 / w.frequency;
    let t_left = w.start_time + quarter;
    let t_right = w.start_time + 3.0 * quarter;
    let s = values(
        "seed001_wobble",
        Channel::SteeringWheelAngle,
        &[t_left, t_right, w.start_time + 4.0 * quarter + 0.1],
    );
    assert_relative_eq!(s[0], 150f64.to_radians(), max_relative = 1e-12);
    assert_relative_eq!(s[1], -225f64.to_radians(), max_relative = 1e-12);
    assert_eq!(s[2], 0.0);
    assert_relative_eq!(m.initial_speed() * 3.6, 80.0, max_relative = 1e-12);
}

#[test]
fn sine_with_dwell_holds_the_second_peak_for_500_ms() {
    let m = library("fmvss126_sine_with_dwell").unwrap();
    let Manoeuvre::SineWithDwell(s) = &m else {
        panic!()
    };
    let period = 1.0 / s.frequency;
    let peak2 = s.start_time + 0.75 * period;
    let w = values(
        "fmvss126_sine_with_dwell",
        Channel::SteeringWheelAngle,
        &[
            s.start_time + 0.25 * period,
            peak2 + 0.01,
            peak2 + 0.49,
            s.start_time + period + s.dwell + 0.01,
        ],
    );
    assert_relative_eq!(w[0], s.amplitude, max_relative = 1e-12);
    assert_relative_eq!(w[1], -s.amplitude, max_relative = 1e-12);
    assert_relative_eq!(w[2], -s.amplitude, max_relative = 1e-12);
    assert_eq!(w[3], 0.0);
    assert_eq!(s.frequency, 0.7);
    assert_eq!(s.dwell, 0.5);
}

#[test]
fn lane_change_course_is_continuous_with_a_3_5_m_offset() {
    let m = library("seed001_double_lane_change").unwrap();
    let Manoeuvre::DoubleLaneChange(d) = &m else {
        panic!()
    };
    let start = d.approach + d.entry_length;
    assert_eq!(m.path_lateral_position(start - 1.0), Some(0.0));
    assert_relative_eq!(
        m.path_lateral_position(start + d.first_transition + 1.0)
            .unwrap(),
        3.5
    );
    assert_eq!(m.path_lateral_position(start + 200.0), Some(0.0));
    let mut previous = 0.0;
    for k in 0..2000 {
        let y = m.path_lateral_position(k as f64 * 0.1).unwrap();
        assert!(
            (y - previous).abs() < 0.05,
            "jump at x = {}",
            k as f64 * 0.1
        );
        previous = y;
    }
}

/// The pure-pursuit driver keeps a kinematic single-track vehicle (driven by the same pose
/// integration the master uses) on the ISO 3888-1 course.
#[test]
fn driver_follows_the_lane_change_course() {
    let m = library("seed001_double_lane_change").unwrap();
    let Manoeuvre::DoubleLaneChange(d) = m.clone() else {
        panic!()
    };
    let mut run = ManoeuvreRun::new(m.clone());
    let h = 0.001;
    let speed = d.initial_speed;
    // Kinematic vehicle in its own world frame: yaw rate = v tan(delta) / wheelbase.
    let mut yaw_rate = 0.0;
    let mut worst: f64 = 0.0;
    for n in 0..=((d.duration / h) as usize) {
        let t = n as f64 * h;
        run.update(
            t,
            Some(VehicleMotion {
                longitudinal_velocity: speed,
                lateral_velocity: 0.0,
                yaw_rate,
            }),
        );
        let delta = run.value(Channel::SteeringAngle, t);
        yaw_rate = speed * delta.tan() / d.wheelbase;
        let pose = run.pose();
        let error = pose.y - m.path_lateral_position(pose.x).unwrap();
        worst = worst.max(error.abs());
    }
    assert!(
        run.pose().x > 150.0,
        "did not get through the course: x = {}",
        run.pose().x
    );
    assert!(
        worst < 0.6,
        "largest lateral deviation from the centre line {worst} m"
    );
    // Speed held: no drive torque needed at the target speed.
    assert_eq!(run.value(Channel::DriveTorque, d.duration), 0.0);
}

/// ISO 3888-2: lane 3 (b + 1 m wide) begins 1 m beyond the left edge of lane 1 (1.1 b + 0.25 m
/// wide), the exit lane (1.3 b + 0.25 m) shares lane 1's right edge; b = 1.75 m. Worked out by
/// hand: centre lines at 0, 1.0875 + 1 + 1.375 = 3.4625 m and 0.175 m.
#[test]
fn moose_test_course_follows_iso_3888_2() {
    let m = library("seed001_moose_test").unwrap();
    let Manoeuvre::DoubleLaneChange(d) = &m else {
        panic!()
    };
    assert_eq!(d.course, manoeuvres::LaneChangeCourse::Iso3888Part2);
    let lane_1_end = d.approach + 12.0;
    let lane_3_start = lane_1_end + 13.5;
    let lane_3_end = lane_3_start + 11.0;
    let lane_5_start = lane_3_end + 12.5;
    assert_eq!(m.path_lateral_position(lane_1_end - 0.5), Some(0.0));
    for x in [lane_3_start + 0.1, lane_3_end - 0.1] {
        assert_relative_eq!(
            m.path_lateral_position(x).unwrap(),
            3.4625,
            max_relative = 1e-12
        );
    }
    for x in [lane_5_start + 0.1, lane_5_start + 12.0] {
        assert_relative_eq!(
            m.path_lateral_position(x).unwrap(),
            0.175,
            max_relative = 1e-12
        );
    }
    // Continuous centre line: no jump between 0.1 m samples.
    let mut previous = 0.0;
    for k in 0..1500 {
        let y = m.path_lateral_position(k as f64 * 0.1).unwrap();
        assert!((y - previous).abs() < 0.1, "jump at x = {}", k as f64 * 0.1);
        previous = y;
    }
}

#[test]
fn speed_controller_drives_when_slower_than_the_target() {
    let m = library("seed001_double_lane_change").unwrap();
    let mut run = ManoeuvreRun::new(m.clone());
    run.update(
        0.0,
        Some(VehicleMotion {
            longitudinal_velocity: m.initial_speed() - 1.0,
            lateral_velocity: 0.0,
            yaw_rate: 0.0,
        }),
    );
    assert!(run.value(Channel::DriveTorque, 0.0) > 0.0);
    assert_eq!(run.value(Channel::BrakeTorque, 0.0), 0.0);
}

/// The seed-000 manoeuvres as the models' tests drive them: the closed forms of seed 000 ch. 7
/// (ramp `min(0.07 max(t - 4, 0), limit)`, brake `min(max(t - 9, 0) / 2, 1) 2000`, step 2° at
/// 4 s), bit for bit, on a 1 ms grid to the end and a rounding step beyond it.
#[test]
fn seed000_signals_are_the_closed_forms_bit_for_bit() {
    use manoeuvres::seed000::SeedManoeuvre;
    let ramp = |t: f64, limit: f64| ((t - 4.0_f64).max(0.0) * 0.07).min(limit);
    let brake = |t: f64| ((t - 9.0_f64).max(0.0) / 2.0).min(1.0) * 2000.0;
    let step = |t: f64| {
        if t >= 4.0 {
            2.0 * std::f64::consts::PI / 180.0
        } else {
            0.0
        }
    };
    let mut times: Vec<f64> = (0..=12_000).map(|k| k as f64 * 0.001).collect();
    times.push(12.0 + 1e-12);
    for t in times {
        let expected = [
            (SeedManoeuvre::ModerateRamp, ramp(t, 0.035), 0.0),
            (SeedManoeuvre::HighRamp, ramp(t, 0.122), 0.0),
            (SeedManoeuvre::HighRampBraking, ramp(t, 0.122), brake(t)),
            (SeedManoeuvre::StepSteer, step(t), 0.0),
        ];
        for (manoeuvre, steering, braking) in expected {
            let u = manoeuvre.input_at(t);
            assert_eq!(
                u.steering_angle.to_bits(),
                steering.to_bits(),
                "{manoeuvre:?} t={t}"
            );
            assert_eq!(
                u.brake_torque.to_bits(),
                braking.to_bits(),
                "{manoeuvre:?} t={t}"
            );
            assert_eq!(u.drive_torque, 0.0);
        }
    }
}

/// The Python tests read the seed-000 numbers from this generated table; it must be current.
/// `UPDATE_MANOEUVRE_TABLE=1 cargo test -p manoeuvres` rewrites it.
#[test]
fn the_generated_seed000_table_is_current() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("seed000_manoeuvres.toml");
    let generated = format!(
        "# Generated from fmu-src/manoeuvres/src/seed000.rs by its test \
         (UPDATE_MANOEUVRE_TABLE=1 cargo test -p manoeuvres); do not edit.\n{}",
        toml::to_string(&manoeuvres::seed000::Seed000Table::TABLE).unwrap()
    );
    if std::env::var_os("UPDATE_MANOEUVRE_TABLE").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let stored = std::fs::read_to_string(&path).unwrap_or_default();
    assert_eq!(
        stored,
        generated,
        "{} is stale: run UPDATE_MANOEUVRE_TABLE=1 cargo test -p manoeuvres",
        path.display()
    );
}
