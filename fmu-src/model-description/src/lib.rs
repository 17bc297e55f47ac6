//! Reads and checks an FMI 2.0 Co-Simulation `modelDescription.xml`, and generates the Rust
//! value-reference tables of the FMU crates from it at build time, so that code and XML cannot drift.
//!
//! # Reading and checking (packaging, tests)
//!
//! ```no_run
//! let description = model_description::parse_file("modelDescription/ReferenceVehicle.xml")?;
//! println!("{} has {} variables", description.model_name, description.variables.len());
//! # Ok::<(), model_description::Error>(())
//! ```
//!
//! [`parse_file`] (and [`parse_str`]) parse *and* validate: the result is a description that
//! satisfies every rule in [`validate`]: the FMI 2.0 rules on causality, variability, initial and
//! start values, units, enumerations and the model structure, plus the project's own rules (every
//! variable has a description, every Real a declared unit, nothing the `fmi` crate's parser
//! rejects). An [`Error`] names the file, the line, the element or variable and what was expected.
//!
//! # Code generation (build.rs of an FMU crate)
//!
//! ```no_run
//! // In build.rs, inside `fn main()`:
//! model_description::generate_for_build("../../modelDescription/ReferenceVehicle.xml");
//! // In lib.rs: include!(concat!(env!("OUT_DIR"), "/model_description.rs"));
//! ```
//!
//! See [`codegen`] for what the generated file contains.

pub mod codegen;
pub mod docs;
mod error;
pub mod fmi3;
mod parse;
pub mod validate;
mod xml;

use std::path::Path;

pub use codegen::{generate_for_build, generate_rust};
pub use error::Error;

/// Reads, parses and validates a modelDescription.xml file.
pub fn parse_file(path: impl AsRef<Path>) -> Result<ModelDescription, Error> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|error| Error {
        file: path.display().to_string(),
        line: None,
        context: String::from("reading the file"),
        message: error.to_string(),
    })?;
    parse_str(&text, &path.display().to_string())
}

/// Parses and validates the text of a modelDescription.xml; `file_name` only labels error messages.
pub fn parse_str(text: &str, file_name: &str) -> Result<ModelDescription, Error> {
    let description = parse::parse(text, file_name)?;
    validate::validate(&description, file_name)?;
    Ok(description)
}

/// An FMI 2.0 Co-Simulation model description, as far as this project uses it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: Option<String>,
    pub version: Option<String>,
    pub author: Option<String>,
    pub copyright: Option<String>,
    pub license: Option<String>,
    pub generation_tool: Option<String>,
    pub variable_naming_convention: Option<String>,
    pub co_simulation: CoSimulation,
    pub unit_definitions: Vec<Unit>,
    pub type_definitions: Vec<SimpleType>,
    pub log_categories: Vec<LogCategory>,
    pub default_experiment: Option<DefaultExperiment>,
    /// In document order; the `index` of the model structure is the position in this list plus one.
    pub variables: Vec<ScalarVariable>,
    pub model_structure: ModelStructure,
}

impl ModelDescription {
    /// The variable with this name.
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.variables.iter().find(|variable| variable.name == name)
    }

    /// The simple type (TypeDefinitions) with this name.
    pub fn simple_type(&self, name: &str) -> Option<&SimpleType> {
        self.type_definitions
            .iter()
            .find(|simple| simple.name == name)
    }

    /// The unit (UnitDefinitions) with this name.
    pub fn unit(&self, name: &str) -> Option<&Unit> {
        self.unit_definitions.iter().find(|unit| unit.name == name)
    }

    /// Names of the Real and Integer parameters that lack `min` or `max` (a
    /// master can only check a value against bounds that are declared).
    pub fn unbounded_parameters(&self) -> Vec<&str> {
        self.variables
            .iter()
            .filter(|v| v.causality == Causality::Parameter)
            .filter(|v| match &v.value {
                VariableValue::Real { min, max, .. } => min.is_none() || max.is_none(),
                VariableValue::Integer { min, max, .. } => min.is_none() || max.is_none(),
                _ => false,
            })
            .map(|v| v.name.as_str())
            .collect()
    }
}

/// The `<CoSimulation>` element: capability flags.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CoSimulation {
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_run_asynchronuously: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_not_use_memory_management_functions: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
}

/// A `<Unit>` of the UnitDefinitions.
#[derive(Debug, Clone, PartialEq)]
pub struct Unit {
    pub name: String,
    pub base_unit: Option<BaseUnit>,
    pub display_units: Vec<DisplayUnit>,
}

/// SI base-unit exponents: `value_in_base = factor * value + offset`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BaseUnit {
    pub kg: i32,
    pub m: i32,
    pub s: i32,
    pub a: i32,
    pub k: i32,
    pub mol: i32,
    pub cd: i32,
    pub rad: i32,
    pub factor: f64,
    pub offset: f64,
}

/// A display unit: `value_display = factor * value_unit + offset`.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayUnit {
    pub name: String,
    pub factor: f64,
    pub offset: f64,
}

/// A `<SimpleType>` of the TypeDefinitions.
#[derive(Debug, Clone, PartialEq)]
pub struct SimpleType {
    pub name: String,
    pub description: Option<String>,
    pub kind: SimpleTypeKind,
}

/// What a simple type declares.
#[derive(Debug, Clone, PartialEq)]
pub enum SimpleTypeKind {
    Real {
        unit: Option<String>,
        display_unit: Option<String>,
        min: Option<f64>,
        max: Option<f64>,
    },
    Integer {
        min: Option<i32>,
        max: Option<i32>,
    },
    Boolean,
    String,
    Enumeration {
        items: Vec<EnumerationItem>,
    },
}

/// One `<Item>` of an enumeration type.
#[derive(Debug, Clone, PartialEq)]
pub struct EnumerationItem {
    pub name: String,
    pub value: i32,
    pub description: Option<String>,
}

/// A `<Category>` of the LogCategories.
#[derive(Debug, Clone, PartialEq)]
pub struct LogCategory {
    pub name: String,
    pub description: Option<String>,
}

/// The `<DefaultExperiment>`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// FMI 2.0 causality and variability, defined once in fmi-export (with their XML spellings)
/// and shared by the parser, the generated variable tables and packaging.
pub use fmi_export::{Causality, Variability};

/// FMI 2.0 `initial` attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

/// One `<ScalarVariable>`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: Option<String>,
    pub causality: Causality,
    pub variability: Variability,
    /// As written in the XML (`None` = attribute absent); see [`ScalarVariable::effective_initial`].
    pub initial: Option<Initial>,
    pub value: VariableValue,
    /// Line of the `<ScalarVariable>` start tag in the file (1-based).
    pub line: usize,
}

impl ScalarVariable {
    /// The `initial` that applies: the attribute, or the FMI 2.0 default for the causality and
    /// variability (FMI 2.0 section 2.2.7, table of defaults); `None` for inputs and the
    /// independent variable, which have no `initial`.
    pub fn effective_initial(&self) -> Option<Initial> {
        if self.initial.is_some() {
            return self.initial;
        }
        use Causality as C;
        use Variability as V;
        match (self.causality, self.variability) {
            (C::Input | C::Independent, _) => None,
            (_, V::Constant) => Some(Initial::Exact),
            (C::Parameter, _) => Some(Initial::Exact),
            _ => Some(Initial::Calculated),
        }
    }

    /// The base type seen by the C API (enumerations are accessed as Integer).
    pub fn base_type(&self) -> BaseType {
        match self.value {
            VariableValue::Real { .. } => BaseType::Real,
            VariableValue::Integer { .. } | VariableValue::Enumeration { .. } => BaseType::Integer,
            VariableValue::Boolean { .. } => BaseType::Boolean,
            VariableValue::String { .. } => BaseType::String,
        }
    }

    /// A label for messages: `variable 'vx' (valueReference 10)`.
    pub fn label(&self) -> String {
        format!(
            "variable '{}' (valueReference {})",
            self.name, self.value_reference
        )
    }
}

/// The four base types of the FMI 2.0 C API (enumerations are accessed as Integer): fmi-export's
/// `ValueType`, defined once.
pub use fmi_export::ValueType as BaseType;

/// The type element of a variable with its attributes.
#[derive(Debug, Clone, PartialEq)]
pub enum VariableValue {
    Real {
        declared_type: Option<String>,
        unit: Option<String>,
        display_unit: Option<String>,
        min: Option<f64>,
        max: Option<f64>,
        nominal: Option<f64>,
        start: Option<f64>,
    },
    Integer {
        declared_type: Option<String>,
        min: Option<i32>,
        max: Option<i32>,
        start: Option<i32>,
    },
    Boolean {
        declared_type: Option<String>,
        start: Option<bool>,
    },
    String {
        declared_type: Option<String>,
        start: Option<String>,
    },
    Enumeration {
        declared_type: String,
        min: Option<i32>,
        max: Option<i32>,
        start: Option<i32>,
    },
}

impl VariableValue {
    /// Whether the type element carries a `start` attribute.
    pub fn has_start(&self) -> bool {
        match self {
            VariableValue::Real { start, .. } => start.is_some(),
            VariableValue::Integer { start, .. } | VariableValue::Enumeration { start, .. } => {
                start.is_some()
            }
            VariableValue::Boolean { start, .. } => start.is_some(),
            VariableValue::String { start, .. } => start.is_some(),
        }
    }
}

/// `<ModelStructure>`: variable indices are 1-based positions in [`ModelDescription::variables`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelStructure {
    pub outputs: Vec<Unknown>,
    pub derivatives: Vec<Unknown>,
    pub initial_unknowns: Vec<Unknown>,
}

/// One `<Unknown>`; `dependencies: None` means "depends on all knowns".
#[derive(Debug, Clone, PartialEq)]
pub struct Unknown {
    pub index: usize,
    pub dependencies: Option<Vec<usize>>,
    pub line: usize,
}
