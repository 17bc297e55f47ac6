//! Units a log may record a signal in, and the factor to the SI unit the estimator FMU declares
//! for the variable it feeds (its modelDescription `unit` attribute: rad, rad/s, m/s, m/s2,
//! N.m). A conversion is `si = factor × sign × (logged − offset)`; the factors are exact by
//! definition (deg = π/180 rad, rpm = 2π/60 rad/s, km/h = 1/3.6 m/s, mph = 0.44704 m/s, standard
//! gravity g = 9.80665 m/s², CGPM 1901).

pub use manoeuvres::STANDARD_GRAVITY;

/// The log units accepted for a variable of SI unit `si`, each with its factor to `si`. A
/// wheel speed (rad/s) may also be logged as the wheel's circumferential speed (m/s, km/h):
/// that needs the rolling radius, so those units are in [`WHEEL_SPEED_UNITS`].
pub fn units_of(si: &str) -> &'static [(&'static str, f64)] {
    use std::f64::consts::PI;
    match si {
        "rad" => &[("rad", 1.0), ("deg", PI / 180.0)],
        "rad/s" => &[("rad/s", 1.0), ("deg/s", PI / 180.0), ("rpm", PI / 30.0)],
        "m/s" => &[("m/s", 1.0), ("km/h", 1.0 / 3.6), ("mph", 0.44704)],
        "m/s2" => &[("m/s2", 1.0), ("m/s^2", 1.0), ("g", STANDARD_GRAVITY)],
        "N.m" => &[("N.m", 1.0), ("Nm", 1.0)],
        "1" => &[("1", 1.0), ("%", 0.01)],
        _ => &[],
    }
}

/// Circumferential wheel speeds, converted to rad/s with the map's `wheel_radius`.
pub const WHEEL_SPEED_UNITS: [(&str, f64); 2] = [("m/s", 1.0), ("km/h", 1.0 / 3.6)];

/// The factor from `unit` to `si`, or the message saying which units would do. `wheel_radius`
/// (m) admits circumferential speeds for a rad/s variable.
pub fn factor(unit: &str, si: &str, wheel_radius: Option<f64>) -> Result<f64, String> {
    if let Some((_, f)) = units_of(si).iter().find(|(name, _)| *name == unit) {
        return Ok(*f);
    }
    if si == "rad/s" {
        if let (Some((_, f)), Some(r)) = (
            WHEEL_SPEED_UNITS.iter().find(|(name, _)| *name == unit),
            wheel_radius,
        ) {
            return if r > 0.0 {
                Ok(f / r)
            } else {
                Err(format!(
                    "wheel_radius = {r}: expected a positive radius in m"
                ))
            };
        }
    }
    let accepted: Vec<&str> = units_of(si).iter().map(|(name, _)| *name).collect();
    if accepted.is_empty() {
        return Err(format!(
            "the FMU variable's unit {si:?} has no conversions here"
        ));
    }
    let extra = if si == "rad/s" {
        " (a wheel speed may also be logged in m/s or km/h with wheel_radius = <m> in its entry)"
    } else {
        ""
    };
    Err(format!(
        "unit {unit:?} is not a unit of this quantity ({si}); expected one of {}{extra}",
        accepted.join(", ")
    ))
}

/// Two spellings of one unit as logging tools write them (`deg/s` and `°/s`, `m/s^2`, …).
pub fn same_unit(a: &str, b: &str) -> bool {
    let normal = |u: &str| {
        u.trim()
            .replace('°', "deg")
            .replace("m/s^2", "m/s2")
            .replace("m/s²", "m/s2")
            .replace("Nm", "N.m")
            .to_ascii_lowercase()
    };
    normal(a) == normal(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_convert_to_si() {
        assert_eq!(
            factor("deg", "rad", None).unwrap(),
            std::f64::consts::PI / 180.0
        );
        assert!(
            (factor("rpm", "rad/s", None).unwrap() * 60.0 - 2.0 * std::f64::consts::PI).abs()
                < 1e-12
        );
        assert!((factor("km/h", "m/s", None).unwrap() * 3.6 - 1.0).abs() < 1e-15);
        assert_eq!(factor("g", "m/s2", None).unwrap(), 9.80665);
        assert!((factor("km/h", "rad/s", Some(0.3)).unwrap() - 1.0 / 3.6 / 0.3).abs() < 1e-15);
        let wrong = factor("km/h", "rad", None).unwrap_err();
        assert!(wrong.contains("rad, deg"), "{wrong}");
        assert!(factor("km/h", "rad/s", None)
            .unwrap_err()
            .contains("rad/s, deg/s, rpm (a wheel speed"));
        assert!(same_unit("°/s", "deg/s") && same_unit("m/s^2", "m/s2") && !same_unit("g", "m/s2"));
    }
}
