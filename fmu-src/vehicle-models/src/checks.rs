//! Checks of parameter values shared by the parameter mapping of the FMUs
//! ([`crate::parameters`]) and the models' own validation ([`crate::full_vehicle`]).

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
