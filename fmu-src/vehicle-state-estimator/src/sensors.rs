//! The sensor inputs of one sample as the runner reads them, the wheels' radii that turn wheel
//! speeds into a speed, and what the sensors measure without the filter (a held sample's
//! outputs).

use crate::model_description::{EstimatorModel, Variables};
use crate::parameters;

/// The sensor inputs of one doStep (XML: the `*_meas` inputs the estimator reads).
#[derive(Clone, Copy, Debug)]
pub struct Sensors {
    pub yaw_rate: f64,
    pub ay: f64,
    pub omega_front: f64,
    pub omega_rear: f64,
    pub vx: f64,
    pub ax: f64,
}

/// The number of sensor inputs.
pub const SENSOR_COUNT: usize = 6;

impl Sensors {
    /// `[yaw_rate, ay, omega_front, omega_rear, vx, ax]`.
    pub fn values(&self) -> [f64; SENSOR_COUNT] {
        [
            self.yaw_rate,
            self.ay,
            self.omega_front,
            self.omega_rear,
            self.vx,
            self.ax,
        ]
    }

    pub fn of(v: &Variables) -> Self {
        Self {
            yaw_rate: v.yaw_rate_meas,
            ay: v.ay_meas,
            omega_front: v.omega_front_meas,
            omega_rear: v.omega_rear_meas,
            vx: v.vx_meas,
            ax: v.ax_meas,
        }
    }

    /// Every lateral and wheel sensor reads exactly 0 (and `vx_meas` too, or it is missing):
    /// what a master sends before its first values and what a CAN dropout reads. Implausible
    /// while the estimate moves.
    pub fn all_zero(&self) -> bool {
        [self.yaw_rate, self.ay, self.omega_front, self.omega_rear]
            .into_iter()
            .all(|value| value == 0.0)
            && !(self.vx.is_finite() && self.vx != 0.0)
    }

    /// The mean of the finite wheels' rolling speeds `r_F ωF` and `r_R ωR`, if any. Written as
    /// `r_F` times the mean of front-wheel-equivalent speeds (`ωR r_R / r_F`), so that equal
    /// radii give `r_w · mean(ω)` to the bit, as before the radii were split.
    pub fn wheel_speed(&self, radii: WheelRadii) -> Option<f64> {
        let rear_to_front = radii.rear / radii.front;
        let (sum, count) = [self.omega_front, self.omega_rear * rear_to_front]
            .into_iter()
            .filter(|w| w.is_finite())
            .fold((0.0, 0u32), |(sum, count), w| (sum + w, count + 1));
        (count > 0).then(|| radii.front * sum / f64::from(count))
    }

    /// The measured speed: `vx_meas`, else the wheel-speed fallback, each only when finite and
    /// at least `min_speed` (XML: vx_meas).
    pub fn speed(&self, radii: WheelRadii, min_speed: f64) -> Option<f64> {
        let usable = |speed: f64| speed.is_finite() && speed >= min_speed;
        if usable(self.vx) {
            Some(self.vx)
        } else {
            self.wheel_speed(radii).filter(|&s| usable(s))
        }
    }
}

/// The rolling radii of the front and rear wheels (XML: `wheel_radius_front`,
/// `wheel_radius_rear`), m.
#[derive(Clone, Copy, Debug)]
pub struct WheelRadii {
    pub front: f64,
    pub rear: f64,
}

impl WheelRadii {
    pub fn of(v: &Variables) -> Self {
        Self {
            front: v.wheel_radius_front,
            rear: v.wheel_radius_rear,
        }
    }

    /// The wheel speeds `[ωF, ωR]` of free rolling at `speed`.
    pub fn free_rolling(&self, speed: f64) -> [f64; 2] {
        [speed / self.front, speed / self.rear]
    }
}

/// What the sensors measured in a sample, without the filter, each `None` where not measured:
/// what a held sample's outputs report in place of the stale estimate, and which wheels the
/// outputs may take as measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measurements {
    pub speed: Option<MeasuredSpeed>,
    /// `yaw_rate_meas` less the gyro's offset learned so far, and the gyro's noise std, rad/s.
    pub yaw_rate: Option<(f64, f64)>,
    /// `[omega_front_meas, omega_rear_meas]` and their noise stds, rad/s.
    pub wheel_speeds: [Option<(f64, f64)>; 2],
}

impl Measurements {
    pub fn of(sensors: &Sensors, v: &Variables, yaw_rate_offset: f64) -> Self {
        let finite = |value: f64, std: f64| value.is_finite().then_some((value, std));
        Self {
            speed: MeasuredSpeed::of(sensors, v),
            yaw_rate: finite(
                sensors.yaw_rate - yaw_rate_offset,
                v.measurement_noise_std_yaw_rate,
            ),
            wheel_speeds: [
                finite(sensors.omega_front, v.measurement_noise_std_omega_front),
                finite(sensors.omega_rear, v.measurement_noise_std_omega_rear),
            ],
        }
    }
}

/// A speed as the sensors measure it, without the filter: what a held sample reports as vx_est.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredSpeed {
    pub speed: f64,
    /// The measurement's standard deviation, m/s.
    pub std: f64,
}

impl MeasuredSpeed {
    /// `vx_meas` if finite and the model reads it (model B always, model A with
    /// `use_speed_measurements`; XML: vx_meas): a speed measured without the wheels.
    pub fn vx_meas(sensors: &Sensors, v: &Variables) -> Option<f64> {
        let reads_vx_meas = v.use_speed_measurements
            || matches!(
                parameters::estimator_model(v),
                Ok(EstimatorModel::TwoTrack3State)
            );
        (reads_vx_meas && sensors.vx.is_finite()).then_some(sensors.vx)
    }

    /// `vx_meas` if finite (negative when reversing) and the model reads it (model B always,
    /// model A with `use_speed_measurements`; XML: vx_meas), else the wheels' rolling speed
    /// `r ω` with the larger wheel noise `r σ_ω`; no threshold, since the held sample is below
    /// `min_speed`.
    pub fn of(sensors: &Sensors, v: &Variables) -> Option<Self> {
        if let Some(speed) = Self::vx_meas(sensors, v) {
            return Some(Self {
                speed,
                std: v.measurement_noise_std_vx,
            });
        }
        let radii = WheelRadii::of(v);
        let wheel_std = (radii.front * v.measurement_noise_std_omega_front)
            .max(radii.rear * v.measurement_noise_std_omega_rear);
        sensors.wheel_speed(radii).map(|speed| Self {
            speed,
            std: wheel_std,
        })
    }
}
