//! The wheels' rolling radii (`rolling_radius`, parameter `wheel_radius_std`): learned driving
//! straight without traction, held while the car accelerates, brakes or corners and without a
//! measured speed, untouched by a locked wheel.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use VehicleStateEstimator::model_description::Variables;
use VehicleStateEstimator::rolling_radius::{RadiusSample, RollingRadius};

const T: f64 = 0.01;
/// The nominal radii, m, and the radius errors the wheels roll with (a worn front tyre, a
/// rear one at high pressure): each wheel rolls as if its radius were `r (1 + error)`.
const RADIUS: [f64; 2] = [0.30, 0.31];
const ERROR: [f64; 2] = [-0.025, 0.02];
/// The sensors' noise: wheel speeds, rad/s, and the measured speed, m/s.
const WHEEL_NOISE: f64 = 0.1;
const SPEED_NOISE: f64 = 0.05;

fn learner() -> RollingRadius {
    let v = Variables {
        sample_time: T,
        wheel_radius_front: RADIUS[0],
        wheel_radius_rear: RADIUS[1],
        measurement_noise_std_omega_front: WHEEL_NOISE,
        measurement_noise_std_omega_rear: WHEEL_NOISE,
        measurement_noise_std_vx: SPEED_NOISE,
        ..Variables::default()
    };
    RollingRadius::from_parameters(&v)
        .expect("valid parameters")
        .expect("on by default")
}

/// `samples` samples of a car at `speed` driving straight with `ax`, its wheels rolling
/// freely on their true radii, with noise on every sensor.
fn feed(learner: &mut RollingRadius, rng: &mut ChaCha8Rng, samples: usize, speed: f64, ax: f64) {
    let wheel = Normal::new(0.0, WHEEL_NOISE).unwrap();
    let measured = Normal::new(0.0, SPEED_NOISE).unwrap();
    for _ in 0..samples {
        let omega = std::array::from_fn(|axle| {
            speed / (RADIUS[axle] * (1.0 + ERROR[axle])) + wheel.sample(rng)
        });
        learner.step(&RadiusSample {
            omega,
            speed: speed + measured.sample(rng),
            ax,
            ay: 0.0,
            yaw_rate: 0.0,
            steering: 0.0,
        });
    }
}

fn learned(learner: &RollingRadius) -> [f64; 2] {
    learner.axles.map(|axle| axle.mean)
}

#[test]
fn driving_straight_the_radii_are_learned_within_ten_seconds() {
    let mut learner = learner();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    feed(&mut learner, &mut rng, 1000, 25.0, 0.1);
    for (axle, learned) in learned(&learner).into_iter().enumerate() {
        assert!(
            (learned - ERROR[axle]).abs() < 0.002,
            "axle {axle}: learned {learned}, true {}",
            ERROR[axle]
        );
    }
    // the corrected wheel speeds roll on the nominal radii
    let omega = [
        25.0 / (RADIUS[0] * (1.0 - 0.025)),
        25.0 / (RADIUS[1] * 1.02),
    ];
    let corrected = learner.corrected(omega);
    for axle in 0..2 {
        let speed = corrected[axle] * RADIUS[axle];
        assert!((speed - 25.0).abs() < 0.05, "axle {axle}: {speed} m/s");
    }
}

/// Under traction or braking the wheels slip, and in a corner the front wheel's speed is not
/// the measured speed's projection: nothing is learned there, and without a measured speed
/// (missing, or slower than the wheel speeds' resolution allows) neither.
#[test]
fn accelerating_braking_cornering_or_without_a_measured_speed_nothing_is_learned() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for (ax, ay, steering, speed) in [
        (2.0, 0.0, 0.0, 25.0),
        (-4.0, 0.0, 0.0, 25.0),
        (0.0, 6.0, 0.05, 25.0),
        (0.0, 0.0, 0.0, f64::NAN),
        (0.0, 0.0, 0.0, 3.0),
        (f64::NAN, 0.0, 0.0, 25.0),
    ] {
        let mut learner = learner();
        let wheel = Normal::new(0.0, WHEEL_NOISE).unwrap();
        for _ in 0..500 {
            let omega = std::array::from_fn(|axle| {
                20.0 / (RADIUS[axle] * (1.0 + ERROR[axle])) + wheel.sample(&mut rng)
            });
            learner.step(&RadiusSample {
                omega,
                speed,
                ax,
                ay,
                yaw_rate: 0.0,
                steering,
            });
        }
        assert_eq!(learned(&learner), [0.0; 2], "ax {ax} ay {ay} speed {speed}");
        // predicted only: the prior's stationary variance
        let prior = 0.03 * 0.03;
        for axle in learner.axles {
            assert!((axle.variance - prior).abs() < 1e-12 * prior);
        }
    }
}

/// A wheel that locks for a moment reads 0, far outside the gate: the learned radius does not
/// move.
#[test]
fn a_locked_wheel_is_not_taken_for_a_radius() {
    let mut learner = learner();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    feed(&mut learner, &mut rng, 1000, 25.0, 0.0);
    let before = learned(&learner);
    for _ in 0..20 {
        learner.step(&RadiusSample {
            omega: [1.0, 25.0 / (RADIUS[1] * 1.02)],
            speed: 25.0,
            ax: 0.0,
            ay: 0.0,
            yaw_rate: 0.0,
            steering: 0.0,
        });
    }
    assert!((learned(&learner)[0] - before[0]).abs() < 1e-4);
}
