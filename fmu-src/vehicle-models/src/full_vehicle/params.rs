//! Parameters of the full vehicle: plain serde structs grouped as the car files' TOML tables
//! (`cars/*.toml`, format in `cars/README.md`); `Default` is the seed car of seed 000.

use serde::{Deserialize, Serialize};

use crate::single_track::Chassis;
use crate::tyre::combined_slip::CombinedSlipParams;

/// Mass, geometry and yaw inertia of the whole car.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyParams {
    /// Total mass `m`, kg.
    pub mass: f64,
    /// CoG to front axle `l_f`, m.
    pub cog_to_front_axle: f64,
    /// CoG to rear axle `l_r`, m.
    pub cog_to_rear_axle: f64,
    /// Height of the total CoG above ground `h`, m (longitudinal load transfer).
    pub cog_height: f64,
    /// Yaw moment of inertia `I_z`, kg m².
    pub yaw_inertia: f64,
    /// Front track width `T_f`, m.
    pub track_front: f64,
    /// Rear track width `T_r`, m.
    pub track_rear: f64,
}

/// Roll of the sprung mass about a roll axis and the lateral load transfer it causes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuspensionParams {
    /// Unsprung mass of the front axle (both wheels), kg.
    pub unsprung_mass_front: f64,
    /// Unsprung mass of the rear axle (both wheels), kg.
    pub unsprung_mass_rear: f64,
    /// Height of the sprung mass's CoG above ground `h_s`, m.
    pub sprung_cog_height: f64,
    /// Height of the roll axis above ground `h_ra`, m (the same at both axles).
    pub roll_axis_height: f64,
    /// Roll moment of inertia of the sprung mass about the roll axis `I_x,s`, kg m².
    pub roll_inertia: f64,
    /// Roll stiffness of the front axle (springs and anti-roll bar) `K_φf`, N m/rad.
    pub roll_stiffness_front: f64,
    /// Roll stiffness of the rear axle `K_φr`, N m/rad.
    pub roll_stiffness_rear: f64,
    /// Roll damping of the front axle `D_φf`, N m s/rad.
    pub roll_damping_front: f64,
    /// Roll damping of the rear axle `D_φr`, N m s/rad.
    pub roll_damping_rear: f64,
}

/// Wheels (each its own rotational degree of freedom).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelParams {
    /// Effective rolling radius `r_e`, m (also the height of the unsprung masses' CoG).
    pub radius: f64,
    /// Spin inertia of **one** front wheel (with its share of the drive line), kg m².
    pub inertia_front: f64,
    /// Spin inertia of **one** rear wheel, kg m².
    pub inertia_rear: f64,
}

/// Optional anti-lock braking, off by default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AbsParams {
    pub enabled: bool,
    /// Longitudinal slip below `−slip_threshold` releases that wheel's brake for the step.
    pub slip_threshold: f64,
    /// Below this speed, m/s, the ABS is inactive (so the car can brake to a stop and hold).
    pub min_speed: f64,
}

impl Default for AbsParams {
    fn default() -> Self {
        Self {
            enabled: false,
            slip_threshold: 0.12,
            min_speed: 2.0,
        }
    }
}

/// Drive and brake torque distribution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrivetrainParams {
    /// Share of the drive torque on the front axle: 1 front-wheel drive, 0 rear-wheel drive,
    /// in between all-wheel drive with that fixed split. Each driven axle has an open
    /// differential: both of its wheels get half of the axle's torque.
    pub drive_split_front: f64,
    /// Share of the brake torque on the front axle; each wheel of an axle gets half.
    pub brake_split_front: f64,
    #[serde(default)]
    pub abs: AbsParams,
}

/// Steering: the input is the road-wheel angle; both front wheels steer by the same angle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteeringParams {
    /// Steering-wheel angle / road-wheel angle (for [`super::FullVehicleParams::road_wheel_angle`]).
    pub steering_ratio: f64,
    /// Time constant of a first-order lag from the commanded to the actual road-wheel angle, s
    /// (0: none).
    pub lag_time_constant: f64,
    /// Compliance steer, rad per N of front-axle lateral force: the road-wheel angle is reduced
    /// by `compliance · F_y,front` (the force of the previous internal step; 0: rigid).
    pub compliance: f64,
}

/// Low-speed regularisation of the tyre forces (see the module docs of [`super`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LowSpeedParams {
    /// `V_low`, m/s: below it the slip-velocity damping fades in.
    pub damping_speed: f64,
    /// Longitudinal damping at standstill, N s/m per tyre.
    pub longitudinal_damping: f64,
    /// Lateral damping at standstill, N s/m per tyre.
    pub lateral_damping: f64,
    /// Largest `|κ'|` the longitudinal deflection may represent (full sliding beyond).
    pub slip_limit: f64,
    /// Largest `|tan α'|` the lateral deflection may represent.
    pub tan_slip_angle_limit: f64,
}

impl Default for LowSpeedParams {
    fn default() -> Self {
        Self {
            damping_speed: 2.5,
            longitudinal_damping: 15000.0,
            lateral_damping: 6000.0,
            slip_limit: 1.5,
            tan_slip_angle_limit: 2.0,
        }
    }
}

/// Every parameter of the full vehicle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FullVehicleParams {
    pub body: BodyParams,
    pub suspension: SuspensionParams,
    pub wheels: WheelParams,
    pub drivetrain: DrivetrainParams,
    pub steering: SteeringParams,
    pub tyre_front: CombinedSlipParams,
    pub tyre_rear: CombinedSlipParams,
    #[serde(default)]
    pub low_speed: LowSpeedParams,
    /// Largest internal integration step, s; [`super::FullVehicle::step`] subdivides longer steps.
    #[serde(default = "default_internal_step")]
    pub internal_step: f64,
}

fn default_internal_step() -> f64 {
    1e-3
}

/// A car file (`cars/*.toml`): the car's name, the source of its values, its parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CarData {
    pub name: String,
    pub source: String,
    pub vehicle: FullVehicleParams,
}

impl Default for FullVehicleParams {
    /// The seed car: [`Chassis::default`] (000: tables 5.1, 5.2), model B's track, CoG height and
    /// front roll share (`TwoTrackParams::default`), the PAC2002 tyre of
    /// [`CombinedSlipParams::seed_car`]. What neither seed gives (roll stiffness, damping and
    /// inertia) is the project's choice: a roll gradient of 4 °/g split 60/40 like model B's
    /// roll moment, roll damping ratio 0.4, roll inertia 450 kg m². All mass is sprung (model B
    /// has no unsprung mass) and the roll axis is on the ground, so at steady state the lateral
    /// transfer is model B's `m ay h / s` shared 60/40 plus the gravity term of the roll.
    fn default() -> Self {
        let chassis = Chassis::default();
        Self {
            body: BodyParams {
                mass: chassis.mass,
                cog_to_front_axle: chassis.cog_to_front_axle,
                cog_to_rear_axle: chassis.cog_to_rear_axle,
                cog_height: 0.55,
                yaw_inertia: chassis.yaw_inertia,
                track_front: 1.5,
                track_rear: 1.5,
            },
            suspension: SuspensionParams {
                unsprung_mass_front: 0.0,
                unsprung_mass_rear: 0.0,
                sprung_cog_height: 0.55,
                roll_axis_height: 0.0,
                roll_inertia: 450.0,
                roll_stiffness_front: 69_500.0,
                roll_stiffness_rear: 46_300.0,
                roll_damping_front: 3_350.0,
                roll_damping_rear: 2_230.0,
            },
            wheels: WheelParams {
                radius: chassis.front_wheel_radius,
                // the seed's inertias are of both wheels of an axle
                inertia_front: 0.5 * chassis.front_wheel_inertia,
                inertia_rear: 0.5 * chassis.rear_wheel_inertia,
            },
            drivetrain: DrivetrainParams {
                drive_split_front: 1.0,
                brake_split_front: chassis.brake_split_front,
                abs: AbsParams::default(),
            },
            steering: SteeringParams {
                steering_ratio: chassis.steering_ratio,
                lag_time_constant: 0.0,
                compliance: 0.0,
            },
            tyre_front: CombinedSlipParams::seed_car(),
            tyre_rear: CombinedSlipParams::seed_car(),
            low_speed: LowSpeedParams::default(),
            internal_step: default_internal_step(),
        }
    }
}

impl FullVehicleParams {
    /// Wheelbase `L = l_f + l_r`, m.
    pub fn wheelbase(&self) -> f64 {
        self.body.cog_to_front_axle + self.body.cog_to_rear_axle
    }

    /// Sprung mass `m_s = m − m_uf − m_ur`, kg.
    pub fn sprung_mass(&self) -> f64 {
        self.body.mass - self.suspension.unsprung_mass_front - self.suspension.unsprung_mass_rear
    }

    /// Height of the sprung CoG above the roll axis `h' = h_s − h_ra`, m.
    pub fn roll_lever(&self) -> f64 {
        self.suspension.sprung_cog_height - self.suspension.roll_axis_height
    }

    /// Total roll stiffness `K_φf + K_φr`, N m/rad.
    pub fn roll_stiffness(&self) -> f64 {
        self.suspension.roll_stiffness_front + self.suspension.roll_stiffness_rear
    }

    /// Steady-state roll gradient `φ/a_y = m_s h' / (K_φ − m_s g h')`, rad per m/s², from the
    /// roll equation of [`super`] at rest (`φ̈ = φ̇ = 0`, small angles).
    pub fn roll_gradient(&self) -> f64 {
        let moment_per_acceleration = self.sprung_mass() * self.roll_lever();
        moment_per_acceleration / (self.roll_stiffness() - moment_per_acceleration * super::GRAVITY)
    }

    /// Static load of one front and one rear wheel, N.
    pub fn static_wheel_loads(&self) -> (f64, f64) {
        let weight = self.body.mass * super::GRAVITY;
        let wheelbase = self.wheelbase();
        (
            0.5 * weight * self.body.cog_to_rear_axle / wheelbase,
            0.5 * weight * self.body.cog_to_front_axle / wheelbase,
        )
    }

    /// Road-wheel angle for a steering-wheel angle, rad.
    pub fn road_wheel_angle(&self, steering_wheel_angle: f64) -> f64 {
        steering_wheel_angle / self.steering.steering_ratio
    }

    /// Checks what the model divides by or needs for a stable roll; the first violation as a
    /// message naming the parameter (so an FMU can refuse a car file instead of producing NaN).
    pub fn validate(&self) -> Result<(), String> {
        let (b, s, w) = (&self.body, &self.suspension, &self.wheels);
        let positive = [
            ("body.mass", b.mass),
            ("body.cog_to_front_axle", b.cog_to_front_axle),
            ("body.cog_to_rear_axle", b.cog_to_rear_axle),
            ("body.yaw_inertia", b.yaw_inertia),
            ("body.track_front", b.track_front),
            ("body.track_rear", b.track_rear),
            ("suspension.roll_inertia", s.roll_inertia),
            ("wheels.radius", w.radius),
            ("wheels.inertia_front", w.inertia_front),
            ("wheels.inertia_rear", w.inertia_rear),
            ("steering.steering_ratio", self.steering.steering_ratio),
            ("tyre_front.nominal_load", self.tyre_front.nominal_load),
            ("tyre_rear.nominal_load", self.tyre_rear.nominal_load),
            (
                "tyre_front.relaxation_length_longitudinal",
                self.tyre_front.relaxation_length_longitudinal,
            ),
            (
                "tyre_front.relaxation_length_lateral",
                self.tyre_front.relaxation_length_lateral,
            ),
            (
                "tyre_rear.relaxation_length_longitudinal",
                self.tyre_rear.relaxation_length_longitudinal,
            ),
            (
                "tyre_rear.relaxation_length_lateral",
                self.tyre_rear.relaxation_length_lateral,
            ),
            ("low_speed.damping_speed", self.low_speed.damping_speed),
            ("internal_step", self.internal_step),
        ];
        for (name, value) in positive {
            crate::checks::positive(name, value)?;
        }
        for (name, share) in [
            (
                "drivetrain.drive_split_front",
                self.drivetrain.drive_split_front,
            ),
            (
                "drivetrain.brake_split_front",
                self.drivetrain.brake_split_front,
            ),
        ] {
            if !(0.0..=1.0).contains(&share) {
                return Err(format!(
                    "parameter {name} = {share}; expected a share in [0, 1]"
                ));
            }
        }
        if self.sprung_mass() <= 0.0 {
            return Err("the unsprung masses are not less than body.mass".to_string());
        }
        // the roll equation's restoring moment must beat gravity's (roll_gradient's denominator)
        let gravity_moment = self.sprung_mass() * super::GRAVITY * self.roll_lever();
        if self.roll_stiffness() <= gravity_moment {
            return Err(format!(
                "roll stiffness {} N m/rad does not exceed m_s g h' = {gravity_moment} N m/rad: \
                 the body would fall over",
                self.roll_stiffness()
            ));
        }
        Ok(())
    }
}
