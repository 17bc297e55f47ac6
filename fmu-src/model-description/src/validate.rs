//! The rules a model description must satisfy before it is compiled into an FMU or packaged.
//!
//! FMI 2.0 rules (FMI 2.0.4, section 2.2): `fmiVersion` is "2.0"; the modelIdentifier is a C
//! identifier; names are unique, value references unique per base type (enumerations share the
//! Integer space); causality/variability/initial combinations of the standard's table; `start`
//! present exactly where required (inputs, parameters, initial exact/approx) and absent for
//! `initial="calculated"`; `min <= start <= max` (a Real input may start at NaN: missing); only Real variables are continuous; declared
//! types and units exist; enumeration starts are item values; `<Outputs>` lists exactly the
//! outputs in variable order; `<InitialUnknowns>` lists exactly the outputs with initial approx or
//! calculated and the calculated parameters, in variable order; dependencies are valid, ascending
//! indices.
//!
//! Project rules (SPEC §2): Co-Simulation only; every variable has a non-empty
//! description; every Real variable declares a unit (directly or through its declared type);
//! log category names are unique; the default experiment is sensible.

use std::collections::{HashMap, HashSet};

use crate::{
    BaseType, Causality, Error, Initial, ModelDescription, ScalarVariable, SimpleTypeKind, Unknown,
    Variability, VariableValue,
};

/// Checks every rule listed in the module documentation; the first violation is returned.
pub fn validate(description: &ModelDescription, file: &str) -> Result<(), Error> {
    let document = |message: String| Error::new(file, None, "<fmiModelDescription>", message);
    if description.fmi_version != "2.0" {
        return Err(document(format!(
            "fmiVersion is \"{}\"; expected \"2.0\"",
            description.fmi_version
        )));
    }
    if description.guid.trim().is_empty() {
        return Err(document(
            "guid is empty; expected a GUID such as {…}".into(),
        ));
    }
    if description.model_name.trim().is_empty() {
        return Err(document("modelName is empty".into()));
    }
    let identifier = &description.co_simulation.model_identifier;
    let valid_identifier = identifier
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && identifier
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !valid_identifier {
        return Err(Error::new(
            file,
            None,
            "<CoSimulation>",
            format!("modelIdentifier \"{identifier}\" is not a C identifier (letters, digits, '_', not starting with a digit)"),
        ));
    }

    validate_units_and_types(description, file)?;

    let mut seen_categories = HashSet::new();
    for category in &description.log_categories {
        if !seen_categories.insert(category.name.as_str()) {
            return Err(Error::new(
                file,
                None,
                "<LogCategories>",
                format!(
                    "category '{}' appears twice; expected unique names",
                    category.name
                ),
            ));
        }
    }

    if let Some(experiment) = &description.default_experiment {
        let context = "<DefaultExperiment>";
        let start = experiment.start_time.unwrap_or(0.0);
        if let Some(stop) = experiment.stop_time {
            if stop.partial_cmp(&start) != Some(std::cmp::Ordering::Greater) {
                return Err(Error::new(
                    file,
                    None,
                    context,
                    format!("stopTime {stop} is not after startTime {start}"),
                ));
            }
        }
        for (name, value) in [
            ("stepSize", experiment.step_size),
            ("tolerance", experiment.tolerance),
        ] {
            if let Some(value) = value {
                if !(value > 0.0 && value.is_finite()) {
                    return Err(Error::new(
                        file,
                        None,
                        context,
                        format!("{name} is {value}; expected a positive number"),
                    ));
                }
            }
        }
    }

    let mut names = HashSet::new();
    let mut references: HashMap<(BaseType, u32), &str> = HashMap::new();
    for variable in &description.variables {
        if !names.insert(variable.name.as_str()) {
            return Err(variable_error(
                file,
                variable,
                "the name appears twice; expected unique variable names",
            ));
        }
        if let Some(other) = references.insert(
            (variable.base_type(), variable.value_reference),
            &variable.name,
        ) {
            return Err(variable_error(
                file,
                variable,
                format!(
                    "value reference {} is already used by {:?} variable '{other}'; expected unique value references per base type",
                    variable.value_reference,
                    variable.base_type()
                ),
            ));
        }
        validate_variable(description, file, variable)?;
    }

    validate_structure(description, file)
}

fn variable_error(file: &str, variable: &ScalarVariable, message: impl Into<String>) -> Error {
    Error::new(file, Some(variable.line), variable.label(), message)
}

fn validate_units_and_types(description: &ModelDescription, file: &str) -> Result<(), Error> {
    let mut unit_names = HashSet::new();
    for unit in &description.unit_definitions {
        let context = format!("unit '{}'", unit.name);
        if !unit_names.insert(unit.name.as_str()) {
            return Err(Error::new(file, None, context, "defined twice"));
        }
        let mut display_names = HashSet::new();
        for display in &unit.display_units {
            if !display_names.insert(display.name.as_str()) {
                return Err(Error::new(
                    file,
                    None,
                    context,
                    format!("display unit '{}' defined twice", display.name),
                ));
            }
            if display.factor == 0.0 || !display.factor.is_finite() {
                return Err(Error::new(
                    file,
                    None,
                    context,
                    format!(
                        "display unit '{}' has factor {}; expected a finite non-zero factor",
                        display.name, display.factor
                    ),
                ));
            }
        }
    }
    let mut type_names = HashSet::new();
    for simple in &description.type_definitions {
        let context = format!("simple type '{}'", simple.name);
        if !type_names.insert(simple.name.as_str()) {
            return Err(Error::new(file, None, context, "defined twice"));
        }
        match &simple.kind {
            SimpleTypeKind::Enumeration { items } => {
                if items.is_empty() {
                    return Err(Error::new(
                        file,
                        None,
                        context,
                        "the enumeration has no <Item>; expected at least one",
                    ));
                }
                let mut item_names = HashSet::new();
                let mut item_values = HashSet::new();
                for item in items {
                    if !item_names.insert(item.name.as_str()) || !item_values.insert(item.value) {
                        return Err(Error::new(
                            file,
                            None,
                            context,
                            format!(
                                "item '{}' = {} repeats a name or value; expected unique names and values",
                                item.name, item.value
                            ),
                        ));
                    }
                }
            }
            SimpleTypeKind::Real {
                unit,
                display_unit,
                min,
                max,
            } => {
                check_unit(description, unit.as_deref(), display_unit.as_deref())
                    .map_err(|message| Error::new(file, None, context.clone(), message))?;
                if let (Some(min), Some(max)) = (min, max) {
                    if min > max {
                        return Err(Error::new(
                            file,
                            None,
                            context,
                            format!("min {min} is greater than max {max}"),
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks that `unit` is defined and `display_unit` belongs to it.
fn check_unit(
    description: &ModelDescription,
    unit: Option<&str>,
    display_unit: Option<&str>,
) -> Result<(), String> {
    match (unit, display_unit) {
        (None, Some(display)) => Err(format!(
            "displayUnit '{display}' is given without a unit; expected unit=\"…\" too"
        )),
        (None, None) => Ok(()),
        (Some(unit_name), display) => {
            let unit = description
                .unit(unit_name)
                .ok_or_else(|| format!("unit '{unit_name}' is not defined in <UnitDefinitions>"))?;
            if let Some(display) = display {
                if !unit.display_units.iter().any(|d| d.name == display) {
                    return Err(format!(
                        "displayUnit '{display}' is not a <DisplayUnit> of unit '{unit_name}'"
                    ));
                }
            }
            Ok(())
        }
    }
}

fn validate_variable(
    description: &ModelDescription,
    file: &str,
    variable: &ScalarVariable,
) -> Result<(), Error> {
    let fail = |message: String| Err(variable_error(file, variable, message));
    if variable
        .description
        .as_deref()
        .is_none_or(|d| d.trim().is_empty())
    {
        return fail(
            "has no description; expected one that states meaning, unit and sign convention".into(),
        );
    }
    if variable.name.trim().is_empty() {
        return fail("has an empty name".into());
    }

    use Causality as C;
    use Variability as V;
    // FMI 2.0.4 section 2.2.7: the allowed causality/variability combinations.
    let combination_ok = match variable.causality {
        C::Parameter | C::CalculatedParameter => {
            matches!(variable.variability, V::Fixed | V::Tunable)
        }
        C::Input => matches!(variable.variability, V::Discrete | V::Continuous),
        C::Output => matches!(
            variable.variability,
            V::Constant | V::Discrete | V::Continuous
        ),
        C::Local => true,
        C::Independent => variable.variability == V::Continuous,
    };
    if !combination_ok {
        return fail(format!(
            "causality {:?} with variability {:?} is not allowed by FMI 2.0",
            variable.causality, variable.variability
        ));
    }
    if variable.variability == V::Continuous && variable.base_type() != BaseType::Real {
        return fail(format!(
            "variability continuous is only allowed for Real variables, this one is {:?}; expected discrete (or fixed/tunable for parameters)",
            variable.base_type()
        ));
    }

    // Allowed values of `initial` (FMI 2.0.4 table after section 2.2.7).
    if let Some(initial) = variable.initial {
        let allowed: &[Initial] = match (variable.causality, variable.variability) {
            (C::Input | C::Independent, _) => &[],
            (_, V::Constant) => &[Initial::Exact],
            (C::Parameter, _) => &[Initial::Exact],
            (C::CalculatedParameter, _) => &[Initial::Calculated, Initial::Approx],
            (C::Local, V::Fixed | V::Tunable) => &[Initial::Calculated, Initial::Approx],
            _ => &[Initial::Calculated, Initial::Exact, Initial::Approx],
        };
        if !allowed.contains(&initial) {
            return fail(format!(
                "initial {initial:?} is not allowed for causality {:?} and variability {:?}; allowed: {allowed:?}",
                variable.causality, variable.variability
            ));
        }
    }
    let needs_start = variable.causality == C::Input
        || matches!(
            variable.effective_initial(),
            Some(Initial::Exact | Initial::Approx)
        );
    let forbids_start = variable.causality == C::Independent
        || variable.effective_initial() == Some(Initial::Calculated);
    if needs_start && !variable.value.has_start() {
        return fail(format!(
            "has no start value; FMI 2.0 requires one for causality {:?} with initial {:?}",
            variable.causality,
            variable.effective_initial()
        ));
    }
    if forbids_start && variable.value.has_start() {
        return fail(
            "has a start value but initial is calculated (or it is the independent variable); expected no start"
                .into(),
        );
    }

    match &variable.value {
        VariableValue::Real {
            declared_type,
            unit,
            display_unit,
            min,
            max,
            nominal,
            start,
        } => {
            let declared = match declared_type {
                Some(name) => match description.simple_type(name) {
                    Some(simple) => match &simple.kind {
                        SimpleTypeKind::Real { unit, min, max, .. } => {
                            Some((unit.clone(), *min, *max))
                        }
                        _ => {
                            return fail(format!("declaredType '{name}' is not a Real simple type"))
                        }
                    },
                    None => {
                        return fail(format!(
                            "declaredType '{name}' is not defined in <TypeDefinitions>"
                        ))
                    }
                },
                None => None,
            };
            let unit = unit
                .clone()
                .or_else(|| declared.as_ref().and_then(|d| d.0.clone()));
            if unit.is_none() {
                return fail(
                    "Real variable without a unit; expected unit=\"…\" (use \"1\" for dimensionless quantities)"
                        .into(),
                );
            }
            check_unit(description, unit.as_deref(), display_unit.as_deref()).or_else(fail)?;
            let min = min.or(declared.as_ref().and_then(|d| d.1));
            let max = max.or(declared.as_ref().and_then(|d| d.2));
            for (name, value) in [("min", min), ("max", max), ("nominal", *nominal)] {
                if value.is_some_and(f64::is_nan) {
                    return fail(format!("{name} is NaN; expected a number"));
                }
            }
            // A Real input may start at NaN: the FMU's "not connected, treated as missing"
            // (an importer that leaves the input unset feeds NaN); any other NaN start is a typo.
            let missing_input = variable.causality == C::Input && start.is_some_and(f64::is_nan);
            let checked_start = if missing_input { None } else { *start };
            check_range(min, max, checked_start).or_else(fail)?;
            if let Some(nominal) = nominal {
                if *nominal <= 0.0 {
                    return fail(format!("nominal {nominal} is not positive"));
                }
            }
        }
        VariableValue::Integer {
            declared_type,
            min,
            max,
            start,
        } => {
            if let Some(name) = declared_type {
                match description.simple_type(name).map(|simple| &simple.kind) {
                    Some(SimpleTypeKind::Integer { .. }) => {}
                    _ => {
                        return fail(format!(
                        "declaredType '{name}' is not an Integer simple type of <TypeDefinitions>"
                    ))
                    }
                }
            }
            check_range(min.map(f64::from), max.map(f64::from), start.map(f64::from))
                .or_else(fail)?;
        }
        VariableValue::Boolean { declared_type, .. }
        | VariableValue::String { declared_type, .. } => {
            if let Some(name) = declared_type {
                let ok = matches!(
                    (
                        description.simple_type(name).map(|simple| &simple.kind),
                        variable.base_type()
                    ),
                    (Some(SimpleTypeKind::Boolean), BaseType::Boolean)
                        | (Some(SimpleTypeKind::String), BaseType::String)
                );
                if !ok {
                    return fail(format!(
                        "declaredType '{name}' is not a {:?} simple type of <TypeDefinitions>",
                        variable.base_type()
                    ));
                }
            }
        }
        VariableValue::Enumeration {
            declared_type,
            min,
            max,
            start,
        } => {
            let items = match description.simple_type(declared_type).map(|simple| &simple.kind) {
                Some(SimpleTypeKind::Enumeration { items }) => items,
                _ => {
                    return fail(format!(
                        "declaredType '{declared_type}' is not an Enumeration simple type of <TypeDefinitions>"
                    ))
                }
            };
            check_range(min.map(f64::from), max.map(f64::from), start.map(f64::from))
                .or_else(fail)?;
            if let Some(start) = start {
                if !items.iter().any(|item| item.value == *start) {
                    let values: Vec<String> = items
                        .iter()
                        .map(|item| format!("{} ({})", item.value, item.name))
                        .collect();
                    return fail(format!(
                        "start {start} is not an item of enumeration '{declared_type}'; expected one of {}",
                        values.join(", ")
                    ));
                }
            }
        }
    }
    Ok(())
}

fn check_range(min: Option<f64>, max: Option<f64>, start: Option<f64>) -> Result<(), String> {
    if let (Some(min), Some(max)) = (min, max) {
        if min > max {
            return Err(format!("min {min} is greater than max {max}"));
        }
    }
    if let Some(start) = start {
        if start.is_nan() {
            return Err("start is NaN; expected a number".into());
        }
        if let Some(min) = min {
            if start < min {
                return Err(format!("start {start} is below min {min}"));
            }
        }
        if let Some(max) = max {
            if start > max {
                return Err(format!("start {start} is above max {max}"));
            }
        }
    }
    Ok(())
}

fn validate_structure(description: &ModelDescription, file: &str) -> Result<(), Error> {
    let variables = &description.variables;
    let count = variables.len();
    let check_list = |list_name: &str,
                      list: &[Unknown],
                      expected: Vec<usize>|
     -> Result<(), Error> {
        let context = format!("<ModelStructure><{list_name}>");
        for unknown in list {
            if unknown.index == 0 || unknown.index > count {
                return Err(Error::new(
                    file,
                    Some(unknown.line),
                    context,
                    format!(
                        "index {} is outside the variable list; expected 1..={count}",
                        unknown.index
                    ),
                ));
            }
            if let Some(dependencies) = &unknown.dependencies {
                let mut previous = 0;
                for &dependency in dependencies {
                    if dependency == 0 || dependency > count {
                        return Err(Error::new(
                            file,
                            Some(unknown.line),
                            context,
                            format!(
                                "dependency {dependency} of index {} is outside the variable list; expected 1..={count}",
                                unknown.index
                            ),
                        ));
                    }
                    if dependency <= previous {
                        return Err(Error::new(
                            file,
                            Some(unknown.line),
                            context,
                            format!(
                                "dependencies of index {} are not strictly ascending",
                                unknown.index
                            ),
                        ));
                    }
                    previous = dependency;
                    let known = &variables[dependency - 1];
                    let is_known = known.causality == Causality::Input
                        || known.causality == Causality::Independent
                        || (matches!(known.causality, Causality::Parameter)
                            && list_name == "InitialUnknowns")
                        || (known.effective_initial() == Some(Initial::Exact)
                            && list_name == "InitialUnknowns");
                    if !is_known {
                        return Err(Error::new(
                            file,
                            Some(unknown.line),
                            context,
                            format!(
                                "index {} depends on '{}', which is not a known (input{})",
                                unknown.index,
                                known.name,
                                if list_name == "InitialUnknowns" {
                                    " or variable with initial exact"
                                } else {
                                    ""
                                }
                            ),
                        ));
                    }
                }
            }
        }
        let listed: Vec<usize> = list.iter().map(|unknown| unknown.index).collect();
        if listed != expected {
            let names = |indices: &[usize]| -> String {
                indices
                    .iter()
                    .map(|&i| {
                        variables
                            .get(i.wrapping_sub(1))
                            .map_or(format!("#{i}"), |v| format!("{i} ({})", v.name))
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let missing: Vec<usize> = expected
                .iter()
                .copied()
                .filter(|i| !listed.contains(i))
                .collect();
            let extra: Vec<usize> = listed
                .iter()
                .copied()
                .filter(|i| !expected.contains(i))
                .collect();
            return Err(Error::new(
                file,
                None,
                context,
                format!(
                    "expected exactly the indices [{}] in ascending order; missing: [{}], not expected: [{}]",
                    names(&expected),
                    names(&missing),
                    names(&extra)
                ),
            ));
        }
        Ok(())
    };

    let outputs: Vec<usize> = variables
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i + 1)
        .collect();
    check_list("Outputs", &description.model_structure.outputs, outputs)?;
    check_list(
        "Derivatives",
        &description.model_structure.derivatives,
        Vec::new(),
    )?;
    let initial_unknowns: Vec<usize> = variables
        .iter()
        .enumerate()
        .filter(|(_, v)| {
            (v.causality == Causality::Output
                && matches!(
                    v.effective_initial(),
                    Some(Initial::Approx | Initial::Calculated)
                ))
                || v.causality == Causality::CalculatedParameter
        })
        .map(|(i, _)| i + 1)
        .collect();
    check_list(
        "InitialUnknowns",
        &description.model_structure.initial_unknowns,
        initial_unknowns,
    )?;
    Ok(())
}
