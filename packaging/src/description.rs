//! The view of a `modelDescription.xml` that packaging works with (identity, variables, units,
//! type definitions, model structure), as display-ready text.
//!
//! Parsing and validation are the model-description crate's: the FMU crates generate their
//! value-reference tables with the same parser, so what packaging accepts is exactly what the FMU
//! build accepts. This module converts its typed result into attribute texts for the generated
//! documentation and the SSP, and adds the one rule that only packaging knows: the file name, the
//! archive name and the shared-library name must all be the model identifier.

use std::fmt;
use std::path::{Path, PathBuf};

use model_description as md;

/// One problem found in a model description, with the file and (where known) the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    pub file: PathBuf,
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}: {}", self.file.display(), line, self.message),
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

/// All problems of one or more files; `Display` lists every one on its own line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problems(pub Vec<Problem>);

impl fmt::Display for Problems {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (index, problem) in self.0.iter().enumerate() {
            if index > 0 {
                writeln!(f)?;
            }
            write!(f, "{problem}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Problems {}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct DisplayUnit {
    pub name: String,
    pub factor: Option<String>,
    pub offset: Option<String>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct UnitDefinition {
    pub name: String,
    /// Attributes of `<BaseUnit>` in document order (kg, m, s, A, K, mol, cd, rad, factor, offset).
    pub base_unit: Vec<(String, String)>,
    pub display_units: Vec<DisplayUnit>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct EnumerationItem {
    pub name: String,
    pub value: String,
    pub description: Option<String>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct SimpleType {
    pub name: String,
    pub description: Option<String>,
    /// Real, Integer, Boolean, String or Enumeration.
    pub kind: String,
    pub unit: Option<String>,
    pub display_unit: Option<String>,
    pub items: Vec<EnumerationItem>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: Option<String>,
    /// FMI 2.0 defaults applied: "local" when absent.
    pub causality: String,
    /// FMI 2.0 defaults applied: "continuous" when absent.
    pub variability: String,
    pub initial: Option<String>,
    /// Real, Integer, Boolean, String or Enumeration.
    pub type_name: String,
    pub declared_type: Option<String>,
    pub unit: Option<String>,
    pub display_unit: Option<String>,
    pub start: Option<String>,
    pub min: Option<String>,
    pub max: Option<String>,
    /// 1-based line of the `<ScalarVariable>` element, for messages.
    pub line: usize,
}

/// What packaging reads from one `modelDescription.xml`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModelDescription {
    pub file: PathBuf,
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: Option<String>,
    pub author: Option<String>,
    pub version: Option<String>,
    pub generation_tool: Option<String>,
    /// `modelIdentifier` of `<CoSimulation>`; empty when the element is missing.
    pub model_identifier: String,
    /// All attributes of `<CoSimulation>` in document order.
    pub co_simulation: Vec<(String, String)>,
    pub unit_definitions: Vec<UnitDefinition>,
    pub type_definitions: Vec<SimpleType>,
    pub log_categories: Vec<(String, Option<String>)>,
    pub default_experiment: Vec<(String, String)>,
    pub variables: Vec<ScalarVariable>,
    /// 1-based indices from `<ModelStructure><Outputs><Unknown index=..>`.
    pub structure_outputs: Vec<usize>,
}

impl ModelDescription {
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.variables.iter().find(|variable| variable.name == name)
    }

    pub fn simple_type(&self, name: &str) -> Option<&SimpleType> {
        self.type_definitions.iter().find(|t| t.name == name)
    }

    /// The unit of a variable: its own `unit` attribute, else its declared type's.
    pub fn effective_unit(&self, variable: &ScalarVariable) -> Option<String> {
        variable.unit.clone().or_else(|| {
            variable
                .declared_type
                .as_deref()
                .and_then(|name| self.simple_type(name))
                .and_then(|t| t.unit.clone())
        })
    }

    /// The display unit of a variable: its own, else its declared type's.
    pub fn effective_display_unit(&self, variable: &ScalarVariable) -> Option<String> {
        variable.display_unit.clone().or_else(|| {
            variable
                .declared_type
                .as_deref()
                .and_then(|name| self.simple_type(name))
                .and_then(|t| t.display_unit.clone())
        })
    }

    pub fn unit_definition(&self, name: &str) -> Option<&UnitDefinition> {
        self.unit_definitions.iter().find(|unit| unit.name == name)
    }

    pub fn co_simulation_attribute(&self, name: &str) -> Option<&str> {
        self.co_simulation
            .iter()
            .find(|(key, _)| key == name)
            .map(|(_, value)| value.as_str())
    }

    pub fn variables_with_causality<'a>(
        &'a self,
        causality: &'a str,
    ) -> impl Iterator<Item = &'a ScalarVariable> + 'a {
        self.variables
            .iter()
            .filter(move |variable| variable.causality == causality)
    }
}

fn problem_from(path: &Path, error: model_description::Error) -> Problems {
    Problems(vec![Problem {
        file: path.to_path_buf(),
        line: error.line,
        message: format!("{}: {}", error.context, error.message),
    }])
}

/// Reads, parses and validates a model description from disk (model-description crate); any
/// problem is a [`Problem`] naming the file and, where known, the line.
pub fn read_file(path: &Path) -> Result<ModelDescription, Problems> {
    let text = std::fs::read_to_string(path).map_err(|error| {
        Problems(vec![Problem {
            file: path.to_path_buf(),
            line: None,
            message: format!("cannot read the model description: {error}"),
        }])
    })?;
    parse(path, &text)
}

/// Parses and validates model-description text; `file` only names the source in messages.
pub fn parse(file: &Path, text: &str) -> Result<ModelDescription, Problems> {
    let parsed = model_description::parse_str(text, &file.display().to_string())
        .map_err(|error| problem_from(file, error))?;
    Ok(convert(file, &parsed))
}

/// Shortest text that reads back as the same number ("0", "0.001", "57.29577951308232").
fn number(value: f64) -> String {
    format!("{value}")
}

fn initial_name(initial: md::Initial) -> &'static str {
    match initial {
        md::Initial::Exact => "exact",
        md::Initial::Approx => "approx",
        md::Initial::Calculated => "calculated",
    }
}

fn base_unit_attributes(base: &md::BaseUnit) -> Vec<(String, String)> {
    // FMI 2.0 attribute names and order; zero exponents and the identity factor/offset are the
    // defaults and stay implicit, as in the source files.
    let exponents = [
        ("kg", base.kg),
        ("m", base.m),
        ("s", base.s),
        ("A", base.a),
        ("K", base.k),
        ("mol", base.mol),
        ("cd", base.cd),
        ("rad", base.rad),
    ];
    let mut attributes: Vec<(String, String)> = exponents
        .iter()
        .filter(|(_, exponent)| *exponent != 0)
        .map(|(name, exponent)| (name.to_string(), exponent.to_string()))
        .collect();
    if base.factor != 1.0 {
        attributes.push(("factor".into(), number(base.factor)));
    }
    if base.offset != 0.0 {
        attributes.push(("offset".into(), number(base.offset)));
    }
    attributes
}

fn convert_variable(variable: &md::ScalarVariable) -> ScalarVariable {
    let mut converted = ScalarVariable {
        name: variable.name.clone(),
        value_reference: variable.value_reference,
        description: variable.description.clone(),
        causality: variable.causality.xml_name().into(),
        variability: variable.variability.xml_name().into(),
        initial: variable.initial.map(|i| initial_name(i).to_string()),
        line: variable.line,
        ..ScalarVariable::default()
    };
    let text = |value: Option<f64>| value.map(number);
    let integer = |value: Option<i32>| value.map(|v| v.to_string());
    match &variable.value {
        md::VariableValue::Real {
            declared_type,
            unit,
            display_unit,
            min,
            max,
            start,
            ..
        } => {
            converted.type_name = "Real".into();
            converted.declared_type = declared_type.clone();
            converted.unit = unit.clone();
            converted.display_unit = display_unit.clone();
            converted.min = text(*min);
            converted.max = text(*max);
            converted.start = text(*start);
        }
        md::VariableValue::Integer {
            declared_type,
            min,
            max,
            start,
        } => {
            converted.type_name = "Integer".into();
            converted.declared_type = declared_type.clone();
            converted.min = integer(*min);
            converted.max = integer(*max);
            converted.start = integer(*start);
        }
        md::VariableValue::Enumeration {
            declared_type,
            min,
            max,
            start,
        } => {
            converted.type_name = "Enumeration".into();
            converted.declared_type = Some(declared_type.clone());
            converted.min = integer(*min);
            converted.max = integer(*max);
            converted.start = integer(*start);
        }
        md::VariableValue::Boolean {
            declared_type,
            start,
        } => {
            converted.type_name = "Boolean".into();
            converted.declared_type = declared_type.clone();
            converted.start = start.map(|b| b.to_string());
        }
        md::VariableValue::String {
            declared_type,
            start,
        } => {
            converted.type_name = "String".into();
            converted.declared_type = declared_type.clone();
            converted.start = start.clone();
        }
    }
    converted
}

fn convert_simple_type(simple: &md::SimpleType) -> SimpleType {
    let mut converted = SimpleType {
        name: simple.name.clone(),
        description: simple.description.clone(),
        ..SimpleType::default()
    };
    match &simple.kind {
        md::SimpleTypeKind::Real {
            unit, display_unit, ..
        } => {
            converted.kind = "Real".into();
            converted.unit = unit.clone();
            converted.display_unit = display_unit.clone();
        }
        md::SimpleTypeKind::Integer { .. } => converted.kind = "Integer".into(),
        md::SimpleTypeKind::Boolean => converted.kind = "Boolean".into(),
        md::SimpleTypeKind::String => converted.kind = "String".into(),
        md::SimpleTypeKind::Enumeration { items } => {
            converted.kind = "Enumeration".into();
            converted.items = items
                .iter()
                .map(|item| EnumerationItem {
                    name: item.name.clone(),
                    value: item.value.to_string(),
                    description: item.description.clone(),
                })
                .collect();
        }
    }
    converted
}

/// The packaging view of a validated model description.
pub fn convert(file: &Path, parsed: &md::ModelDescription) -> ModelDescription {
    let co = &parsed.co_simulation;
    let flag = |value: bool| value.to_string();
    let co_simulation = vec![
        ("modelIdentifier".to_string(), co.model_identifier.clone()),
        ("needsExecutionTool".into(), flag(co.needs_execution_tool)),
        (
            "canHandleVariableCommunicationStepSize".into(),
            flag(co.can_handle_variable_communication_step_size),
        ),
        (
            "canInterpolateInputs".into(),
            flag(co.can_interpolate_inputs),
        ),
        (
            "maxOutputDerivativeOrder".into(),
            co.max_output_derivative_order.to_string(),
        ),
        (
            "canRunAsynchronuously".into(),
            flag(co.can_run_asynchronuously),
        ),
        (
            "canBeInstantiatedOnlyOncePerProcess".into(),
            flag(co.can_be_instantiated_only_once_per_process),
        ),
        (
            "canNotUseMemoryManagementFunctions".into(),
            flag(co.can_not_use_memory_management_functions),
        ),
        (
            "canGetAndSetFMUstate".into(),
            flag(co.can_get_and_set_fmu_state),
        ),
        (
            "canSerializeFMUstate".into(),
            flag(co.can_serialize_fmu_state),
        ),
        (
            "providesDirectionalDerivative".into(),
            flag(co.provides_directional_derivative),
        ),
    ];
    let mut default_experiment = Vec::new();
    if let Some(experiment) = &parsed.default_experiment {
        for (name, value) in [
            ("startTime", experiment.start_time),
            ("stopTime", experiment.stop_time),
            ("tolerance", experiment.tolerance),
            ("stepSize", experiment.step_size),
        ] {
            if let Some(value) = value {
                default_experiment.push((name.to_string(), number(value)));
            }
        }
    }
    ModelDescription {
        file: file.to_path_buf(),
        fmi_version: parsed.fmi_version.clone(),
        model_name: parsed.model_name.clone(),
        guid: parsed.guid.clone(),
        description: parsed.description.clone(),
        author: parsed.author.clone(),
        version: parsed.version.clone(),
        generation_tool: parsed.generation_tool.clone(),
        model_identifier: co.model_identifier.clone(),
        co_simulation,
        unit_definitions: parsed
            .unit_definitions
            .iter()
            .map(|unit| UnitDefinition {
                name: unit.name.clone(),
                base_unit: unit
                    .base_unit
                    .as_ref()
                    .map(base_unit_attributes)
                    .unwrap_or_default(),
                display_units: unit
                    .display_units
                    .iter()
                    .map(|display| DisplayUnit {
                        name: display.name.clone(),
                        factor: Some(number(display.factor)),
                        offset: Some(number(display.offset)),
                    })
                    .collect(),
            })
            .collect(),
        type_definitions: parsed
            .type_definitions
            .iter()
            .map(convert_simple_type)
            .collect(),
        log_categories: parsed
            .log_categories
            .iter()
            .map(|category| (category.name.clone(), category.description.clone()))
            .collect(),
        default_experiment,
        variables: parsed.variables.iter().map(convert_variable).collect(),
        structure_outputs: parsed
            .model_structure
            .outputs
            .iter()
            .map(|unknown| unknown.index)
            .collect(),
    }
}
/// Checks what packaging adds to the model-description crate's validation: the CoSimulation
/// model identifier must be `expected_identifier` (the file stem, which names the archive and the
/// shared library `binaries/linux64/<id>.so` that importers look up).
pub fn check(description: &ModelDescription, expected_identifier: &str) -> Vec<Problem> {
    let mut problems = Vec::new();
    if description.model_identifier != expected_identifier {
        problems.push(Problem {
            file: description.file.clone(),
            line: None,
            message: format!(
                "CoSimulation modelIdentifier is {:?}, expected {:?} (the file name and the \
                 shared library lib{}.so must carry the model identifier)",
                description.model_identifier, expected_identifier, expected_identifier
            ),
        });
    }
    problems
}

/// Reads and checks one file; returns every problem at once.
pub fn load_and_check(
    path: &Path,
    expected_identifier: &str,
) -> Result<ModelDescription, Problems> {
    let description = read_file(path)?;
    let problems = check(&description, expected_identifier);
    if problems.is_empty() {
        Ok(description)
    } else {
        Err(Problems(problems))
    }
}
