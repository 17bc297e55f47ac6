//! `documentation/index.html` of an FMU: hand-written prose about the models and filters, followed
//! by the variable reference that `model_description::docs` generates from the model description
//! (the same tables as the repository's `docs/reference/<model>.md`), so neither can drift from
//! the variables the binary actually exposes.

use std::fmt::Write as _;

use quick_xml::escape::escape;

use crate::description::ModelDescription;

fn text(value: &str) -> String {
    escape(value).into_owned()
}

fn optional(value: Option<&str>) -> String {
    value.map(text).unwrap_or_default()
}

/// The generated variable reference of the model description at `description.file`. Packaging
/// has parsed and validated that file just before, with the same parser; should it have changed
/// on disk since, the page says so instead of showing stale tables.
fn reference_tables(description: &ModelDescription) -> String {
    match model_description::parse_file(&description.file) {
        Ok(parsed) => model_description::docs::reference_html(&parsed),
        Err(error) => format!(
            "<p><strong>The variable reference could not be generated: {}</strong></p>\n",
            text(&error.to_string())
        ),
    }
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
        "<p>Generated from <code>modelDescription.xml</code> by the same code that writes the \
         repository's <code>docs/reference/</code>. VR is the value reference used with \
         <code>fmi2GetReal</code>/<code>fmi2SetReal</code> etc.</p>\n",
    );
    out.push_str(&reference_tables(description));

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
