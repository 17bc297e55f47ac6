//! The car's parameters as both FMUs declare them: the VehicleStateEstimator and the
//! ReferenceVehicle name the vehicle and HSRI tyre parameters alike in their modelDescriptions
//! (`mass`, `cog_to_front_axle`, …, `tyre_f00`, …), so the mapping from those names to the
//! models' parameter structs is written once, here: the car ([`Chassis`], embedded in both
//! models' parameters) and the HSRI tyre. An FMU passes a lookup of its Real
//! variables by name (the generated `Variables::real_by_name`).

use crate::single_track::Chassis;
use crate::tyre::HsriParams;

/// `value` if it is a positive finite number, else the message naming the parameter.
pub fn positive(name: &str, value: f64) -> Result<f64, String> {
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(format!(
            "parameter {name} = {value}; expected a positive number"
        ))
    }
}

/// Reads the FMU's Real parameters by name.
pub struct ParameterSource<F: Fn(&str) -> Option<f64>> {
    lookup: F,
}

impl<F: Fn(&str) -> Option<f64>> ParameterSource<F> {
    /// Over a lookup of Real variables by name.
    pub fn new(lookup: F) -> Self {
        Self { lookup }
    }

    /// The parameter's value; an error if the FMU does not declare it.
    pub fn value(&self, name: &str) -> Result<f64, String> {
        (self.lookup)(name).ok_or_else(|| format!("the FMU declares no parameter {name}"))
    }

    /// The parameter's value, which must be positive.
    pub fn positive(&self, name: &str) -> Result<f64, String> {
        positive(name, self.value(name)?)
    }

    /// The car: the FMU's vehicle parameters, the steering ratio the seed car's.
    pub fn chassis(&self) -> Result<Chassis, String> {
        Ok(Chassis {
            mass: self.positive("mass")?,
            cog_to_front_axle: self.positive("cog_to_front_axle")?,
            cog_to_rear_axle: self.positive("cog_to_rear_axle")?,
            yaw_inertia: self.positive("yaw_inertia")?,
            front_wheel_inertia: self.positive("wheel_inertia_front")?,
            rear_wheel_inertia: self.positive("wheel_inertia_rear")?,
            brake_split_front: self.value("brake_distribution_front")?,
            wheel_radius: self.positive("wheel_radius")?,
            front_wheel_load: self.positive("wheel_load_front")?,
            rear_wheel_load: self.positive("wheel_load_rear")?,
            ..Chassis::default()
        })
    }

    /// The HSRI tyre parameters (model A's tyre; model B's Magic Formula tyre is matched to
    /// them, `MagicFormulaParams::matching_hsri`).
    pub fn hsri(&self) -> Result<HsriParams, String> {
        Ok(HsriParams {
            reference_load: self.positive("tyre_reference_load")?,
            friction_base: self.value("tyre_f00")?,
            friction_load: self.value("tyre_f01")?,
            friction_decay_base: self.value("tyre_kr0")?,
            friction_decay_load: self.value("tyre_kr1")?,
            cornering_base: self.value("tyre_ca1")?,
            cornering_load: self.value("tyre_ca2")?,
            longitudinal_base: self.value("tyre_cs1")?,
            longitudinal_load: self.value("tyre_cs2")?,
            reference_sliding_speed: self.positive("tyre_v_mu")?,
            ..HsriParams::default()
        })
    }
}
