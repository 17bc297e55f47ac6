//! From the element tree to typed structs. Strict: an attribute or element that FMI 2.0 does not
//! define at that place is an error (it is usually a typo), and so is anything the `fmi` crate's
//! parser rejects (e.g. `<Annotations>` inside a `<ScalarVariable>`, which FMI 2.0 would allow).

use std::str::FromStr;

use crate::xml::{parse_tree, Element};
use crate::{
    BaseUnit, Causality, CoSimulation, DefaultExperiment, DisplayUnit, EnumerationItem, Error,
    Initial, LogCategory, ModelDescription, ModelStructure, ScalarVariable, SimpleType,
    SimpleTypeKind, Unit, Unknown, Variability, VariableValue,
};

/// Typed access to the attributes of one element, with messages that name the element.
struct Attributes<'a> {
    file: &'a str,
    element: &'a Element,
    context: String,
}

impl<'a> Attributes<'a> {
    fn new(file: &'a str, element: &'a Element, context: impl Into<String>) -> Self {
        Self {
            file,
            element,
            context: context.into(),
        }
    }

    fn error(&self, message: impl Into<String>) -> Error {
        Error::new(
            self.file,
            Some(self.element.line),
            self.context.clone(),
            message,
        )
    }

    /// Rejects attributes outside `allowed`.
    fn only(&self, allowed: &[&str]) -> Result<(), Error> {
        for (key, _) in &self.element.attributes {
            if !allowed.contains(&key.as_str()) {
                return Err(self.error(format!(
                    "unknown attribute '{key}' on <{}>; expected one of: {}",
                    self.element.name,
                    allowed.join(", ")
                )));
            }
        }
        Ok(())
    }

    fn string(&self, name: &str) -> Option<String> {
        self.element.attribute(name).map(str::to_owned)
    }

    fn required(&self, name: &str) -> Result<String, Error> {
        self.string(name).ok_or_else(|| {
            self.error(format!(
                "missing attribute '{name}' on <{}>",
                self.element.name
            ))
        })
    }

    fn parsed<T: FromStr>(&self, name: &str, expected: &str) -> Result<Option<T>, Error> {
        match self.element.attribute(name) {
            None => Ok(None),
            Some(text) => text.trim().parse::<T>().map(Some).map_err(|_| {
                self.error(format!("attribute '{name}' = \"{text}\" is not {expected}"))
            }),
        }
    }

    fn f64(&self, name: &str) -> Result<Option<f64>, Error> {
        self.parsed::<f64>(name, "a real number")
    }

    fn i32(&self, name: &str) -> Result<Option<i32>, Error> {
        self.parsed::<i32>(name, "a 32-bit integer")
    }

    fn bool(&self, name: &str) -> Result<Option<bool>, Error> {
        match self.element.attribute(name) {
            None => Ok(None),
            Some("true") | Some("1") => Ok(Some(true)),
            Some("false") | Some("0") => Ok(Some(false)),
            Some(text) => Err(self.error(format!(
                "attribute '{name}' = \"{text}\" is not a boolean (true or false)"
            ))),
        }
    }
}

fn no_children(file: &str, element: &Element, context: &str) -> Result<(), Error> {
    match element.children.first() {
        None => Ok(()),
        Some(child) => Err(Error::new(
            file,
            Some(child.line),
            context,
            format!(
                "unexpected element <{}> inside <{}>",
                child.name, element.name
            ),
        )),
    }
}

pub(crate) fn parse(text: &str, file: &str) -> Result<ModelDescription, Error> {
    let root = parse_tree(text, file)?;
    if root.name != "fmiModelDescription" {
        return Err(Error::new(
            file,
            Some(root.line),
            "document",
            format!(
                "root element is <{}>; expected <fmiModelDescription>",
                root.name
            ),
        ));
    }
    let attributes = Attributes::new(file, &root, "<fmiModelDescription>");
    attributes.only(&[
        "fmiVersion",
        "modelName",
        "guid",
        "description",
        "author",
        "version",
        "copyright",
        "license",
        "generationTool",
        "generationDateAndTime",
        "variableNamingConvention",
        "numberOfEventIndicators",
    ])?;

    let mut co_simulation = None;
    let mut unit_definitions = Vec::new();
    let mut type_definitions = Vec::new();
    let mut log_categories = Vec::new();
    let mut default_experiment = None;
    let mut variables = None;
    let mut model_structure = None;
    for child in &root.children {
        let duplicate = |seen: bool| -> Result<(), Error> {
            if seen {
                Err(Error::new(
                    file,
                    Some(child.line),
                    format!("<{}>", child.name),
                    "the element appears twice; expected it at most once",
                ))
            } else {
                Ok(())
            }
        };
        match child.name.as_str() {
            "CoSimulation" => {
                duplicate(co_simulation.is_some())?;
                co_simulation = Some(parse_co_simulation(file, child)?);
            }
            "ModelExchange" => {
                return Err(Error::new(
                    file,
                    Some(child.line),
                    "<ModelExchange>",
                    "this project's FMUs are Co-Simulation only; expected no <ModelExchange>",
                ))
            }
            "UnitDefinitions" => {
                unit_definitions = parse_units(file, child)?;
            }
            "TypeDefinitions" => {
                type_definitions = parse_types(file, child)?;
            }
            "LogCategories" => {
                log_categories = parse_log_categories(file, child)?;
            }
            "DefaultExperiment" => {
                duplicate(default_experiment.is_some())?;
                let attributes = Attributes::new(file, child, "<DefaultExperiment>");
                attributes.only(&["startTime", "stopTime", "tolerance", "stepSize"])?;
                no_children(file, child, "<DefaultExperiment>")?;
                default_experiment = Some(DefaultExperiment {
                    start_time: attributes.f64("startTime")?,
                    stop_time: attributes.f64("stopTime")?,
                    tolerance: attributes.f64("tolerance")?,
                    step_size: attributes.f64("stepSize")?,
                });
            }
            "VendorAnnotations" => {}
            "ModelVariables" => {
                duplicate(variables.is_some())?;
                variables = Some(parse_variables(file, child)?);
            }
            "ModelStructure" => {
                duplicate(model_structure.is_some())?;
                model_structure = Some(parse_model_structure(file, child)?);
            }
            other => {
                return Err(Error::new(
                    file,
                    Some(child.line),
                    "<fmiModelDescription>",
                    format!(
                        "unexpected element <{other}>; expected CoSimulation, UnitDefinitions, \
                         TypeDefinitions, LogCategories, DefaultExperiment, VendorAnnotations, \
                         ModelVariables or ModelStructure"
                    ),
                ))
            }
        }
    }

    let missing = |what: &str| {
        Error::new(
            file,
            Some(root.line),
            "<fmiModelDescription>",
            format!("missing element <{what}>"),
        )
    };
    Ok(ModelDescription {
        fmi_version: attributes.required("fmiVersion")?,
        model_name: attributes.required("modelName")?,
        guid: attributes.required("guid")?,
        description: attributes.string("description"),
        version: attributes.string("version"),
        author: attributes.string("author"),
        copyright: attributes.string("copyright"),
        license: attributes.string("license"),
        generation_tool: attributes.string("generationTool"),
        variable_naming_convention: attributes.string("variableNamingConvention"),
        co_simulation: co_simulation.ok_or_else(|| missing("CoSimulation"))?,
        unit_definitions,
        type_definitions,
        log_categories,
        default_experiment,
        variables: variables.ok_or_else(|| missing("ModelVariables"))?,
        model_structure: model_structure.ok_or_else(|| missing("ModelStructure"))?,
    })
}

fn parse_co_simulation(file: &str, element: &Element) -> Result<CoSimulation, Error> {
    let a = Attributes::new(file, element, "<CoSimulation>");
    a.only(&[
        "modelIdentifier",
        "needsExecutionTool",
        "canHandleVariableCommunicationStepSize",
        "canInterpolateInputs",
        "maxOutputDerivativeOrder",
        "canRunAsynchronuously",
        "canBeInstantiatedOnlyOncePerProcess",
        "canNotUseMemoryManagementFunctions",
        "canGetAndSetFMUstate",
        "canSerializeFMUstate",
        "providesDirectionalDerivative",
    ])?;
    for child in &element.children {
        if child.name != "SourceFiles" {
            return Err(Error::new(
                file,
                Some(child.line),
                "<CoSimulation>",
                format!(
                    "unexpected element <{}>; expected only <SourceFiles>",
                    child.name
                ),
            ));
        }
    }
    Ok(CoSimulation {
        model_identifier: a.required("modelIdentifier")?,
        needs_execution_tool: a.bool("needsExecutionTool")?.unwrap_or(false),
        can_handle_variable_communication_step_size: a
            .bool("canHandleVariableCommunicationStepSize")?
            .unwrap_or(false),
        can_interpolate_inputs: a.bool("canInterpolateInputs")?.unwrap_or(false),
        max_output_derivative_order: a
            .parsed::<u32>("maxOutputDerivativeOrder", "a non-negative integer")?
            .unwrap_or(0),
        can_run_asynchronuously: a.bool("canRunAsynchronuously")?.unwrap_or(false),
        can_be_instantiated_only_once_per_process: a
            .bool("canBeInstantiatedOnlyOncePerProcess")?
            .unwrap_or(false),
        can_not_use_memory_management_functions: a
            .bool("canNotUseMemoryManagementFunctions")?
            .unwrap_or(false),
        can_get_and_set_fmu_state: a.bool("canGetAndSetFMUstate")?.unwrap_or(false),
        can_serialize_fmu_state: a.bool("canSerializeFMUstate")?.unwrap_or(false),
        provides_directional_derivative: a.bool("providesDirectionalDerivative")?.unwrap_or(false),
    })
}

fn expect_children_named(file: &str, element: &Element, expected: &str) -> Result<(), Error> {
    for child in &element.children {
        if child.name != expected {
            return Err(Error::new(
                file,
                Some(child.line),
                format!("<{}>", element.name),
                format!(
                    "unexpected element <{}>; expected only <{expected}>",
                    child.name
                ),
            ));
        }
    }
    Ok(())
}

fn parse_units(file: &str, element: &Element) -> Result<Vec<Unit>, Error> {
    Attributes::new(file, element, "<UnitDefinitions>").only(&[])?;
    expect_children_named(file, element, "Unit")?;
    let mut units = Vec::new();
    for unit_element in &element.children {
        let a = Attributes::new(file, unit_element, "<Unit>");
        a.only(&["name"])?;
        let name = a.required("name")?;
        let context = format!("unit '{name}'");
        let mut base_unit = None;
        let mut display_units = Vec::new();
        for child in &unit_element.children {
            match child.name.as_str() {
                "BaseUnit" => {
                    let b = Attributes::new(file, child, context.clone());
                    b.only(&[
                        "kg", "m", "s", "A", "K", "mol", "cd", "rad", "factor", "offset",
                    ])?;
                    no_children(file, child, &context)?;
                    base_unit = Some(BaseUnit {
                        kg: b.i32("kg")?.unwrap_or(0),
                        m: b.i32("m")?.unwrap_or(0),
                        s: b.i32("s")?.unwrap_or(0),
                        a: b.i32("A")?.unwrap_or(0),
                        k: b.i32("K")?.unwrap_or(0),
                        mol: b.i32("mol")?.unwrap_or(0),
                        cd: b.i32("cd")?.unwrap_or(0),
                        rad: b.i32("rad")?.unwrap_or(0),
                        factor: b.f64("factor")?.unwrap_or(1.0),
                        offset: b.f64("offset")?.unwrap_or(0.0),
                    });
                }
                "DisplayUnit" => {
                    let d = Attributes::new(file, child, context.clone());
                    d.only(&["name", "factor", "offset"])?;
                    no_children(file, child, &context)?;
                    display_units.push(DisplayUnit {
                        name: d.required("name")?,
                        factor: d.f64("factor")?.unwrap_or(1.0),
                        offset: d.f64("offset")?.unwrap_or(0.0),
                    });
                }
                other => {
                    return Err(Error::new(
                        file,
                        Some(child.line),
                        context,
                        format!("unexpected element <{other}>; expected BaseUnit or DisplayUnit"),
                    ))
                }
            }
        }
        units.push(Unit {
            name,
            base_unit,
            display_units,
        });
    }
    Ok(units)
}

fn parse_types(file: &str, element: &Element) -> Result<Vec<SimpleType>, Error> {
    Attributes::new(file, element, "<TypeDefinitions>").only(&[])?;
    expect_children_named(file, element, "SimpleType")?;
    let mut types = Vec::new();
    for type_element in &element.children {
        let a = Attributes::new(file, type_element, "<SimpleType>");
        a.only(&["name", "description"])?;
        let name = a.required("name")?;
        let context = format!("simple type '{name}'");
        let [kind_element] = type_element.children.as_slice() else {
            return Err(Error::new(
                file,
                Some(type_element.line),
                context,
                "expected exactly one of <Real>, <Integer>, <Boolean>, <String>, <Enumeration>",
            ));
        };
        let k = Attributes::new(file, kind_element, context.clone());
        let kind = match kind_element.name.as_str() {
            "Real" => {
                k.only(&[
                    "quantity",
                    "unit",
                    "displayUnit",
                    "relativeQuantity",
                    "min",
                    "max",
                    "nominal",
                    "unbounded",
                ])?;
                SimpleTypeKind::Real {
                    unit: k.string("unit"),
                    display_unit: k.string("displayUnit"),
                    min: k.f64("min")?,
                    max: k.f64("max")?,
                }
            }
            "Integer" => {
                k.only(&["quantity", "min", "max"])?;
                SimpleTypeKind::Integer {
                    min: k.i32("min")?,
                    max: k.i32("max")?,
                }
            }
            "Boolean" => {
                k.only(&[])?;
                SimpleTypeKind::Boolean
            }
            "String" => {
                k.only(&[])?;
                SimpleTypeKind::String
            }
            "Enumeration" => {
                k.only(&["quantity"])?;
                expect_children_named(file, kind_element, "Item")?;
                let mut items = Vec::new();
                for item in &kind_element.children {
                    let i = Attributes::new(file, item, context.clone());
                    i.only(&["name", "value", "description"])?;
                    no_children(file, item, &context)?;
                    items.push(EnumerationItem {
                        name: i.required("name")?,
                        value: i.i32("value")?.ok_or_else(|| {
                            i.error("missing attribute 'value' on <Item>")
                        })?,
                        description: i.string("description"),
                    });
                }
                SimpleTypeKind::Enumeration { items }
            }
            other => {
                return Err(Error::new(
                    file,
                    Some(kind_element.line),
                    context,
                    format!(
                        "unexpected element <{other}>; expected Real, Integer, Boolean, String or Enumeration"
                    ),
                ))
            }
        };
        types.push(SimpleType {
            name,
            description: a.string("description"),
            kind,
        });
    }
    Ok(types)
}

fn parse_log_categories(file: &str, element: &Element) -> Result<Vec<LogCategory>, Error> {
    Attributes::new(file, element, "<LogCategories>").only(&[])?;
    expect_children_named(file, element, "Category")?;
    element
        .children
        .iter()
        .map(|category| {
            let a = Attributes::new(file, category, "<Category>");
            a.only(&["name", "description"])?;
            no_children(file, category, "<Category>")?;
            Ok(LogCategory {
                name: a.required("name")?,
                description: a.string("description"),
            })
        })
        .collect()
}

fn parse_variables(file: &str, element: &Element) -> Result<Vec<ScalarVariable>, Error> {
    Attributes::new(file, element, "<ModelVariables>").only(&[])?;
    expect_children_named(file, element, "ScalarVariable")?;
    element
        .children
        .iter()
        .map(|variable| parse_variable(file, variable))
        .collect()
}

fn parse_variable(file: &str, element: &Element) -> Result<ScalarVariable, Error> {
    let a = Attributes::new(file, element, "<ScalarVariable>");
    // Deliberately without canHandleMultipleSetPerTimeInstant: the `fmi` crate rejects it.
    a.only(&[
        "name",
        "valueReference",
        "description",
        "causality",
        "variability",
        "initial",
    ])?;
    let name = a.required("name")?;
    let context = format!("variable '{name}'");
    let a = Attributes::new(file, element, context.clone());
    let value_reference = a
        .parsed::<u32>("valueReference", "an unsigned 32-bit value reference")?
        .ok_or_else(|| a.error("missing attribute 'valueReference'"))?;
    let context = format!("variable '{name}' (valueReference {value_reference})");
    let a = Attributes::new(file, element, context.clone());
    let causality = match a.string("causality") {
        None => Causality::Local,
        Some(name) => Causality::from_xml_name(&name).ok_or_else(|| {
            a.error(format!(
                "causality \"{name}\" is not one of {}",
                xml_names(Causality::ALL.iter().map(|c| c.xml_name()))
            ))
        })?,
    };
    let variability = match a.string("variability") {
        None => Variability::Continuous,
        Some(name) => Variability::from_xml_name(&name).ok_or_else(|| {
            a.error(format!(
                "variability \"{name}\" is not one of {}",
                xml_names(Variability::ALL.iter().map(|v| v.xml_name()))
            ))
        })?,
    };
    let initial = match a.string("initial").as_deref() {
        None => None,
        Some("exact") => Some(Initial::Exact),
        Some("approx") => Some(Initial::Approx),
        Some("calculated") => Some(Initial::Calculated),
        Some(other) => {
            return Err(a.error(format!(
                "initial \"{other}\" is not one of exact, approx, calculated"
            )))
        }
    };

    let mut type_elements = Vec::new();
    for child in &element.children {
        match child.name.as_str() {
            "Real" | "Integer" | "Boolean" | "String" | "Enumeration" => type_elements.push(child),
            "Annotations" => {
                return Err(Error::new(
                    file,
                    Some(child.line),
                    context,
                    "<Annotations> inside a <ScalarVariable> is rejected by the Rust `fmi` crate's \
                     parser; expected only the type element",
                ))
            }
            other => {
                return Err(Error::new(
                    file,
                    Some(child.line),
                    context,
                    format!(
                        "unexpected element <{other}>; expected one of Real, Integer, Boolean, String, Enumeration"
                    ),
                ))
            }
        }
    }
    let [type_element] = type_elements.as_slice() else {
        return Err(a.error(format!(
            "expected exactly one type element (Real, Integer, Boolean, String or Enumeration), found {}",
            type_elements.len()
        )));
    };
    no_children(file, type_element, &context)?;
    let t = Attributes::new(file, type_element, context.clone());
    let value = match type_element.name.as_str() {
        "Real" => {
            t.only(&[
                "declaredType",
                "quantity",
                "unit",
                "displayUnit",
                "relativeQuantity",
                "min",
                "max",
                "nominal",
                "unbounded",
                "start",
                "derivative",
                "reinit",
            ])?;
            VariableValue::Real {
                declared_type: t.string("declaredType"),
                unit: t.string("unit"),
                display_unit: t.string("displayUnit"),
                min: t.f64("min")?,
                max: t.f64("max")?,
                nominal: t.f64("nominal")?,
                start: t.f64("start")?,
            }
        }
        "Integer" => {
            t.only(&["declaredType", "quantity", "min", "max", "start"])?;
            VariableValue::Integer {
                declared_type: t.string("declaredType"),
                min: t.i32("min")?,
                max: t.i32("max")?,
                start: t.i32("start")?,
            }
        }
        "Boolean" => {
            t.only(&["declaredType", "start"])?;
            VariableValue::Boolean {
                declared_type: t.string("declaredType"),
                start: t.bool("start")?,
            }
        }
        "String" => {
            t.only(&["declaredType", "start"])?;
            VariableValue::String {
                declared_type: t.string("declaredType"),
                start: t.string("start"),
            }
        }
        _ => {
            t.only(&["declaredType", "quantity", "min", "max", "start"])?;
            VariableValue::Enumeration {
                declared_type: t.required("declaredType")?,
                min: t.i32("min")?,
                max: t.i32("max")?,
                start: t.i32("start")?,
            }
        }
    };
    Ok(ScalarVariable {
        name,
        value_reference,
        description: a.string("description"),
        causality,
        variability,
        initial,
        value,
        line: element.line,
    })
}

fn parse_model_structure(file: &str, element: &Element) -> Result<ModelStructure, Error> {
    Attributes::new(file, element, "<ModelStructure>").only(&[])?;
    let mut structure = ModelStructure::default();
    for list in &element.children {
        let target = match list.name.as_str() {
            "Outputs" => &mut structure.outputs,
            "Derivatives" => &mut structure.derivatives,
            "InitialUnknowns" => &mut structure.initial_unknowns,
            other => {
                return Err(Error::new(
                    file,
                    Some(list.line),
                    "<ModelStructure>",
                    format!(
                        "unexpected element <{other}>; expected Outputs, Derivatives or InitialUnknowns"
                    ),
                ))
            }
        };
        let context = format!("<ModelStructure><{}>", list.name);
        Attributes::new(file, list, context.clone()).only(&[])?;
        expect_children_named(file, list, "Unknown")?;
        for unknown in &list.children {
            let a = Attributes::new(file, unknown, context.clone());
            a.only(&["index", "dependencies", "dependenciesKind"])?;
            no_children(file, unknown, &context)?;
            let index = a
                .parsed::<usize>("index", "a positive variable index")?
                .ok_or_else(|| a.error("missing attribute 'index' on <Unknown>"))?;
            let dependencies = match unknown.attribute("dependencies") {
                None => None,
                Some(list_text) => Some(
                    list_text
                        .split_whitespace()
                        .map(|entry| {
                            entry.parse::<usize>().map_err(|_| {
                                a.error(format!(
                                    "dependencies entry \"{entry}\" is not a variable index"
                                ))
                            })
                        })
                        .collect::<Result<Vec<_>, _>>()?,
                ),
            };
            target.push(Unknown {
                index,
                dependencies,
                line: unknown.line,
            });
        }
    }
    Ok(structure)
}

/// `a, b, c` for a message listing the valid attribute values.
fn xml_names<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names.collect::<Vec<_>>().join(", ")
}
