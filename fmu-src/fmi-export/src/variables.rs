//! The variable table generated from modelDescription.xml (see the `model-description` crate's
//! `codegen`) is made of these types.

/// Base type of a variable as seen by the C API; enumerations are `Integer`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ValueType {
    Real,
    Integer,
    Boolean,
    String,
}

/// Defines an FMI attribute's enum with its XML spellings (`xml_name`, `from_xml_name`, `ALL`),
/// so that the parser, the code generator and packaging share one definition.
macro_rules! xml_enum {
    ($(#[$meta:meta])* $name:ident { $($variant:ident = $xml:literal,)+ }) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum $name {
            $($variant,)+
        }

        impl $name {
            /// Every value, in the order of the FMI 2.0 standard's attribute description.
            pub const ALL: &'static [Self] = &[$(Self::$variant),+];

            /// The attribute value in modelDescription.xml.
            pub const fn xml_name(self) -> &'static str {
                match self {
                    $(Self::$variant => $xml,)+
                }
            }

            /// The value with this XML spelling.
            pub fn from_xml_name(name: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|value| value.xml_name() == name)
            }
        }
    };
}

xml_enum! {
    /// FMI 2.0 causality (FMI 2.0, section 2.2.7).
    Causality {
        Parameter = "parameter",
        CalculatedParameter = "calculatedParameter",
        Input = "input",
        Output = "output",
        Local = "local",
        Independent = "independent",
    }
}

xml_enum! {
    /// FMI 2.0 variability (FMI 2.0, section 2.2.7).
    Variability {
        Constant = "constant",
        Fixed = "fixed",
        Tunable = "tunable",
        Discrete = "discrete",
        Continuous = "continuous",
    }
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

/// Marks a value reference that has no variable in a dense row table (see [`dense_row`]).
pub const NO_ROW: u16 = u16::MAX;

/// The row for `value_reference` in a dense table generated as `table[vr] = row` ([`NO_ROW`]
/// where no variable of that type has the reference): one bounds-checked index, no search.
#[inline]
pub fn dense_row(table: &[u16], value_reference: u32) -> Option<usize> {
    match table.get(usize::try_from(value_reference).ok()?) {
        Some(&row) if row != NO_ROW => Some(usize::from(row)),
        _ => None,
    }
}

/// Typed storage of all variable values, generated from the model description.
/// The plumbing has already checked the value reference, the state and the range when it calls
/// a setter; a `false` answer means the table and the storage disagree (a bug). The getters
/// answer exactly the value references of their type (`None` for any other), so fmi2Get*
/// reads through them without a look-up and consults the table only to explain a `None`.
pub trait VariableStore {
    /// The row of the generated variable table (`VARIABLES`, sorted by (value type, value
    /// reference)) that describes `(value_type, value_reference)`, `None` when there is none.
    /// Generated as a direct index ([`dense_row`]) or, for sparse value references, a `match`,
    /// so that fmi2Get/fmi2Set do not search the table once per value. The plumbing confirms the
    /// row it gets and falls back to [`VariableInfo::find`] if it does not match.
    fn variable_row(value_type: ValueType, value_reference: u32) -> Option<usize>
    where
        Self: Sized;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_row_answers_only_the_filled_cells() {
        let table = [NO_ROW, 0, NO_ROW, 7];
        assert_eq!(dense_row(&table, 1), Some(0));
        assert_eq!(dense_row(&table, 3), Some(7));
        assert_eq!(dense_row(&table, 0), None);
        assert_eq!(dense_row(&table, 2), None);
        // Past the end, including the largest value reference FMI allows.
        assert_eq!(dense_row(&table, 4), None);
        assert_eq!(dense_row(&table, u32::MAX), None);
        assert_eq!(dense_row(&[], 0), None);
    }
}
