//! The FMI 3.0 model description, generated from the FMI 2.0 one (the single source of each
//! FMU's variables) and the FMU's FMI 3 supplement.
//!
//! The supplement, `modelDescription/<model>.fmi3.xml` beside `<model>.xml`, declares only what
//! FMI 2.0 cannot express, each variable once, with value references from
//! [`FMI3_ONLY_VALUE_REFERENCES`] up:
//!
//! ```xml
//! <Fmi3Supplement>
//!   <Float64 name="time" valueReference="1000" causality="independent" unit="s" description="…"/>
//!   <Int32 name="n" valueReference="1001" causality="output" description="…"/>
//!   <Float64 name="x" valueReference="1002" causality="output" description="…">
//!     <Dimension start="11"/>
//!   </Float64>
//! </Fmi3Supplement>
//! ```
//!
//! FMI 3.0 requires one independent variable, which FMI 2.0 Co-Simulation descriptions may
//! omit: the supplement names it. Every other supplement variable is a calculated output
//! (variability discrete) that depends on no input.
//!
//! The mapping of the FMI 2.0 part (FMI 3.0, section 2.4): Real becomes `Float64`, Integer
//! `Int32`, Enumeration `Enumeration` (accessed as Int64), Boolean `Boolean`; type definitions
//! likewise (`Float64Type`, `Int32Type`, `EnumerationType`, `BooleanType`); the model
//! structure's variable indices become value references; `guid` becomes
//! `instantiationToken`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::xml::{parse_tree, Element};
use crate::{Causality, Error, Initial, ModelDescription, SimpleTypeKind, Unknown, VariableValue};

/// The lowest value reference of an FMI 3-only variable; the FMI 2.0 ones stay below it.
pub const FMI3_ONLY_VALUE_REFERENCES: u32 = 1000;

/// What an FMI 3-only variable is.
#[derive(Debug, Clone, PartialEq)]
pub enum Fmi3Kind {
    /// The independent variable (time), a Float64 scalar.
    Time,
    /// A Float64 output with these dimensions (none: a scalar).
    Float64 { dimensions: Vec<usize> },
    /// An Int32 output scalar.
    Int32,
}

/// One variable of the FMI 3 supplement.
#[derive(Debug, Clone, PartialEq)]
pub struct Fmi3OnlyVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: String,
    pub unit: Option<String>,
    pub kind: Fmi3Kind,
}

/// The FMI 3 supplement of one FMU.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Supplement {
    pub variables: Vec<Fmi3OnlyVariable>,
}

/// The supplement's path for the FMI 2.0 description at `xml_path`: `<stem>.fmi3.xml`.
pub fn supplement_path(xml_path: &Path) -> PathBuf {
    let stem = xml_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    xml_path.with_file_name(format!("{stem}.fmi3.xml"))
}

/// Reads the supplement of the description at `xml_path` and checks it against `description`.
pub fn read_supplement(
    xml_path: &Path,
    description: &ModelDescription,
) -> Result<Supplement, Error> {
    let path = supplement_path(xml_path);
    let label = path.display().to_string();
    let text = std::fs::read_to_string(&path).map_err(|error| {
        Error::new(
            &label,
            None,
            "reading the FMI 3 supplement",
            error.to_string(),
        )
    })?;
    parse_supplement(&text, &label, description)
}

/// Parses a supplement and checks it: names and value references unique (also against the FMI
/// 2.0 variables), value references from [`FMI3_ONLY_VALUE_REFERENCES`], exactly one independent
/// variable, a description of at most 60 words, units declared in `description`.
pub fn parse_supplement(
    text: &str,
    file: &str,
    description: &ModelDescription,
) -> Result<Supplement, Error> {
    let root = parse_tree(text, file)?;
    if root.name != "Fmi3Supplement" {
        return Err(Error::new(
            file,
            Some(root.line),
            format!("<{}>", root.name),
            "expected the root element <Fmi3Supplement>",
        ));
    }
    let mut variables = Vec::new();
    for element in &root.children {
        variables.push(parse_variable(file, element, description)?);
    }
    let supplement = Supplement { variables };
    check_supplement(file, &supplement, description)?;
    Ok(supplement)
}

fn parse_variable(
    file: &str,
    element: &Element,
    description: &ModelDescription,
) -> Result<Fmi3OnlyVariable, Error> {
    let context = format!("<{}>", element.name);
    let fail = |message: String| Error::new(file, Some(element.line), context.clone(), message);
    let attribute = |name: &str| {
        element
            .attribute(name)
            .ok_or_else(|| fail(format!("attribute {name} is missing")))
    };
    let name = attribute("name")?.to_owned();
    let value_reference: u32 = attribute("valueReference")?
        .parse()
        .map_err(|_| fail(String::from("valueReference is not an unsigned integer")))?;
    let text = attribute("description")?.to_owned();
    let causality = attribute("causality")?;
    let unit = element.attribute("unit").map(str::to_owned);
    if let Some(unit) = &unit {
        if description.unit(unit).is_none() {
            return Err(fail(format!(
                "unit {unit:?} is not declared in the UnitDefinitions of the FMI 2.0 description"
            )));
        }
    }
    let mut dimensions = Vec::new();
    for child in &element.children {
        if child.name != "Dimension" {
            return Err(fail(format!(
                "unexpected child <{}>; expected <Dimension>",
                child.name
            )));
        }
        let start = child
            .attribute("start")
            .and_then(|s| s.parse::<usize>().ok())
            .filter(|&n| n > 0)
            .ok_or_else(|| fail(String::from("<Dimension> needs start, a positive integer")))?;
        dimensions.push(start);
    }
    let kind = match (element.name.as_str(), causality) {
        ("Float64", "independent") if dimensions.is_empty() => Fmi3Kind::Time,
        ("Float64", "output") => Fmi3Kind::Float64 { dimensions },
        ("Int32", "output") if dimensions.is_empty() => Fmi3Kind::Int32,
        (type_name, causality) => {
            return Err(fail(format!(
                "a {type_name} of causality {causality}{} is not supported; expected an independent Float64 scalar, a Float64 output or an Int32 output scalar",
                if dimensions.is_empty() { "" } else { " with dimensions" }
            )))
        }
    };
    Ok(Fmi3OnlyVariable {
        name,
        value_reference,
        description: text,
        unit,
        kind,
    })
}

fn check_supplement(
    file: &str,
    supplement: &Supplement,
    description: &ModelDescription,
) -> Result<(), Error> {
    let fail = |variable: &Fmi3OnlyVariable, message: String| {
        Error::new(
            file,
            None,
            format!(
                "variable '{}' (valueReference {})",
                variable.name, variable.value_reference
            ),
            message,
        )
    };
    for (i, variable) in supplement.variables.iter().enumerate() {
        if variable.value_reference < FMI3_ONLY_VALUE_REFERENCES {
            return Err(fail(
                variable,
                format!("FMI 3-only value references start at {FMI3_ONLY_VALUE_REFERENCES}"),
            ));
        }
        let words = variable.description.split_whitespace().count();
        if words > 60 {
            return Err(fail(
                variable,
                format!("the description has {words} words; at most 60"),
            ));
        }
        let clash_2 = description
            .variables
            .iter()
            .any(|v| v.name == variable.name || v.value_reference == variable.value_reference);
        let clash_3 = supplement.variables[..i]
            .iter()
            .any(|v| v.name == variable.name || v.value_reference == variable.value_reference);
        if clash_2 || clash_3 {
            return Err(fail(
                variable,
                String::from("the name or value reference is taken already"),
            ));
        }
    }
    let independent = supplement
        .variables
        .iter()
        .filter(|v| v.kind == Fmi3Kind::Time)
        .count();
    let independent_2 = description
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Independent)
        .count();
    if independent + independent_2 != 1 {
        return Err(Error::new(
            file,
            None,
            "<Fmi3Supplement>",
            format!(
                "FMI 3.0 needs exactly one independent variable; the descriptions declare {}",
                independent + independent_2
            ),
        ));
    }
    Ok(())
}

/// The value reference of FMI 2.0 variable number `index` (1-based, model structure).
fn reference_of(description: &ModelDescription, index: usize) -> u32 {
    description.variables[index - 1].value_reference
}

/// The outputs and the value references of their dependencies: the FMI 2.0 outputs' as the
/// model structure lists them (all knowns where it gives none: the inputs and the independent
/// variable), then the supplement's outputs, which depend on none.
pub fn output_dependencies(
    description: &ModelDescription,
    supplement: &Supplement,
) -> Vec<(u32, Vec<u32>)> {
    let all_knowns: Vec<u32> = description
        .variables
        .iter()
        .filter(|v| matches!(v.causality, Causality::Input | Causality::Independent))
        .map(|v| v.value_reference)
        .chain(
            (supplement.variables.iter())
                .filter(|v| v.kind == Fmi3Kind::Time)
                .map(|v| v.value_reference),
        )
        .collect();
    let mut outputs: Vec<(u32, Vec<u32>)> = description
        .model_structure
        .outputs
        .iter()
        .map(|unknown: &Unknown| {
            let dependencies = match &unknown.dependencies {
                Some(indices) => {
                    let mut references: Vec<u32> = indices
                        .iter()
                        .map(|&index| reference_of(description, index))
                        .collect();
                    references.sort_unstable();
                    references
                }
                None => all_knowns.clone(),
            };
            (reference_of(description, unknown.index), dependencies)
        })
        .collect();
    for variable in &supplement.variables {
        if variable.kind != Fmi3Kind::Time {
            outputs.push((variable.value_reference, Vec::new()));
        }
    }
    outputs
}

/// Rust source for the FMU crates: `FMI3_VARIABLES` and `OUTPUT_DEPENDENCIES` for
/// `fmi_export::CoSimulationModel`, and `mod vr3` with one value reference per FMI 3-only
/// variable.
pub fn generate_rust(description: &ModelDescription, supplement: &Supplement) -> String {
    let mut w = String::new();
    let _ = writeln!(
        w,
        "/// The FMI 3-only variables (the FMI 3 supplement).\npub const FMI3_VARIABLES: &[::fmi_export::Fmi3Variable] = &["
    );
    for variable in &supplement.variables {
        let kind = match &variable.kind {
            Fmi3Kind::Time => String::from("::fmi_export::Fmi3Kind::Time"),
            Fmi3Kind::Int32 => String::from("::fmi_export::Fmi3Kind::Int32"),
            Fmi3Kind::Float64 { dimensions } => {
                format!("::fmi_export::Fmi3Kind::Float64 {{ dimensions: &{dimensions:?} }}")
            }
        };
        let _ = writeln!(
            w,
            "    ::fmi_export::Fmi3Variable {{ name: {:?}, value_reference: {}, kind: {kind} }},",
            variable.name, variable.value_reference
        );
    }
    let _ = writeln!(w, "];\n");
    let _ = writeln!(
        w,
        "/// Each output's dependencies (value references of knowns), as the ModelStructure lists them.\npub const OUTPUT_DEPENDENCIES: &[(u32, &[u32])] = &["
    );
    for (output, dependencies) in output_dependencies(description, supplement) {
        let _ = writeln!(w, "    ({output}, &{dependencies:?}),");
    }
    let _ = writeln!(w, "];\n");
    let _ = writeln!(
        w,
        "/// Value references of the FMI 3-only variables.\n#[allow(dead_code)]\npub mod vr3 {{"
    );
    for variable in &supplement.variables {
        let _ = writeln!(
            w,
            "    /// {}\n    pub const {}: u32 = {};",
            variable.description,
            variable.name.to_ascii_uppercase(),
            variable.value_reference
        );
    }
    let _ = writeln!(w, "}}");
    w
}

/// XML attribute text with the five special characters escaped.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// A number as the XML writes it: the shortest form that reads back to the same f64.
fn number(value: f64) -> String {
    format!("{value:?}").trim_end_matches(".0").to_owned()
}

/// ` name="value"` for each present attribute.
fn attributes(pairs: &[(&str, Option<String>)]) -> String {
    pairs
        .iter()
        .filter_map(|(name, value)| {
            value
                .as_ref()
                .map(|value| format!(" {name}=\"{}\"", escape(value)))
        })
        .collect()
}

fn flag(value: bool) -> Option<String> {
    Some(String::from(if value { "true" } else { "false" }))
}

/// The FMI 3.0 `modelDescription.xml` of the FMU, with `generationDateAndTime` when given.
pub fn model_description_xml(
    description: &ModelDescription,
    supplement: &Supplement,
    generation_time: Option<&str>,
) -> String {
    let mut w = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let cs = &description.co_simulation;
    let _ = writeln!(
        w,
        "<fmiModelDescription{}>",
        attributes(&[
            ("fmiVersion", Some(String::from("3.0"))),
            ("modelName", Some(description.model_name.clone())),
            ("instantiationToken", Some(description.guid.clone())),
            ("description", description.description.clone()),
            ("version", description.version.clone()),
            ("author", description.author.clone()),
            ("copyright", description.copyright.clone()),
            ("license", description.license.clone()),
            (
                "generationTool",
                Some(String::from(
                    "generated from the FMI 2.0 model description and the FMI 3 supplement by fmu-src/model-description",
                )),
            ),
            ("generationDateAndTime", generation_time.map(str::to_owned)),
            (
                "variableNamingConvention",
                description.variable_naming_convention.clone(),
            ),
        ])
    );
    let _ = writeln!(
        w,
        "  <CoSimulation{}/>",
        attributes(&[
            ("modelIdentifier", Some(cs.model_identifier.clone())),
            ("needsExecutionTool", flag(cs.needs_execution_tool)),
            (
                "canBeInstantiatedOnlyOncePerProcess",
                flag(cs.can_be_instantiated_only_once_per_process),
            ),
            ("canGetAndSetFMUState", flag(cs.can_get_and_set_fmu_state)),
            ("canSerializeFMUState", flag(cs.can_serialize_fmu_state)),
            ("providesDirectionalDerivatives", flag(false)),
            ("providesAdjointDerivatives", flag(false)),
            ("providesPerElementDependencies", flag(false)),
            (
                "canHandleVariableCommunicationStepSize",
                flag(cs.can_handle_variable_communication_step_size),
            ),
            ("maxOutputDerivativeOrder", Some(String::from("0"))),
            ("providesIntermediateUpdate", flag(false)),
            ("canReturnEarlyAfterIntermediateUpdate", flag(false)),
            ("hasEventMode", flag(false)),
            ("providesEvaluateDiscreteStates", flag(false)),
        ])
    );
    write_units(&mut w, description);
    write_types(&mut w, description);
    if !description.log_categories.is_empty() {
        let _ = writeln!(w, "  <LogCategories>");
        for category in &description.log_categories {
            let _ = writeln!(
                w,
                "    <Category{}/>",
                attributes(&[
                    ("name", Some(category.name.clone())),
                    (
                        "description",
                        category
                            .description
                            .as_ref()
                            .map(|d| d.replace("fmi2", "fmi3")),
                    ),
                ])
            );
        }
        let _ = writeln!(w, "  </LogCategories>");
    }
    if let Some(experiment) = &description.default_experiment {
        let _ = writeln!(
            w,
            "  <DefaultExperiment{}/>",
            attributes(&[
                ("startTime", experiment.start_time.map(number)),
                ("stopTime", experiment.stop_time.map(number)),
                ("tolerance", experiment.tolerance.map(number)),
                ("stepSize", experiment.step_size.map(number)),
            ])
        );
    }
    write_variables(&mut w, description, supplement);
    write_structure(&mut w, description, supplement);
    w.push_str("</fmiModelDescription>\n");
    w
}

fn write_units(w: &mut String, description: &ModelDescription) {
    if description.unit_definitions.is_empty() {
        return;
    }
    let _ = writeln!(w, "  <UnitDefinitions>");
    for unit in &description.unit_definitions {
        let _ = write!(w, "    <Unit name=\"{}\">", escape(&unit.name));
        if let Some(base) = &unit.base_unit {
            let exponent = |e: i32| (e != 0).then(|| e.to_string());
            let _ = write!(
                w,
                "<BaseUnit{}/>",
                attributes(&[
                    ("kg", exponent(base.kg)),
                    ("m", exponent(base.m)),
                    ("s", exponent(base.s)),
                    ("A", exponent(base.a)),
                    ("K", exponent(base.k)),
                    ("mol", exponent(base.mol)),
                    ("cd", exponent(base.cd)),
                    ("rad", exponent(base.rad)),
                    ("factor", (base.factor != 1.0).then(|| number(base.factor))),
                    ("offset", (base.offset != 0.0).then(|| number(base.offset))),
                ])
            );
        }
        for display in &unit.display_units {
            let _ = write!(
                w,
                "<DisplayUnit{}/>",
                attributes(&[
                    ("name", Some(display.name.clone())),
                    (
                        "factor",
                        (display.factor != 1.0).then(|| number(display.factor))
                    ),
                    (
                        "offset",
                        (display.offset != 0.0).then(|| number(display.offset))
                    ),
                ])
            );
        }
        let _ = writeln!(w, "</Unit>");
    }
    let _ = writeln!(w, "  </UnitDefinitions>");
}

fn write_types(w: &mut String, description: &ModelDescription) {
    if description.type_definitions.is_empty() {
        return;
    }
    let _ = writeln!(w, "  <TypeDefinitions>");
    for simple in &description.type_definitions {
        let common = [
            ("name", Some(simple.name.clone())),
            ("description", simple.description.clone()),
        ];
        match &simple.kind {
            SimpleTypeKind::Real {
                unit,
                display_unit,
                min,
                max,
            } => {
                let _ = writeln!(
                    w,
                    "    <Float64Type{}{}/>",
                    attributes(&common),
                    attributes(&[
                        ("unit", unit.clone()),
                        ("displayUnit", display_unit.clone()),
                        ("min", min.map(number)),
                        ("max", max.map(number)),
                    ])
                );
            }
            SimpleTypeKind::Integer { min, max } => {
                let _ = writeln!(
                    w,
                    "    <Int32Type{}{}/>",
                    attributes(&common),
                    attributes(&[
                        ("min", min.map(|v| v.to_string())),
                        ("max", max.map(|v| v.to_string())),
                    ])
                );
            }
            SimpleTypeKind::Boolean => {
                let _ = writeln!(w, "    <BooleanType{}/>", attributes(&common));
            }
            SimpleTypeKind::String => {
                let _ = writeln!(w, "    <StringType{}/>", attributes(&common));
            }
            SimpleTypeKind::Enumeration { items } => {
                let _ = writeln!(w, "    <EnumerationType{}>", attributes(&common));
                for item in items {
                    let _ = writeln!(
                        w,
                        "      <Item{}/>",
                        attributes(&[
                            ("name", Some(item.name.clone())),
                            ("value", Some(item.value.to_string())),
                            ("description", item.description.clone()),
                        ])
                    );
                }
                let _ = writeln!(w, "    </EnumerationType>");
            }
        }
    }
    let _ = writeln!(w, "  </TypeDefinitions>");
}

fn initial_name(initial: Initial) -> &'static str {
    match initial {
        Initial::Exact => "exact",
        Initial::Approx => "approx",
        Initial::Calculated => "calculated",
    }
}

fn write_variables(w: &mut String, description: &ModelDescription, supplement: &Supplement) {
    let _ = writeln!(w, "  <ModelVariables>");
    for variable in &supplement.variables {
        if variable.kind == Fmi3Kind::Time {
            let _ = writeln!(
                w,
                "    <Float64{}/>",
                attributes(&[
                    ("name", Some(variable.name.clone())),
                    ("valueReference", Some(variable.value_reference.to_string())),
                    ("description", Some(variable.description.clone())),
                    ("causality", Some(String::from("independent"))),
                    ("variability", Some(String::from("continuous"))),
                    ("unit", variable.unit.clone()),
                ])
            );
        }
    }
    for variable in &description.variables {
        let head = attributes(&[
            ("name", Some(variable.name.clone())),
            ("valueReference", Some(variable.value_reference.to_string())),
            ("description", variable.description.clone()),
            ("causality", Some(variable.causality.xml_name().to_owned())),
            (
                "variability",
                Some(variable.variability.xml_name().to_owned()),
            ),
            (
                "initial",
                variable.initial.map(|i| initial_name(i).to_owned()),
            ),
        ]);
        let (element, rest) = match &variable.value {
            VariableValue::Real {
                declared_type,
                unit,
                display_unit,
                min,
                max,
                nominal,
                start,
            } => (
                "Float64",
                attributes(&[
                    ("declaredType", declared_type.clone()),
                    ("unit", unit.clone()),
                    ("displayUnit", display_unit.clone()),
                    ("min", min.map(number)),
                    ("max", max.map(number)),
                    ("nominal", nominal.map(number)),
                    ("start", start.map(number)),
                ]),
            ),
            VariableValue::Integer {
                declared_type,
                min,
                max,
                start,
            } => (
                "Int32",
                attributes(&[
                    ("declaredType", declared_type.clone()),
                    ("min", min.map(|v| v.to_string())),
                    ("max", max.map(|v| v.to_string())),
                    ("start", start.map(|v| v.to_string())),
                ]),
            ),
            VariableValue::Enumeration {
                declared_type,
                min,
                max,
                start,
            } => (
                "Enumeration",
                attributes(&[
                    ("declaredType", Some(declared_type.clone())),
                    ("min", min.map(|v| v.to_string())),
                    ("max", max.map(|v| v.to_string())),
                    ("start", start.map(|v| v.to_string())),
                ]),
            ),
            VariableValue::Boolean {
                declared_type,
                start,
            } => (
                "Boolean",
                attributes(&[
                    ("declaredType", declared_type.clone()),
                    ("start", start.and_then(flag)),
                ]),
            ),
            VariableValue::String {
                declared_type,
                start,
            } => (
                "String",
                // The plumbing has no String variables (codegen refuses them), so no start.
                {
                    let _ = start;
                    attributes(&[("declaredType", declared_type.clone())])
                },
            ),
        };
        let _ = writeln!(w, "    <{element}{head}{rest}/>");
    }
    for variable in &supplement.variables {
        let head = attributes(&[
            ("name", Some(variable.name.clone())),
            ("valueReference", Some(variable.value_reference.to_string())),
            ("description", Some(variable.description.clone())),
            ("causality", Some(String::from("output"))),
            ("variability", Some(String::from("discrete"))),
            ("initial", Some(String::from("calculated"))),
        ]);
        match &variable.kind {
            Fmi3Kind::Time => {}
            Fmi3Kind::Int32 => {
                let _ = writeln!(w, "    <Int32{head}/>");
            }
            Fmi3Kind::Float64 { dimensions } if dimensions.is_empty() => {
                let unit = attributes(&[("unit", variable.unit.clone())]);
                let _ = writeln!(w, "    <Float64{head}{unit}/>");
            }
            Fmi3Kind::Float64 { dimensions } => {
                let unit = attributes(&[("unit", variable.unit.clone())]);
                let _ = writeln!(w, "    <Float64{head}{unit}>");
                for size in dimensions {
                    let _ = writeln!(w, "      <Dimension start=\"{size}\"/>");
                }
                let _ = writeln!(w, "    </Float64>");
            }
        }
    }
    let _ = writeln!(w, "  </ModelVariables>");
}

fn write_structure(w: &mut String, description: &ModelDescription, supplement: &Supplement) {
    let _ = writeln!(w, "  <ModelStructure>");
    let list = |references: &[u32]| {
        references
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(" ")
    };
    for (output, dependencies) in output_dependencies(description, supplement) {
        let _ = writeln!(
            w,
            "    <Output valueReference=\"{output}\" dependencies=\"{}\"/>",
            list(&dependencies)
        );
    }
    for unknown in &description.model_structure.initial_unknowns {
        let dependencies = unknown.dependencies.as_ref().map(|indices| {
            let mut references: Vec<u32> = indices
                .iter()
                .map(|&index| reference_of(description, index))
                .collect();
            references.sort_unstable();
            references
        });
        let _ = writeln!(
            w,
            "    <InitialUnknown valueReference=\"{}\"{}/>",
            reference_of(description, unknown.index),
            attributes(&[("dependencies", dependencies.map(|d| list(&d)))])
        );
    }
    for variable in &supplement.variables {
        if variable.kind != Fmi3Kind::Time {
            let _ = writeln!(
                w,
                "    <InitialUnknown valueReference=\"{}\" dependencies=\"\"/>",
                variable.value_reference
            );
        }
    }
    let _ = writeln!(w, "  </ModelStructure>");
}
