//! Reads the parts of an FMI 2.0 `modelDescription.xml` that packaging needs (identity, variables,
//! units, type definitions, model structure) and checks the rules an archive relies on.
//!
//! The model-description crate of the FMU build is the authority on the full schema; this reader is
//! deliberately small and only extracts what the documentation page and the SSP system structure are
//! generated from, plus the checks whose failure would make a shipped archive unusable.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};

use quick_xml::events::{BytesStart, Event};
use quick_xml::{Reader, XmlVersion};

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
    pub has_model_exchange: bool,
    pub unit_definitions: Vec<UnitDefinition>,
    pub type_definitions: Vec<SimpleType>,
    pub log_categories: Vec<(String, Option<String>)>,
    pub default_experiment: Vec<(String, String)>,
    pub variables: Vec<ScalarVariable>,
    /// 1-based indices from `<ModelStructure><Outputs><Unknown index=..>`.
    pub structure_outputs: Vec<usize>,
    pub has_model_structure: bool,
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

const VARIABLE_TYPES: [&str; 5] = ["Real", "Integer", "Boolean", "String", "Enumeration"];

fn attributes(element: &BytesStart<'_>) -> Result<BTreeMap<String, String>, String> {
    let mut map = BTreeMap::new();
    for attribute in element.attributes() {
        let attribute = attribute.map_err(|error| format!("malformed attribute: {error}"))?;
        let key = AsRef::<str>::as_ref(&attribute.key).to_string();
        let value = attribute
            .normalized_value(XmlVersion::Implicit1_0)
            .map_err(|error| format!("attribute {key}: {error}"))?
            .into_owned();
        map.insert(key, value);
    }
    Ok(map)
}

fn ordered_attributes(element: &BytesStart<'_>) -> Result<Vec<(String, String)>, String> {
    let mut list = Vec::new();
    for attribute in element.attributes() {
        let attribute = attribute.map_err(|error| format!("malformed attribute: {error}"))?;
        let key = AsRef::<str>::as_ref(&attribute.key).to_string();
        let value = attribute
            .normalized_value(XmlVersion::Implicit1_0)
            .map_err(|error| format!("attribute {key}: {error}"))?
            .into_owned();
        list.push((key, value));
    }
    Ok(list)
}

fn line_of(text: &str, byte_position: usize) -> usize {
    let end = byte_position.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Reads a model description from disk; any I/O or XML syntax error is a [`Problem`] naming the file.
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

/// Parses model-description text; `file` only names the source in messages.
pub fn parse(file: &Path, text: &str) -> Result<ModelDescription, Problems> {
    let problem = |line: Option<usize>, message: String| {
        Problems(vec![Problem {
            file: file.to_path_buf(),
            line,
            message,
        }])
    };
    let mut reader = Reader::from_str(text);
    reader.config_mut().trim_text(true);
    let mut description = ModelDescription {
        file: file.to_path_buf(),
        ..ModelDescription::default()
    };
    // Element names from the root down to the current element.
    let mut stack: Vec<String> = Vec::new();
    let mut saw_root = false;
    loop {
        let start_position = reader.buffer_position() as usize;
        let event = reader.read_event().map_err(|error| {
            problem(
                Some(line_of(text, reader.error_position() as usize)),
                format!("XML syntax error: {error}"),
            )
        })?;
        let (element, is_empty) = match &event {
            Event::Start(element) => (element, false),
            Event::Empty(element) => (element, true),
            Event::End(_) => {
                stack.pop();
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        // The element starts after leading whitespace that trim_text skipped.
        let line = line_of(
            text,
            start_position + leading_whitespace(&text[start_position..]),
        );
        let name = AsRef::<str>::as_ref(&element.local_name()).to_string();
        let attrs = attributes(element).map_err(|message| problem(Some(line), message))?;
        let parent = stack.last().map(String::as_str);
        let grandparent = stack.len().checked_sub(2).map(|i| stack[i].as_str());
        match (parent, name.as_str()) {
            (None, root) => {
                if root != "fmiModelDescription" {
                    return Err(problem(
                        Some(line),
                        format!("the root element is <{root}>, expected <fmiModelDescription>"),
                    ));
                }
                saw_root = true;
                let get = |key: &str| attrs.get(key).cloned();
                description.fmi_version = get("fmiVersion").unwrap_or_default();
                description.model_name = get("modelName").unwrap_or_default();
                description.guid = get("guid").unwrap_or_default();
                description.description = get("description");
                description.author = get("author");
                description.version = get("version");
                description.generation_tool = get("generationTool");
            }
            (Some("fmiModelDescription"), "CoSimulation") => {
                description.model_identifier =
                    attrs.get("modelIdentifier").cloned().unwrap_or_default();
                description.co_simulation =
                    ordered_attributes(element).map_err(|message| problem(Some(line), message))?;
            }
            (Some("fmiModelDescription"), "ModelExchange") => description.has_model_exchange = true,
            (Some("fmiModelDescription"), "DefaultExperiment") => {
                description.default_experiment =
                    ordered_attributes(element).map_err(|message| problem(Some(line), message))?;
            }
            (Some("fmiModelDescription"), "ModelStructure") => {
                description.has_model_structure = true
            }
            (Some("UnitDefinitions"), "Unit") => {
                description.unit_definitions.push(UnitDefinition {
                    name: attrs.get("name").cloned().unwrap_or_default(),
                    ..UnitDefinition::default()
                })
            }
            (Some("Unit"), "BaseUnit") if grandparent == Some("UnitDefinitions") => {
                if let Some(unit) = description.unit_definitions.last_mut() {
                    unit.base_unit = ordered_attributes(element)
                        .map_err(|message| problem(Some(line), message))?;
                }
            }
            (Some("Unit"), "DisplayUnit") if grandparent == Some("UnitDefinitions") => {
                if let Some(unit) = description.unit_definitions.last_mut() {
                    unit.display_units.push(DisplayUnit {
                        name: attrs.get("name").cloned().unwrap_or_default(),
                        factor: attrs.get("factor").cloned(),
                        offset: attrs.get("offset").cloned(),
                    });
                }
            }
            (Some("TypeDefinitions"), "SimpleType") => {
                description.type_definitions.push(SimpleType {
                    name: attrs.get("name").cloned().unwrap_or_default(),
                    description: attrs.get("description").cloned(),
                    ..SimpleType::default()
                })
            }
            (Some("SimpleType"), kind) if VARIABLE_TYPES.contains(&kind) => {
                if let Some(simple_type) = description.type_definitions.last_mut() {
                    simple_type.kind = kind.to_string();
                    simple_type.unit = attrs.get("unit").cloned();
                    simple_type.display_unit = attrs.get("displayUnit").cloned();
                }
            }
            (Some("Enumeration"), "Item") if grandparent == Some("SimpleType") => {
                if let Some(simple_type) = description.type_definitions.last_mut() {
                    simple_type.items.push(EnumerationItem {
                        name: attrs.get("name").cloned().unwrap_or_default(),
                        value: attrs.get("value").cloned().unwrap_or_default(),
                        description: attrs.get("description").cloned(),
                    });
                }
            }
            (Some("LogCategories"), "Category") => description.log_categories.push((
                attrs.get("name").cloned().unwrap_or_default(),
                attrs.get("description").cloned(),
            )),
            (Some("ModelVariables"), "ScalarVariable") => {
                let name = attrs.get("name").cloned().unwrap_or_default();
                let value_reference = match attrs.get("valueReference") {
                    Some(text) => text.trim().parse::<u32>().map_err(|_| {
                        problem(
                            Some(line),
                            format!(
                                "variable {name:?}: valueReference {text:?} is not an unsigned \
                                 32-bit integer"
                            ),
                        )
                    })?,
                    None => {
                        return Err(problem(
                            Some(line),
                            format!("variable {name:?} has no valueReference"),
                        ))
                    }
                };
                description.variables.push(ScalarVariable {
                    name,
                    value_reference,
                    description: attrs.get("description").cloned(),
                    causality: attrs
                        .get("causality")
                        .cloned()
                        .unwrap_or_else(|| "local".into()),
                    variability: attrs
                        .get("variability")
                        .cloned()
                        .unwrap_or_else(|| "continuous".into()),
                    initial: attrs.get("initial").cloned(),
                    line,
                    ..ScalarVariable::default()
                });
            }
            (Some("ScalarVariable"), kind)
                if VARIABLE_TYPES.contains(&kind) && grandparent == Some("ModelVariables") =>
            {
                if let Some(variable) = description.variables.last_mut() {
                    variable.type_name = kind.to_string();
                    variable.declared_type = attrs.get("declaredType").cloned();
                    variable.unit = attrs.get("unit").cloned();
                    variable.display_unit = attrs.get("displayUnit").cloned();
                    variable.start = attrs.get("start").cloned();
                    variable.min = attrs.get("min").cloned();
                    variable.max = attrs.get("max").cloned();
                }
            }
            (Some("Outputs"), "Unknown") if grandparent == Some("ModelStructure") => {
                let index = attrs
                    .get("index")
                    .and_then(|text| text.trim().parse::<usize>().ok())
                    .ok_or_else(|| {
                        problem(
                            Some(line),
                            "ModelStructure/Outputs/Unknown needs a positive integer index".into(),
                        )
                    })?;
                description.structure_outputs.push(index);
            }
            _ => {}
        }
        if !is_empty {
            stack.push(name);
        }
    }
    if !saw_root {
        return Err(problem(None, "the file contains no XML element".into()));
    }
    Ok(description)
}

fn leading_whitespace(text: &str) -> usize {
    text.len() - text.trim_start().len()
}

fn parse_number(text: &str) -> Option<f64> {
    text.trim().parse::<f64>().ok()
}

/// Checks the rules a packaged FMU relies on. `expected_identifier` is the model identifier the
/// archive is built for (the file stem and the shared-library name must agree with it).
pub fn check(description: &ModelDescription, expected_identifier: &str) -> Vec<Problem> {
    let mut problems = Vec::new();
    let mut report = |line: Option<usize>, message: String| {
        problems.push(Problem {
            file: description.file.clone(),
            line,
            message,
        })
    };
    if description.fmi_version != "2.0" {
        report(
            None,
            format!(
                "fmiVersion is {:?}, expected \"2.0\"",
                description.fmi_version
            ),
        );
    }
    if description.model_name.trim().is_empty() {
        report(None, "modelName is missing or empty".into());
    }
    if description.guid.trim().is_empty() {
        report(None, "guid is missing or empty".into());
    }
    if description.co_simulation.is_empty() {
        report(
            None,
            "no <CoSimulation> element: the FMUs are Co-Simulation FMUs".into(),
        );
    } else if description.model_identifier != expected_identifier {
        report(
            None,
            format!(
                "CoSimulation modelIdentifier is {:?}, expected {:?} (the file name and the \
                 shared library lib{}.so must carry the model identifier)",
                description.model_identifier, expected_identifier, expected_identifier
            ),
        );
    }
    if description.has_model_exchange {
        report(
            None,
            "declares <ModelExchange>, but the binaries implement Co-Simulation only".into(),
        );
    }
    if !description.has_model_structure {
        report(None, "no <ModelStructure> element".into());
    }
    if description.variables.is_empty() {
        report(None, "no ScalarVariable in <ModelVariables>".into());
    }

    let units: BTreeSet<&str> = description
        .unit_definitions
        .iter()
        .map(|unit| unit.name.as_str())
        .collect();
    let mut names = BTreeSet::new();
    for variable in &description.variables {
        let at = Some(variable.line);
        let name = &variable.name;
        if name.is_empty() {
            report(at, "a ScalarVariable has no name".into());
            continue;
        }
        if !names.insert(name.as_str()) {
            report(at, format!("variable {name:?} is declared twice"));
        }
        if variable.type_name.is_empty() {
            report(
                at,
                format!(
                    "variable {name:?} has no type element (Real, Integer, Boolean, String or \
                     Enumeration)"
                ),
            );
            continue;
        }
        if !matches!(
            variable.causality.as_str(),
            "parameter" | "calculatedParameter" | "input" | "output" | "local" | "independent"
        ) {
            report(
                at,
                format!(
                    "variable {name:?}: unknown causality {:?}",
                    variable.causality
                ),
            );
        }
        if matches!(
            variable.causality.as_str(),
            "input" | "output" | "parameter"
        ) && variable
            .description
            .as_deref()
            .is_none_or(|text| text.trim().is_empty())
        {
            report(
                at,
                format!(
                    "{} {name:?} has no description (it must state meaning and sign convention)",
                    variable.causality
                ),
            );
        }
        if matches!(variable.causality.as_str(), "input" | "parameter") && variable.start.is_none()
        {
            report(
                at,
                format!(
                    "{} {name:?} has no start value (FMI 2.0 requires one)",
                    variable.causality
                ),
            );
        }
        if let Some(declared) = &variable.declared_type {
            match description.simple_type(declared) {
                None => report(
                    at,
                    format!(
                        "variable {name:?}: declaredType {declared:?} is not in <TypeDefinitions>"
                    ),
                ),
                Some(simple_type) if simple_type.kind != variable.type_name => report(
                    at,
                    format!(
                        "variable {name:?} is {} but its declaredType {declared:?} is {}",
                        variable.type_name, simple_type.kind
                    ),
                ),
                Some(_) => {}
            }
        } else if variable.type_name == "Enumeration" {
            report(at, format!("enumeration {name:?} has no declaredType"));
        }
        if variable.type_name == "Real" {
            match description.effective_unit(variable) {
                None => report(
                    at,
                    format!("Real variable {name:?} has no unit (use \"1\" for dimensionless)"),
                ),
                Some(unit) if !units.contains(unit.as_str()) => report(
                    at,
                    format!(
                        "variable {name:?}: unit {unit:?} is not declared in <UnitDefinitions>"
                    ),
                ),
                Some(unit) => {
                    if let Some(display) = description.effective_display_unit(variable) {
                        let declared = description
                            .unit_definition(&unit)
                            .is_some_and(|u| u.display_units.iter().any(|d| d.name == display));
                        if !declared {
                            report(
                                at,
                                format!(
                                    "variable {name:?}: displayUnit {display:?} is not a \
                                     DisplayUnit of unit {unit:?}"
                                ),
                            );
                        }
                    }
                }
            }
        }
        if matches!(
            variable.type_name.as_str(),
            "Real" | "Integer" | "Enumeration"
        ) {
            let min = variable.min.as_deref().and_then(parse_number);
            let max = variable.max.as_deref().and_then(parse_number);
            let start = variable.start.as_deref().and_then(parse_number);
            for (label, value) in [
                ("min", &variable.min),
                ("max", &variable.max),
                ("start", &variable.start),
            ] {
                if let Some(text) = value {
                    if parse_number(text).is_none() {
                        report(
                            at,
                            format!("variable {name:?}: {label} {text:?} is not a number"),
                        );
                    }
                }
            }
            if let (Some(min), Some(max)) = (min, max) {
                if min > max {
                    report(at, format!("variable {name:?}: min {min} > max {max}"));
                }
            }
            if let (Some(start), Some(min)) = (start, min) {
                if start < min {
                    report(at, format!("variable {name:?}: start {start} < min {min}"));
                }
            }
            if let (Some(start), Some(max)) = (start, max) {
                if start > max {
                    report(at, format!("variable {name:?}: start {start} > max {max}"));
                }
            }
        }
    }

    // ModelStructure/Outputs must list exactly the outputs (FMI 2.0 section 2.2.8).
    let output_indices: BTreeSet<usize> = description
        .variables
        .iter()
        .enumerate()
        .filter(|(_, variable)| variable.causality == "output")
        .map(|(index, _)| index + 1)
        .collect();
    let listed: BTreeSet<usize> = description.structure_outputs.iter().copied().collect();
    for index in output_indices.difference(&listed) {
        let variable = &description.variables[index - 1];
        report(
            Some(variable.line),
            format!(
                "output {:?} (index {index}) is missing from <ModelStructure><Outputs>",
                variable.name
            ),
        );
    }
    for index in listed.difference(&output_indices) {
        let what = match description.variables.get(index - 1) {
            Some(variable) => format!(
                "variable {:?} with causality {:?}",
                variable.name, variable.causality
            ),
            None => "no variable".into(),
        };
        report(
            None,
            format!(
                "<ModelStructure><Outputs> lists index {index}, which is {what}, not an output"
            ),
        );
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
