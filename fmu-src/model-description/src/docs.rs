//! The variable reference of an FMU, generated from its model description: one table per
//! causality (name, value reference, unit, range, default, meaning), the enumerations with their
//! items and, for the estimator, the bits of its `status` output.
//!
//! The same tables are written as Markdown (`docs/reference/<model>.md`, checked to be current by
//! this module's test) and as HTML (the FMU's `documentation/index.html`, written by packaging),
//! so the repository's reference and the one shipped inside the archive cannot differ.
//!
//! Refresh the Markdown after changing a model description:
//!
//! ```text
//! UPDATE_REFERENCE=1 cargo test --release -p model-description --lib docs
//! ```

use std::fmt::Write as _;

use crate::{Causality, ModelDescription, ScalarVariable, SimpleTypeKind, VariableValue};

/// One bit of the estimator's `status` output: value, short name, meaning.
///
/// The XML description of `status` is limited to two sentences, so the bits are listed here;
/// the test below checks that they add up to the `max` the XML declares, so a new bit cannot
/// be added to the FMU without a line here.
pub const STATUS_BITS: &[(u32, &str, &str)] = &[
    (1, "row skipped", "A measurement row was skipped: an input was NaN or infinite (missing), or model B used the wheel speeds because `vx_meas` was missing."),
    (2, "covariance repaired", "The covariance lost symmetry or positive definiteness and was repaired."),
    (4, "update skipped", "An update was skipped because its innovation covariance was singular."),
    (8, "state reset", "The state became non-finite and was reset to the last finite estimate, or model A was re-seeded from the measured speed after falling below `min_speed`."),
    (16, "weights reset", "The particle filter's weights degenerated and were reset."),
    (32, "low speed", "The speed is below `min_speed`: the filter holds, sideslip is the steering geometry's kinematic sideslip with a wide std, speeds and yaw rate are the measured ones."),
    (64, "input held", "An input other than a sensor was non-finite; its last finite value was used."),
    (128, "row gated", "A measurement row failed the chi-square gate or was physically implausible; gated inertial rows enter clipped to the gate's edge."),
    (256, "sensor re-admitted", "A sensor was locked out by the gate for `readmit_time`, or the gyro stayed 5 standard deviations off the estimate for 0.2 s (the filter had left the car), and the filter was re-seeded from the measurements."),
    (512, "initialising", "`start_from_measurements` waits for the first measured speed, or started from it in this step."),
    (1024, "input clamped", "An input outside its declared range was clamped into it (the setter answered fmi2Warning naming the variable)."),
    (2048, "wheel lifted", "Model B: the load transfer at the estimated ay exceeds an axle's static wheel load; the inner wheel's load is held at 0."),
    (4096, "adapting", "`adaptive_process_noise` has scaled Q up beyond what its window resolves, or the Luenberger observer's covariance is scaled to its innovations."),
    (8192, "inconsistent", "The innovations are larger than the reported covariance allows (the filter does not follow the car): the NIS summed over the last second is above its 99.9 % chi-square quantile; with `adaptive_process_noise` or the Luenberger observer, outside its 95 % band over their window."),
    (16384, "guarded", "`integrity_guard`: the sideslip estimate stayed outside what the kinematics and the car's own single-track data allow and was re-seeded there with a wide std."),
    (32768, "off the kinematics", "Over the last 0.5 s the estimated lateral velocity changed by more than 5° of sideslip (at the measured speed) away from what `ay − r vx` integrates to: the estimate has left the car's motion (a spin, or a car the model does not follow), and neither it nor its std is to be trusted."),
];

/// The variable reference of one FMU as a Markdown document.
pub fn reference_markdown(description: &ModelDescription, source: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# {}: variable reference\n", description.model_name);
    let _ = writeln!(
        out,
        "<!-- Generated from {source} by fmu-src/model-description/src/docs.rs; do not edit. \
         Refresh: UPDATE_REFERENCE=1 cargo test --release -p model-description --lib docs -->\n"
    );
    if let Some(summary) = &description.description {
        let _ = writeln!(out, "{}\n", summary.trim());
    }
    let _ = writeln!(
        out,
        "FMI {} Co-Simulation, model identifier `{}`, {} variables. Every value is SI on the \
         interface (display units only change how tools show it); axes follow ISO 8855: x \
         forward, y left, z up, angles and yaw rate positive to the left. Range is the declared \
         `[min, max]`; a value outside it is clamped with a warning.\n",
        description.fmi_version,
        description.co_simulation.model_identifier,
        description.variables.len()
    );
    for (title, causality, intro) in SECTIONS {
        let variables = with_causality(description, *causality);
        if variables.is_empty() {
            continue;
        }
        let _ = writeln!(out, "## {title} ({})\n\n{intro}\n", variables.len());
        out.push_str("| Name | VR | Unit | Range | Default | Meaning |\n");
        out.push_str("|:--|--:|:--|:--|:--|:--|\n");
        for variable in variables {
            let row = Row::of(description, variable);
            let _ = writeln!(
                out,
                "| `{}` | {} | {} | {} | {} | {} |",
                variable.name,
                variable.value_reference,
                md_cell(&row.unit),
                md_cell(&row.range),
                md_cell(&row.default),
                md_cell(&row.meaning)
            );
        }
        out.push('\n');
    }
    let enumerations = enumerations(description);
    if !enumerations.is_empty() {
        out.push_str("## Enumerations\n\n");
        for (name, meaning, items) in enumerations {
            let _ = writeln!(out, "### `{name}`\n\n{}\n", md_cell(meaning));
            out.push_str("| Value | Item | Meaning |\n|--:|:--|:--|\n");
            for (value, item, item_meaning) in items {
                let _ = writeln!(out, "| {value} | `{item}` | {} |", md_cell(item_meaning));
            }
            out.push('\n');
        }
    }
    if has_status(description) {
        out.push_str(
            "## Status bits\n\n`status` is the sum of the bits that applied during the last \
             doStep; 0 means all well.\n\n| Bit | Name | Meaning |\n|--:|:--|:--|\n",
        );
        for (bit, name, meaning) in STATUS_BITS {
            let _ = writeln!(out, "| {bit} | {name} | {} |", md_cell(meaning));
        }
        out.push('\n');
    }
    out
}

/// The same reference as an HTML fragment (headings from `<h2>` down), for the FMU's
/// `documentation/index.html`.
pub fn reference_html(description: &ModelDescription) -> String {
    let mut out = String::new();
    for (title, causality, intro) in SECTIONS {
        let variables = with_causality(description, *causality);
        if variables.is_empty() {
            continue;
        }
        let _ = writeln!(
            out,
            "<h2>{} ({})</h2>\n<p>{}</p>\n<table>\n<thead><tr><th>Name</th><th>VR</th>\
             <th>Unit</th><th>Range</th><th>Default</th><th>Meaning</th></tr></thead>\n<tbody>",
            html(title),
            variables.len(),
            html(intro)
        );
        for variable in variables {
            let row = Row::of(description, variable);
            let _ = writeln!(
                out,
                "<tr id=\"var-{name}\"><td><code>{name}</code></td><td>{}</td><td>{}</td>\
                 <td>{}</td><td>{}</td><td>{}</td></tr>",
                variable.value_reference,
                html(&row.unit),
                html(&row.range),
                html(&row.default),
                html(&row.meaning),
                name = html(&variable.name),
            );
        }
        out.push_str("</tbody>\n</table>\n");
    }
    let enumerations = enumerations(description);
    if !enumerations.is_empty() {
        out.push_str("<h2>Enumerations</h2>\n");
        for (name, meaning, items) in enumerations {
            let _ = writeln!(
                out,
                "<h3><code>{}</code></h3>\n<p>{}</p>\n<table>\n<thead><tr><th>Value</th>\
                 <th>Item</th><th>Meaning</th></tr></thead>\n<tbody>",
                html(name),
                html(meaning)
            );
            for (value, item, item_meaning) in items {
                let _ = writeln!(
                    out,
                    "<tr><td>{value}</td><td><code>{}</code></td><td>{}</td></tr>",
                    html(item),
                    html(item_meaning)
                );
            }
            out.push_str("</tbody>\n</table>\n");
        }
    }
    if has_status(description) {
        out.push_str(
            "<h2 id=\"status-bits\">Status bits</h2>\n<p><code>status</code> is the sum of the \
             bits that applied during the last doStep; 0 means all well.</p>\n<table>\n<thead>\
             <tr><th>Bit</th><th>Name</th><th>Meaning</th></tr></thead>\n<tbody>\n",
        );
        for (bit, name, meaning) in STATUS_BITS {
            let _ = writeln!(
                out,
                "<tr><td>{bit}</td><td>{}</td><td>{}</td></tr>",
                html(name),
                html(meaning)
            );
        }
        out.push_str("</tbody>\n</table>\n");
    }
    out
}

const SECTIONS: &[(&str, Causality, &str)] = &[
    (
        "Inputs",
        Causality::Input,
        "Set before each doStep; held over the communication step.",
    ),
    (
        "Outputs",
        Causality::Output,
        "Valid after initialisation and after every doStep.",
    ),
    (
        "Parameters",
        Causality::Parameter,
        "Fixed parameters are set before initialisation ends; tunable ones may change between steps.",
    ),
    (
        "Calculated parameters",
        Causality::CalculatedParameter,
        "Computed by the FMU during initialisation.",
    ),
    (
        "Local variables",
        Causality::Local,
        "Internal quantities exposed for inspection.",
    ),
];

fn with_causality(description: &ModelDescription, causality: Causality) -> Vec<&ScalarVariable> {
    description
        .variables
        .iter()
        .filter(|variable| variable.causality == causality)
        .collect()
}

fn has_status(description: &ModelDescription) -> bool {
    description.variable("status").is_some() && description.model_name == "VehicleStateEstimator"
}

type Enumeration<'a> = (&'a str, &'a str, Vec<(i32, &'a str, &'a str)>);

fn enumerations(description: &ModelDescription) -> Vec<Enumeration<'_>> {
    description
        .type_definitions
        .iter()
        .filter_map(|simple| match &simple.kind {
            SimpleTypeKind::Enumeration { items } => Some((
                simple.name.as_str(),
                simple.description.as_deref().unwrap_or(""),
                items
                    .iter()
                    .map(|item| {
                        (
                            item.value,
                            item.name.as_str(),
                            item.description.as_deref().unwrap_or(""),
                        )
                    })
                    .collect(),
            )),
            _ => None,
        })
        .collect()
}

/// The text cells of one variable's row.
struct Row {
    unit: String,
    range: String,
    default: String,
    meaning: String,
}

impl Row {
    fn of(description: &ModelDescription, variable: &ScalarVariable) -> Self {
        let declared = declared_type(variable).and_then(|name| description.simple_type(name));
        let (type_unit, type_min, type_max) = match declared.map(|simple| &simple.kind) {
            Some(SimpleTypeKind::Real { unit, min, max, .. }) => (unit.clone(), *min, *max),
            Some(SimpleTypeKind::Integer { min, max }) => {
                (None, min.map(f64::from), max.map(f64::from))
            }
            _ => (None, None, None),
        };
        let (unit, range, default) = match &variable.value {
            VariableValue::Real {
                unit,
                display_unit,
                min,
                max,
                start,
                ..
            } => {
                let unit = unit.clone().or(type_unit);
                let unit = match (unit, display_unit) {
                    (Some(unit), Some(display)) if *display != unit => {
                        format!("{unit} (shown in {display})")
                    }
                    (Some(unit), _) => unit,
                    (None, _) => String::new(),
                };
                (
                    unit,
                    range(min.or(type_min), max.or(type_max)),
                    start.map(real).unwrap_or_default(),
                )
            }
            VariableValue::Integer {
                min, max, start, ..
            } => (
                String::new(),
                range(
                    min.map(f64::from).or(type_min),
                    max.map(f64::from).or(type_max),
                ),
                start.map(|value| value.to_string()).unwrap_or_default(),
            ),
            VariableValue::Boolean { start, .. } => (
                String::new(),
                "false, true".into(),
                start.map(|value| value.to_string()).unwrap_or_default(),
            ),
            VariableValue::String { start, .. } => (
                String::new(),
                String::new(),
                start.clone().unwrap_or_default(),
            ),
            VariableValue::Enumeration {
                declared_type,
                start,
                ..
            } => {
                let items = enumerations(description)
                    .into_iter()
                    .find(|(name, _, _)| name == declared_type)
                    .map(|(_, _, items)| items)
                    .unwrap_or_default();
                let item_name = |value: i32| {
                    items
                        .iter()
                        .find(|(item_value, _, _)| *item_value == value)
                        .map(|(_, name, _)| format!("{value} ({name})"))
                        .unwrap_or_else(|| value.to_string())
                };
                (
                    String::new(),
                    format!("`{declared_type}`"),
                    start.map(item_name).unwrap_or_default(),
                )
            }
        };
        Row {
            unit,
            range,
            default,
            meaning: variable
                .description
                .as_deref()
                .unwrap_or("")
                .trim()
                .to_string(),
        }
    }
}

fn declared_type(variable: &ScalarVariable) -> Option<&str> {
    match &variable.value {
        VariableValue::Real { declared_type, .. }
        | VariableValue::Integer { declared_type, .. }
        | VariableValue::Boolean { declared_type, .. }
        | VariableValue::String { declared_type, .. } => declared_type.as_deref(),
        VariableValue::Enumeration { declared_type, .. } => Some(declared_type),
    }
}

/// A number as the XML would write it; NaN is how the FMU marks a sensor as missing.
fn real(value: f64) -> String {
    if value.is_nan() {
        "NaN (missing)".into()
    } else {
        format!("{value}")
    }
}

fn range(min: Option<f64>, max: Option<f64>) -> String {
    match (min, max) {
        (None, None) => String::new(),
        (min, max) => format!(
            "[{}, {}]",
            min.map(real).unwrap_or_else(|| "-inf".into()),
            max.map(real).unwrap_or_else(|| "inf".into())
        ),
    }
}

/// A table cell of Markdown: pipes and asterisks escaped (`*_std` names a group of variables,
/// not emphasis), line breaks folded.
fn md_cell(text: &str) -> String {
    text.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace('|', "\\|")
        .replace('*', "\\*")
}

fn html(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::{Path, PathBuf};

    const MODELS: &[&str] = &["VehicleStateEstimator", "ReferenceVehicle"];

    fn workspace() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    /// `docs/reference/<model>.md` is what this module generates from
    /// `modelDescription/<model>.xml`; with UPDATE_REFERENCE=1 the test writes it instead.
    #[test]
    fn the_reference_docs_are_current() {
        let mut stale = Vec::new();
        for model in MODELS {
            let source = format!("modelDescription/{model}.xml");
            let description = crate::parse_file(workspace().join(&source)).unwrap();
            let expected = reference_markdown(&description, &source);
            let path = workspace().join(format!("docs/reference/{model}.md"));
            if std::env::var_os("UPDATE_REFERENCE").is_some() {
                std::fs::write(&path, &expected).unwrap();
            } else if std::fs::read_to_string(&path).ok().as_deref() != Some(expected.as_str()) {
                stale.push(format!("docs/reference/{model}.md"));
            }
        }
        assert!(
            stale.is_empty(),
            "{stale:?} differ from what modelDescription/*.xml generates; refresh with \
             UPDATE_REFERENCE=1 cargo test --release -p model-description --lib docs"
        );
    }

    /// Every bit the XML allows in `status` has a line in STATUS_BITS, and no other.
    #[test]
    fn the_status_bits_cover_the_declared_range() {
        let description =
            crate::parse_file(workspace().join("modelDescription/VehicleStateEstimator.xml"))
                .unwrap();
        let Some(VariableValue::Integer { max: Some(max), .. }) =
            description.variable("status").map(|status| &status.value)
        else {
            panic!("VehicleStateEstimator has no Integer output `status` with a max");
        };
        let sum: u32 = STATUS_BITS.iter().map(|(bit, _, _)| bit).sum();
        assert_eq!(
            i64::from(sum),
            i64::from(*max),
            "STATUS_BITS sum to {sum}, the XML's status max is {max}: document the new bit"
        );
        for (index, (bit, _, _)) in STATUS_BITS.iter().enumerate() {
            assert_eq!(
                *bit,
                1 << index,
                "STATUS_BITS in order, one per power of two"
            );
        }
    }

    #[test]
    fn cells_escape_pipes_and_fold_lines() {
        assert_eq!(md_cell("a | b\n  c *_std"), "a \\| b c \\*_std");
        assert_eq!(html("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
        assert_eq!(range(Some(0.0), None), "[0, inf]");
        assert_eq!(real(f64::NAN), "NaN (missing)");
    }
}
