//! The variable table generated from modelDescription.xml (see the `model-description` crate's
//! `codegen`) is made of these types.

/// Base type of a variable as seen by the C API; enumerations are `Integer`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum ValueType {
    Real,
    Integer,
    Boolean,
    String,
}

/// FMI 2.0 causality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
    Independent,
}

/// FMI 2.0 variability.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

/// One row of the generated variable table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VariableInfo {
    pub name: &'static str,
    pub value_reference: u32,
    pub value_type: ValueType,
    pub causality: Causality,
    pub variability: Variability,
    /// Lower bound (−∞ when the XML gives none); integers are widened to f64.
    pub min: f64,
    /// Upper bound (+∞ when the XML gives none).
    pub max: f64,
    /// For enumerations: the item values; empty otherwise (any value within min/max).
    pub allowed_values: &'static [i32],
}

impl VariableInfo {
    /// Finds a variable in a table sorted by (value type, value reference).
    pub fn find(
        table: &'static [VariableInfo],
        value_type: ValueType,
        value_reference: u32,
    ) -> Option<&'static VariableInfo> {
        table
            .binary_search_by(|row| {
                (row.value_type, row.value_reference).cmp(&(value_type, value_reference))
            })
            .ok()
            .map(|index| &table[index])
    }

    /// A label for messages: `variable 'vx' (valueReference 10)`.
    pub fn label(&self) -> String {
        format!(
            "variable '{}' (valueReference {})",
            self.name, self.value_reference
        )
    }
}

/// Typed storage of all variable values, generated from the model description.
/// The plumbing has already checked the value reference, the state and the range when it calls
/// a setter; a `false`/`None` answer means the table and the storage disagree (a bug).
pub trait VariableStore {
    fn real(&self, value_reference: u32) -> Option<f64>;
    fn set_real(&mut self, value_reference: u32, value: f64) -> bool;
    fn integer(&self, value_reference: u32) -> Option<i32>;
    fn set_integer(&mut self, value_reference: u32, value: i32) -> bool;
    fn boolean(&self, value_reference: u32) -> Option<bool>;
    fn set_boolean(&mut self, value_reference: u32, value: bool) -> bool;
    /// Appends every value, bit-exactly, to an FMU-state serialisation.
    fn write_state(&self, writer: &mut crate::StateWriter);
    /// Reads the values written by [`VariableStore::write_state`].
    fn read_state(&mut self, reader: &mut crate::StateReader<'_>) -> Result<(), crate::StateError>;
}
