//! A value to set on one FMU variable before initialisation, and which variable types take it.

use crate::fmu::VariableType;

#[derive(Debug, Clone, PartialEq)]
pub enum ParameterValue {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

impl ParameterValue {
    /// Whether a variable of type `var_type` takes this value: an Enumeration takes an Integer,
    /// its item's number, as FMI 2.0 sets it through fmi2SetInteger.
    pub fn fits(&self, var_type: VariableType) -> bool {
        use VariableType as T;
        matches!(
            (self, var_type),
            (ParameterValue::Real(_), T::Real)
                | (ParameterValue::Integer(_), T::Integer | T::Enumeration)
                | (ParameterValue::Boolean(_), T::Boolean)
                | (ParameterValue::String(_), T::String)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_enumeration_takes_an_integer_and_nothing_else_crosses_types() {
        assert!(ParameterValue::Integer(2).fits(VariableType::Enumeration));
        assert!(ParameterValue::Integer(2).fits(VariableType::Integer));
        assert!(ParameterValue::Real(0.5).fits(VariableType::Real));
        assert!(!ParameterValue::Integer(2).fits(VariableType::Real));
        assert!(!ParameterValue::Real(1.0).fits(VariableType::Integer));
        assert!(!ParameterValue::Boolean(true).fits(VariableType::Integer));
        assert!(!ParameterValue::String("ekf".into()).fits(VariableType::Enumeration));
    }
}
