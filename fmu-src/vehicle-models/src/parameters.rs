//! The car's parameters as both FMUs declare them: the VehicleStateEstimator and the
//! ReferenceVehicle name the vehicle and HSRI tyre parameters alike in their modelDescriptions
//! (`mass`, `cog_to_front_axle`, …, `tyre_f00`, …), so the mapping from those names to the
//! models' parameter structs is written once, here: the car ([`Chassis`], embedded in both
//! models' parameters) and the HSRI tyre. An FMU passes a lookup of its Real
//! variables by name (the generated `Variables::real_by_name`).

use crate::full_vehicle::{CarData, FullVehicleParams};
use crate::single_track::Chassis;
use crate::two_track::TwoTrackParams;
use crate::two_track_lateral::TwoTrackLateralModel;
use crate::tyre::{HsriParams, MagicFormulaParams, MagicFormulaTyre};

pub use crate::checks::positive;

/// The FMU parameter of the front rolling radius (see [`ParameterSource::wheel_radii`]).
pub const WHEEL_RADIUS_FRONT: &str = "wheel_radius_front";
/// The FMU parameter of the rear rolling radius.
pub const WHEEL_RADIUS_REAR: &str = "wheel_radius_rear";

/// The per-axle tyre parameters, `(front, rear)` FMU names: factors on the
/// shared tyre law (`tyre_*`) of each axle, Pacejka's user scaling factors (`λμy`, `λFz0`;
/// [`crate::tyre::AxleTyreScaling`]), for both estimator models, and model B's Magic Formula
/// shape and curvature per axle. An FMU that does not declare them (the ReferenceVehicle) gets
/// the seed car's one tyre: factor 1, `MagicFormulaParams::matching_hsri`'s shape and curvature.
pub const TYRE_FRICTION_SCALE: (&str, &str) =
    ("tyre_front_friction_scale", "tyre_rear_friction_scale");
/// `λFz0` per axle (see [`TYRE_FRICTION_SCALE`]).
pub const TYRE_REFERENCE_LOAD_SCALE: (&str, &str) = (
    "tyre_front_reference_load_scale",
    "tyre_rear_reference_load_scale",
);
/// Model B's Magic Formula lateral shape factor `C_y` per axle (001: eq 3).
pub const TYRE_LATERAL_SHAPE: (&str, &str) =
    ("tyre_front_lateral_shape", "tyre_rear_lateral_shape");
/// Model B's Magic Formula lateral curvature factor `E_y` per axle (001: eq 3).
pub const TYRE_LATERAL_CURVATURE: (&str, &str) = (
    "tyre_front_lateral_curvature",
    "tyre_rear_lateral_curvature",
);

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
        let (front_wheel_radius, rear_wheel_radius) = self.wheel_radii()?;
        Ok(Chassis {
            mass: self.positive("mass")?,
            cog_to_front_axle: self.positive("cog_to_front_axle")?,
            cog_to_rear_axle: self.positive("cog_to_rear_axle")?,
            yaw_inertia: self.positive("yaw_inertia")?,
            front_wheel_inertia: self.positive("wheel_inertia_front")?,
            rear_wheel_inertia: self.positive("wheel_inertia_rear")?,
            brake_split_front: self.value("brake_distribution_front")?,
            front_wheel_radius,
            rear_wheel_radius,
            front_wheel_load: self.positive("wheel_load_front")?,
            rear_wheel_load: self.positive("wheel_load_rear")?,
            front_tyre_friction_scale: self.positive_or(TYRE_FRICTION_SCALE.0, 1.0)?,
            rear_tyre_friction_scale: self.positive_or(TYRE_FRICTION_SCALE.1, 1.0)?,
            front_tyre_reference_load_scale: self.positive_or(TYRE_REFERENCE_LOAD_SCALE.0, 1.0)?,
            rear_tyre_reference_load_scale: self.positive_or(TYRE_REFERENCE_LOAD_SCALE.1, 1.0)?,
            ..Chassis::default()
        })
    }

    /// The factors on the front and rear tyres' cornering stiffness
    /// (`cornering_stiffness_scale_front`, `_rear`; 1 = the seed's tyre), which must be positive.
    pub fn cornering_stiffness_scales(&self) -> Result<(f64, f64), String> {
        Ok((
            self.positive("cornering_stiffness_scale_front")?,
            self.positive("cornering_stiffness_scale_rear")?,
        ))
    }

    /// The parameter's value where the FMU declares it (it must be positive), else `default`.
    fn positive_or(&self, name: &str, default: f64) -> Result<f64, String> {
        match (self.lookup)(name) {
            Some(value) => positive(name, value),
            None => Ok(default),
        }
    }

    /// Model B's Magic Formula tyres of the front and rear axle: matched to the HSRI tyre
    /// ([`MagicFormulaParams::matching_hsri`]: peak friction and stiffnesses from `tyre_*`; the
    /// axles' factors on them come with the [`Chassis`] and the cornering-stiffness scales),
    /// with each axle's lateral shape `C_y` and curvature `E_y` where the FMU declares them
    /// ([`TYRE_LATERAL_SHAPE`], [`TYRE_LATERAL_CURVATURE`]; their defaults are
    /// `matching_hsri`'s, so the seed car's tyre is reproduced to the bit). `C_y` must be
    /// positive and `E_y` at most 1 (001: eq 3 is monotonic up to its peak only for `E ≤ 1`).
    pub fn magic_formula_axles(&self) -> Result<(MagicFormulaParams, MagicFormulaParams), String> {
        let matched = MagicFormulaParams::matching_hsri(&self.hsri()?);
        let axle = |shape: &str, curvature: &str| -> Result<MagicFormulaParams, String> {
            let lateral_shape = self.positive_or(shape, matched.lateral_shape)?;
            let lateral_curvature = (self.lookup)(curvature).unwrap_or(matched.lateral_curvature);
            if lateral_curvature.is_finite() && lateral_curvature <= 1.0 {
                Ok(MagicFormulaParams {
                    lateral_shape,
                    lateral_curvature,
                    ..matched.clone()
                })
            } else {
                Err(format!(
                    "parameter {curvature} = {lateral_curvature}; expected a number at most 1"
                ))
            }
        };
        Ok((
            axle(TYRE_LATERAL_SHAPE.0, TYRE_LATERAL_CURVATURE.0)?,
            axle(TYRE_LATERAL_SHAPE.1, TYRE_LATERAL_CURVATURE.1)?,
        ))
    }

    /// Model B's 3-state car as the VehicleStateEstimator builds it: the [`Chassis`], the
    /// cornering-stiffness scales, model B's geometry (`track_width`, `cog_height`,
    /// `roll_moment_distribution_front`) and each axle's Magic Formula tyre
    /// ([`Self::magic_formula_axles`]).
    pub fn two_track_lateral(&self) -> Result<TwoTrackLateralModel<MagicFormulaTyre>, String> {
        let (cornering_front, cornering_rear) = self.cornering_stiffness_scales()?;
        let vehicle = TwoTrackParams {
            chassis: self.chassis()?,
            track_width: self.positive("track_width")?,
            cog_height: self.value("cog_height")?,
            front_roll_moment_share: self.value("roll_moment_distribution_front")?,
            cornering_stiffness_scale_front: cornering_front,
            cornering_stiffness_scale_rear: cornering_rear,
            ..TwoTrackParams::default()
        };
        let (front_tyre, rear_tyre) = self.magic_formula_axles()?;
        Ok(TwoTrackLateralModel::with_axle_tyres(
            vehicle,
            MagicFormulaTyre::new(front_tyre),
            MagicFormulaTyre::new(rear_tyre),
        ))
    }

    /// The front and rear rolling radii: `wheel_radius_front` and `wheel_radius_rear` where the
    /// FMU declares them (the estimator: a car may carry other tyres on each axle), else the one
    /// `wheel_radius` of all wheels (the ReferenceVehicle, whose full vehicle has one radius).
    pub fn wheel_radii(&self) -> Result<(f64, f64), String> {
        match (self.lookup)(WHEEL_RADIUS_FRONT) {
            Some(front) => Ok((
                positive(WHEEL_RADIUS_FRONT, front)?,
                self.positive(WHEEL_RADIUS_REAR)?,
            )),
            None => {
                let radius = self.positive("wheel_radius")?;
                Ok((radius, radius))
            }
        }
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

/// Visits every Real parameter of the full vehicle (`model = 3` of the
/// ReferenceVehicle) with its FMU name, the factor from the model's field to the FMU's value,
/// and the field. The names shared with models A and B mean the same there (`mass`, …,
/// `wheel_inertia_*`, which the seed declares for both wheels of an axle, hence the factor 2);
/// the car files' other fields get their own names. The table is written once, here: the FMU
/// reads through it ([`ParameterSource::full_vehicle`]) and the car files' parameter-value
/// files are written through it ([`full_vehicle_parameter_values`]). Not visited: `internal_step`
/// (the FMU's `integration_step`) and `drivetrain.abs.enabled` (a Boolean,
/// [`ABS_ENABLED_PARAMETER`]).
pub fn visit_full_vehicle_parameters(
    params: &mut FullVehicleParams,
    mut visit: impl FnMut(&'static str, f64, &mut f64),
) {
    macro_rules! fields {
        ($($name:literal, $factor:literal => $($field:ident).+;)*) => {
            $(visit($name, $factor, &mut params.$($field).+);)*
        };
    }
    macro_rules! tyre_fields {
        ($tyre:ident, $prefix:literal: $($field:ident)*) => {
            $(visit(concat!($prefix, stringify!($field)), 1.0, &mut params.$tyre.$field);)*
        };
    }
    fields! {
        "mass", 1.0 => body.mass;
        "cog_to_front_axle", 1.0 => body.cog_to_front_axle;
        "cog_to_rear_axle", 1.0 => body.cog_to_rear_axle;
        "yaw_inertia", 1.0 => body.yaw_inertia;
        "wheel_radius", 1.0 => wheels.radius;
        "wheel_inertia_front", 2.0 => wheels.inertia_front;
        "wheel_inertia_rear", 2.0 => wheels.inertia_rear;
        "brake_distribution_front", 1.0 => drivetrain.brake_split_front;
        "cog_height", 1.0 => body.cog_height;
        "track_front", 1.0 => body.track_front;
        "track_rear", 1.0 => body.track_rear;
        "unsprung_mass_front", 1.0 => suspension.unsprung_mass_front;
        "unsprung_mass_rear", 1.0 => suspension.unsprung_mass_rear;
        "sprung_cog_height", 1.0 => suspension.sprung_cog_height;
        "roll_axis_height", 1.0 => suspension.roll_axis_height;
        "roll_inertia", 1.0 => suspension.roll_inertia;
        "roll_stiffness_front", 1.0 => suspension.roll_stiffness_front;
        "roll_stiffness_rear", 1.0 => suspension.roll_stiffness_rear;
        "roll_damping_front", 1.0 => suspension.roll_damping_front;
        "roll_damping_rear", 1.0 => suspension.roll_damping_rear;
        "drive_distribution_front", 1.0 => drivetrain.drive_split_front;
        "abs_slip_threshold", 1.0 => drivetrain.abs.slip_threshold;
        "abs_min_speed", 1.0 => drivetrain.abs.min_speed;
        "steering_ratio", 1.0 => steering.steering_ratio;
        "steering_lag_time_constant", 1.0 => steering.lag_time_constant;
        "steering_compliance", 1.0 => steering.compliance;
        "low_speed_damping_speed", 1.0 => low_speed.damping_speed;
        "low_speed_longitudinal_damping", 1.0 => low_speed.longitudinal_damping;
        "low_speed_lateral_damping", 1.0 => low_speed.lateral_damping;
        "low_speed_slip_limit", 1.0 => low_speed.slip_limit;
        "low_speed_tan_slip_angle_limit", 1.0 => low_speed.tan_slip_angle_limit;
    }
    tyre_fields!(tyre_front, "tyre_front_": nominal_load p_cx1 p_dx1 p_dx2 p_ex1 p_ex2 p_kx1
        p_kx2 p_kx3 p_cy1 p_dy1 p_dy2 p_ey1 p_ey2 p_ky1 p_ky2 r_bx1 r_bx2 r_cx1 r_ex1 r_by1 r_by2
        r_cy1 r_ey1 relaxation_length_longitudinal relaxation_length_lateral);
    tyre_fields!(tyre_rear, "tyre_rear_": nominal_load p_cx1 p_dx1 p_dx2 p_ex1 p_ex2 p_kx1
        p_kx2 p_kx3 p_cy1 p_dy1 p_dy2 p_ey1 p_ey2 p_ky1 p_ky2 r_bx1 r_bx2 r_cx1 r_ex1 r_by1 r_by2
        r_cy1 r_ey1 relaxation_length_longitudinal relaxation_length_lateral);
}

/// The FMU's Boolean parameter that switches the full vehicle's ABS on.
pub const ABS_ENABLED_PARAMETER: &str = "abs_enabled";

/// The full vehicle's Real parameters as the FMU declares them: `(name, value)` in the order of
/// [`visit_full_vehicle_parameters`].
pub fn full_vehicle_parameter_values(params: &FullVehicleParams) -> Vec<(&'static str, f64)> {
    let mut values = Vec::new();
    visit_full_vehicle_parameters(&mut params.clone(), |name, factor, field| {
        values.push((name, *field * factor))
    });
    values
}

impl<F: Fn(&str) -> Option<f64>> ParameterSource<F> {
    /// The full vehicle from the FMU's parameters (the Boolean ABS switch and the internal step
    /// come from the caller), validated.
    pub fn full_vehicle(
        &self,
        abs_enabled: bool,
        internal_step: f64,
    ) -> Result<FullVehicleParams, String> {
        let mut params = FullVehicleParams::default();
        let mut missing = None;
        visit_full_vehicle_parameters(&mut params, |name, factor, field| {
            match (self.lookup)(name) {
                Some(value) => *field = value / factor,
                None => missing = missing.take().or(Some(name)),
            }
        });
        if let Some(name) = missing {
            return Err(format!("the FMU declares no parameter {name}"));
        }
        params.drivetrain.abs.enabled = abs_enabled;
        params.internal_step = internal_step;
        params.validate()?;
        Ok(params)
    }
}

/// The item of the ReferenceVehicle's `model` enumeration that runs the full vehicle.
pub const FULL_VEHICLE_MODEL_ITEM: &str = "full_vehicle";

/// The ReferenceVehicle's parameters of the static load of one front and one rear wheel, which
/// its models 1 and 2 take as given (the full vehicle computes its own).
pub const STATIC_WHEEL_LOAD_PARAMETERS: [&str; 2] = ["wheel_load_front", "wheel_load_rear"];

/// A car file as an SSP 1.0 parameter-value file (`.ssv`, SSP 1.0 Sect. 6, namespace
/// `ssv`): `model = full_vehicle`, `abs_enabled`, every Real parameter of
/// [`visit_full_vehicle_parameters`] under the ReferenceVehicle's names and the car's static wheel
/// loads ([`STATIC_WHEEL_LOAD_PARAMETERS`], [`FullVehicleParams::static_wheel_loads`]), so a
/// master or an SSP applies a car to the FMU as it is, on any of its models (a master that sets
/// `model` to 1 or 2 keeps the car's loads, not the seed car's). Numbers are written in Rust's
/// shortest round-trip form.
pub fn parameter_value_file(car: &CarData) -> String {
    let escape = |text: &str| {
        text.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('"', "&quot;")
    };
    let mut parameters = format!(
        "    <ssv:Parameter name=\"model\"><ssv:Enumeration value=\"{FULL_VEHICLE_MODEL_ITEM}\"/></ssv:Parameter>\n    \
         <ssv:Parameter name=\"{ABS_ENABLED_PARAMETER}\"><ssv:Boolean value=\"{}\"/></ssv:Parameter>\n",
        car.vehicle.drivetrain.abs.enabled
    );
    let (front_load, rear_load) = car.vehicle.static_wheel_loads();
    let static_loads = [
        (STATIC_WHEEL_LOAD_PARAMETERS[0], front_load),
        (STATIC_WHEEL_LOAD_PARAMETERS[1], rear_load),
    ];
    for (name, value) in full_vehicle_parameter_values(&car.vehicle)
        .into_iter()
        .chain(static_loads)
    {
        parameters.push_str(&format!(
            "    <ssv:Parameter name=\"{name}\"><ssv:Real value=\"{value:?}\"/></ssv:Parameter>\n"
        ));
    }
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
         <ssv:ParameterSet xmlns:ssc=\"http://ssp-standard.org/SSP1/SystemStructureCommon\" \
         xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\" version=\"1.0\" \
         name=\"{}\" description=\"{}\" generationTool=\"vehicle_models::parameters::parameter_value_file\">\n  \
         <ssv:Parameters>\n{parameters}  </ssv:Parameters>\n</ssv:ParameterSet>\n",
        escape(&car.name),
        escape(&format!(
            "ReferenceVehicle parameters: model 3 (full_vehicle) and the static wheel loads models 1 and 2 take; source: {}",
            car.source
        )),
    )
}
