//! `documentation/index.html` of an FMU: hand-written prose about the models and filters, followed
//! by interface tables generated from the model description, so the tables cannot drift from the
//! variables the binary actually exposes.

use std::fmt::Write as _;

use quick_xml::escape::escape;

use crate::description::{ModelDescription, ScalarVariable};

fn text(value: &str) -> String {
    escape(value).into_owned()
}

fn optional(value: Option<&str>) -> String {
    value.map(text).unwrap_or_default()
}

/// How a variable's unit reads in the table: "rad (display: deg)".
fn unit_cell(description: &ModelDescription, variable: &ScalarVariable) -> String {
    match (
        description.effective_unit(variable),
        description.effective_display_unit(variable),
    ) {
        (Some(unit), Some(display)) if display != unit => {
            format!(
                "{} <small>(display {})</small>",
                text(&unit),
                text(&display)
            )
        }
        (Some(unit), _) => text(&unit),
        (None, _) => String::new(),
    }
}

/// The type cell; enumerations list their items so the page explains the numbers.
fn type_cell(description: &ModelDescription, variable: &ScalarVariable) -> String {
    let declared = variable
        .declared_type
        .as_deref()
        .and_then(|name| description.simple_type(name));
    match declared {
        Some(simple_type) if !simple_type.items.is_empty() => {
            let mut cell = format!(
                "{} <code>{}</code><ul>",
                variable.type_name,
                text(&simple_type.name)
            );
            for item in &simple_type.items {
                let _ = write!(
                    cell,
                    "<li>{} = <code>{}</code>{}</li>",
                    text(&item.value),
                    text(&item.name),
                    item.description
                        .as_deref()
                        .map(|d| format!(": {}", text(d)))
                        .unwrap_or_default()
                );
            }
            cell.push_str("</ul>");
            cell
        }
        Some(simple_type) => format!(
            "{} <code>{}</code>",
            variable.type_name,
            text(&simple_type.name)
        ),
        None => variable.type_name.clone(),
    }
}

fn variable_table(
    out: &mut String,
    description: &ModelDescription,
    title: &str,
    intro: &str,
    variables: &[&ScalarVariable],
) {
    if variables.is_empty() {
        return;
    }
    let _ = writeln!(out, "<h3>{} ({})</h3>", text(title), variables.len());
    let _ = writeln!(out, "<p>{}</p>", text(intro));
    out.push_str(
        "<table>\n<thead><tr><th>Name</th><th>VR</th><th>Type</th><th>Unit</th><th>Start</th>\
         <th>Min</th><th>Max</th><th>Variability</th><th>Description</th></tr></thead>\n<tbody>\n",
    );
    for variable in variables {
        let _ = writeln!(
            out,
            "<tr id=\"var-{}\"><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            text(&variable.name),
            text(&variable.name),
            variable.value_reference,
            type_cell(description, variable),
            unit_cell(description, variable),
            optional(variable.start.as_deref()),
            optional(variable.min.as_deref()),
            optional(variable.max.as_deref()),
            text(&variable.variability),
            optional(variable.description.as_deref()),
        );
    }
    out.push_str("</tbody>\n</table>\n");
}

const STYLE: &str =
    "body{font-family:sans-serif;max-width:75em;margin:2em auto;padding:0 1em;line-height:1.45}\
table{border-collapse:collapse;width:100%;margin-bottom:1.5em}\
th,td{border:1px solid #bbb;padding:.25em .5em;text-align:left;vertical-align:top}\
th{background:#eee}td ul{margin:.2em 0;padding-left:1.2em}code{font-size:95%}";

/// The complete page. `prose_html` is a trusted, hand-written HTML fragment (packaging/doc/<id>.html)
/// describing the models and filters; everything else comes from the model description.
pub fn index_html(description: &ModelDescription, prose_html: &str) -> String {
    let mut out = String::new();
    let title = &description.model_name;
    let _ = writeln!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{} — FMI 2.0 \
         Co-Simulation FMU</title>\n<style>{STYLE}</style>\n</head>\n<body>",
        text(title)
    );
    let _ = writeln!(out, "<h1>{}</h1>", text(title));
    if let Some(summary) = &description.description {
        let _ = writeln!(out, "<p><strong>{}</strong></p>", text(summary));
    }

    out.push_str("<h2>At a glance</h2>\n<table>\n<tbody>\n");
    let mut row = |key: &str, value: String| {
        let _ = writeln!(out, "<tr><th>{}</th><td>{value}</td></tr>", text(key));
    };
    row("FMI version", text(&description.fmi_version));
    row("Interface", "Co-Simulation".into());
    row(
        "Model identifier",
        format!("<code>{}</code>", text(&description.model_identifier)),
    );
    row(
        "Binary",
        format!(
            "<code>binaries/linux64/{}.so</code>",
            text(&description.model_identifier)
        ),
    );
    row("GUID", format!("<code>{}</code>", text(&description.guid)));
    if let Some(version) = &description.version {
        row("Version", text(version));
    }
    if let Some(tool) = &description.generation_tool {
        row("Generation tool", text(tool));
    }
    let capabilities: Vec<String> = description
        .co_simulation
        .iter()
        .filter(|(key, _)| key != "modelIdentifier")
        .map(|(key, value)| format!("<code>{}</code> = {}", text(key), text(value)))
        .collect();
    if !capabilities.is_empty() {
        row("Capabilities", capabilities.join("<br>"));
    }
    if !description.default_experiment.is_empty() {
        row(
            "Default experiment",
            description
                .default_experiment
                .iter()
                .map(|(key, value)| format!("<code>{}</code> = {}", text(key), text(value)))
                .collect::<Vec<_>>()
                .join(", "),
        );
    }
    out.push_str("</tbody>\n</table>\n");

    out.push_str("<h2>What it does</h2>\n");
    out.push_str(prose_html.trim());
    out.push('\n');

    out.push_str("<h2>Interface</h2>\n");
    out.push_str(
        "<p>Generated from <code>modelDescription.xml</code>. All values are SI on the interface; \
         display units only change how tools show them. VR is the value reference used with \
         <code>fmi2GetReal</code>/<code>fmi2SetReal</code> etc. Axes follow ISO 8855 (x forward, \
         y left, z up; yaw rate and steering angle positive to the left).</p>\n",
    );
    let group = |causality: &str| -> Vec<&ScalarVariable> {
        description
            .variables
            .iter()
            .filter(|variable| variable.causality == causality)
            .collect()
    };
    variable_table(
        &mut out,
        description,
        "Inputs",
        "Set before each fmi2DoStep; held constant over the communication step.",
        &group("input"),
    );
    variable_table(
        &mut out,
        description,
        "Outputs",
        "Valid after fmi2ExitInitializationMode and after every fmi2DoStep.",
        &group("output"),
    );
    variable_table(
        &mut out,
        description,
        "Parameters",
        "Fixed parameters are set between fmi2Instantiate and fmi2ExitInitializationMode; \
         tunable ones may also change between steps.",
        &group("parameter"),
    );
    variable_table(
        &mut out,
        description,
        "Calculated parameters",
        "Computed by the FMU during initialisation.",
        &group("calculatedParameter"),
    );
    variable_table(
        &mut out,
        description,
        "Local variables",
        "Internal quantities exposed for inspection.",
        &group("local"),
    );

    if !description.type_definitions.is_empty() {
        out.push_str(
            "<h3>Type definitions</h3>\n<table>\n<thead><tr><th>Name</th><th>Kind</th>\
                      <th>Unit</th><th>Items / description</th></tr></thead>\n<tbody>\n",
        );
        for simple_type in &description.type_definitions {
            let items: Vec<String> = simple_type
                .items
                .iter()
                .map(|item| {
                    format!(
                        "{} = <code>{}</code>{}",
                        text(&item.value),
                        text(&item.name),
                        item.description
                            .as_deref()
                            .map(|d| format!(": {}", text(d)))
                            .unwrap_or_default()
                    )
                })
                .collect();
            let detail = if items.is_empty() {
                optional(simple_type.description.as_deref())
            } else {
                items.join("<br>")
            };
            let _ = writeln!(
                out,
                "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{detail}</td></tr>",
                text(&simple_type.name),
                text(&simple_type.kind),
                optional(simple_type.unit.as_deref()),
            );
        }
        out.push_str("</tbody>\n</table>\n");
    }

    if !description.unit_definitions.is_empty() {
        out.push_str(
            "<h3>Units</h3>\n<table>\n<thead><tr><th>Unit</th><th>SI base</th>\
                      <th>Display units</th></tr></thead>\n<tbody>\n",
        );
        for unit in &description.unit_definitions {
            let base: Vec<String> = unit
                .base_unit
                .iter()
                .map(|(key, value)| format!("{}={}", text(key), text(value)))
                .collect();
            let displays: Vec<String> = unit
                .display_units
                .iter()
                .map(|display| {
                    format!(
                        "{} (factor {}, offset {})",
                        text(&display.name),
                        optional(display.factor.as_deref().or(Some("1"))),
                        optional(display.offset.as_deref().or(Some("0")))
                    )
                })
                .collect();
            let _ = writeln!(
                out,
                "<tr><td><code>{}</code></td><td>{}</td><td>{}</td></tr>",
                text(&unit.name),
                base.join(", "),
                displays.join("<br>")
            );
        }
        out.push_str("</tbody>\n</table>\n");
    }

    if !description.log_categories.is_empty() {
        out.push_str("<h3>Log categories</h3>\n<ul>\n");
        for (name, category_description) in &description.log_categories {
            let _ = writeln!(
                out,
                "<li><code>{}</code>{}</li>",
                text(name),
                category_description
                    .as_deref()
                    .map(|d| format!(": {}", text(d)))
                    .unwrap_or_default()
            );
        }
        out.push_str("</ul>\n");
    }

    out.push_str(
        "<h2>License</h2>\n<p>MIT OR Apache-2.0, at your option: see \
         <a href=\"licenses/LICENSE.txt\">licenses/LICENSE.txt</a>, \
         <a href=\"licenses/LICENSE-MIT.txt\">LICENSE-MIT.txt</a>, \
         <a href=\"licenses/LICENSE-APACHE.txt\">LICENSE-APACHE.txt</a> and the statically linked \
         crates in <a href=\"licenses/THIRD-PARTY.txt\">THIRD-PARTY.txt</a>.</p>\n",
    );
    out.push_str("</body>\n</html>\n");
    out
}
