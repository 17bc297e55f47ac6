//! The vehicle behind the FMU: models 1 and 2 (`vehicle_models::ReferenceVehicle`, unchanged
//! from the seeds) or model 3, the full vehicle (`vehicle_models::full_vehicle`),
//! with what the FMU reports of each beyond the common [`VehicleTruth`].

use fmi_export::{StateError, StateReader, StateWriter};
use vehicle_models::full_vehicle::{
    FullVehicle, FullVehicleInput, FullVehicleParams, SAVED_VALUES, WHEELS,
};
use vehicle_models::parameters::{positive, ParameterSource};
use vehicle_models::tyre::MagicFormulaParams;
use vehicle_models::{
    DriverInputVector, Integrator, ReferenceModelKind, ReferenceVehicle as PlanarVehicle,
    ReferenceVehicleParams, SingleTrackParams, TwoTrackParams, VehicleTruth,
};

use crate::model_description::{
    Integrator as IntegratorItem, Variables, VehicleModel as VehicleModelItem,
};

/// What the full vehicle adds to the common truth: roll and the four wheels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct WheelTruth {
    pub roll_angle: f64,
    /// `[FL, FR, RL, RR]`, rad/s.
    pub wheel_speed: [f64; WHEELS],
    /// `[FL, FR, RL, RR]`, N.
    pub wheel_load: [f64; WHEELS],
}

/// Model 1 or 2 (the seeds' models), or model 3 (the full vehicle).
// One vehicle per FMU instance, built once: the variants' sizes do not matter, an indirection on
// every step would.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub(crate) enum Vehicle {
    Planar {
        model: PlanarVehicle,
        /// Static loads of one front and one rear wheel (parameters `wheel_load_*`).
        static_loads: (f64, f64),
    },
    Full(FullVehicle),
}

impl Vehicle {
    /// The vehicle the parameters choose, driving straight at `vx0` with freely rolling wheels.
    pub fn build(v: &Variables) -> Result<Self, String> {
        let source = ParameterSource::new(|name| v.real_by_name(name));
        let kind = match VehicleModelItem::from_parameter("model", v.model)? {
            VehicleModelItem::SingleTrackHsri => ReferenceModelKind::SingleTrack,
            VehicleModelItem::TwoTrackMagicFormula => ReferenceModelKind::TwoTrack,
            VehicleModelItem::FullVehicle => {
                let step = positive("integration_step", v.integration_step)?;
                let params: FullVehicleParams = source
                    .full_vehicle(v.abs_enabled, step)
                    .map_err(|error| format!("model = 3: {error}"))?;
                return Ok(Self::Full(FullVehicle::rolling(params, v.vx0)));
            }
        };
        // The vehicle and tyre parameters, named alike in both FMUs, are read once in
        // vehicle-models; model B is the same car (track width, CoG height and roll-moment
        // split keep the vehicle-models defaults, SPEC §4).
        let chassis = source.chassis()?;
        let static_loads = (chassis.front_wheel_load, chassis.rear_wheel_load);
        let single_track = SingleTrackParams {
            chassis: chassis.clone(),
            ..SingleTrackParams::default()
        };
        let two_track = TwoTrackParams {
            chassis,
            ..TwoTrackParams::default()
        };
        let hsri = source.hsri()?;
        // Seed 001 gives no Magic Formula numbers: the tyre is matched to the HSRI tyre
        // (same stiffnesses and peak friction), as in the vehicle-models crate.
        let magic_formula = MagicFormulaParams::matching_hsri(&hsri);
        let integrator = match IntegratorItem::from_parameter("integrator", v.integrator)? {
            IntegratorItem::SemiImplicitEuler => Integrator::SemiImplicitEuler,
            IntegratorItem::RungeKutta4 => Integrator::RungeKutta4,
        };
        let model = PlanarVehicle::new(
            &ReferenceVehicleParams {
                model: kind,
                integrator,
                single_track,
                hsri,
                two_track,
                magic_formula,
            },
            v.vx0,
        );
        Ok(Self::Planar {
            model,
            static_loads,
        })
    }

    /// The seeds' model, to which process noise applies (model 3 is the detailed truth and has
    /// none).
    pub fn planar_mut(&mut self) -> Option<&mut PlanarVehicle> {
        match self {
            Self::Planar { model, .. } => Some(model),
            Self::Full(_) => None,
        }
    }

    /// One step of `dt` with the input held; on error (a non-finite state) the message.
    /// `road` is `[road_friction, road_bank_angle, road_grade_angle]` (model 3 only).
    pub fn step(
        &mut self,
        input: &DriverInputVector,
        road: &[f64; 3],
        dt: f64,
    ) -> Result<(), String> {
        match self {
            Self::Planar { model, .. } => {
                return model.step(input, dt).map_err(|error| error.to_string())
            }
            Self::Full(vehicle) => vehicle.step(
                &FullVehicleInput {
                    steering_angle: input[0],
                    drive_torque: input[1],
                    brake_torque: input[2],
                    road_friction: road[0],
                    road_bank_angle: road[1],
                    road_grade_angle: road[2],
                },
                dt,
            ),
        }
        // The full vehicle does not check itself; its message names the state as
        // `non_finite_state` does.
        match self.non_finite_state() {
            Some(state) => Err(format!("{state} became non-finite")),
            None => Ok(()),
        }
    }

    /// The name of the first non-finite state, if any.
    pub fn non_finite_state(&self) -> Option<String> {
        match self {
            Self::Planar { model, .. } => model
                .state()
                .iter()
                .position(|value| !value.is_finite())
                .map(|index| model.state_names()[index].to_string()),
            Self::Full(vehicle) => vehicle
                .state()
                .iter()
                .position(|value| !value.is_finite())
                .map(|index| format!("full-vehicle state {index}")),
        }
    }

    /// The truth at the current state and input.
    pub fn truth(&self, input: &DriverInputVector) -> (VehicleTruth, WheelTruth) {
        match self {
            Self::Planar {
                model,
                static_loads: (front, rear),
            } => {
                let truth = model.truth(input);
                let wheel_speed = match model.kind() {
                    ReferenceModelKind::SingleTrack => {
                        let (f, r) = (truth.omega_front, truth.omega_rear);
                        [f, f, r, r]
                    }
                    ReferenceModelKind::TwoTrack => {
                        std::array::from_fn(|wheel| model.state()[3 + wheel])
                    }
                };
                let wheels = WheelTruth {
                    roll_angle: 0.0,
                    wheel_speed,
                    wheel_load: [*front, *front, *rear, *rear],
                };
                (truth, wheels)
            }
            Self::Full(vehicle) => {
                let full = vehicle.truth();
                let wheels = WheelTruth {
                    roll_angle: full.roll_angle,
                    wheel_speed: full.wheel_speed,
                    wheel_load: full.wheel_load,
                };
                (full.vehicle_truth(), wheels)
            }
        }
    }

    /// The model number of the `model` parameter.
    fn model_number(&self) -> u64 {
        match self {
            Self::Planar { model, .. } => match model.kind() {
                ReferenceModelKind::SingleTrack => 1,
                ReferenceModelKind::TwoTrack => 2,
            },
            Self::Full(_) => 3,
        }
    }

    pub fn write_state(&self, writer: &mut StateWriter) {
        // The model number and state length tell the models apart: a state of another model is
        // refused on reading instead of being misread.
        writer.u64(self.model_number());
        match self {
            Self::Planar { model, .. } => {
                writer.u64(model.state_dim() as u64);
                writer.f64s(model.state());
            }
            Self::Full(vehicle) => {
                writer.u64(SAVED_VALUES as u64);
                writer.f64s(&vehicle.saved_values());
            }
        }
    }

    pub fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        let model = reader.u64("vehicle model")?;
        let dimension = reader.u64("vehicle state length")?;
        let expected = match self {
            Self::Planar { model, .. } => model.state_dim(),
            Self::Full(_) => SAVED_VALUES,
        };
        if model != self.model_number() || dimension != expected as u64 {
            return Err(StateError::new(format!(
                "the serialized vehicle is model {model} with {dimension} state entries; parameter \
                 model = {} needs {expected}",
                self.model_number()
            )));
        }
        match self {
            Self::Planar { model, .. } => reader.f64s_into(model.state_mut(), "vehicle state"),
            Self::Full(vehicle) => {
                let mut values = [0.0; SAVED_VALUES];
                reader.f64s_into(&mut values, "vehicle state")?;
                vehicle.restore_saved_values(&values);
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The XML's start values of model 3 are the seed car (`cars/seed_car.toml`, the model's
    /// default), so the FMU's defaults and the car file cannot drift apart.
    #[test]
    fn the_model_3_start_values_are_the_seed_car() {
        let v = Variables::default();
        let source = ParameterSource::new(|name| v.real_by_name(name));
        let params = source.full_vehicle(v.abs_enabled, v.integration_step);
        assert_eq!(params, Ok(FullVehicleParams::default()));
    }
}
