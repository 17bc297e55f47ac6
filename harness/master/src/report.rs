//! A small document model rendered to Markdown and to self-contained HTML (images referenced by
//! relative path next to the report).

use std::fmt::Write as _;

#[derive(Debug, Clone)]
pub enum Block {
    Heading(u8, String),
    Paragraph(String),
    List(Vec<String>),
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    /// Relative path and caption.
    Image(String, String),
    Code(String),
}

#[derive(Debug, Clone, Default)]
pub struct Document {
    pub blocks: Vec<Block>,
}

impl Document {
    pub fn heading(&mut self, level: u8, text: impl Into<String>) {
        self.blocks.push(Block::Heading(level, text.into()));
    }
    pub fn paragraph(&mut self, text: impl Into<String>) {
        self.blocks.push(Block::Paragraph(text.into()));
    }
    pub fn list(&mut self, items: Vec<String>) {
        self.blocks.push(Block::List(items));
    }
    pub fn table(&mut self, header: Vec<String>, rows: Vec<Vec<String>>) {
        self.blocks.push(Block::Table { header, rows });
    }
    pub fn image(&mut self, path: impl Into<String>, caption: impl Into<String>) {
        self.blocks.push(Block::Image(path.into(), caption.into()));
    }
    pub fn code(&mut self, text: impl Into<String>) {
        self.blocks.push(Block::Code(text.into()));
    }

    pub fn to_markdown(&self) -> String {
        let mut md = String::new();
        for block in &self.blocks {
            match block {
                Block::Heading(level, text) => {
                    let _ = writeln!(md, "{} {text}\n", "#".repeat(*level as usize));
                }
                Block::Paragraph(text) => {
                    let _ = writeln!(md, "{text}\n");
                }
                Block::List(items) => {
                    for item in items {
                        let _ = writeln!(md, "- {item}");
                    }
                    md.push('\n');
                }
                Block::Table { header, rows } => {
                    let escape = |s: &String| s.replace('|', "\\|");
                    let folded = rows.len() > FOLDED_ROWS;
                    if folded {
                        let _ = writeln!(
                            md,
                            "<details><summary>{}</summary>\n",
                            fold_label(header, rows)
                        );
                    }
                    let _ = writeln!(
                        md,
                        "| {} |",
                        header.iter().map(escape).collect::<Vec<_>>().join(" | ")
                    );
                    let alignment: String = numeric_columns(header.len(), rows)
                        .iter()
                        .map(|&numeric| if numeric { "---:|" } else { ":---|" })
                        .collect();
                    let _ = writeln!(md, "|{alignment}");
                    for row in rows {
                        let _ = writeln!(
                            md,
                            "| {} |",
                            row.iter().map(escape).collect::<Vec<_>>().join(" | ")
                        );
                    }
                    md.push('\n');
                    if folded {
                        md += "</details>\n\n";
                    }
                }
                Block::Image(path, caption) => {
                    let _ = writeln!(md, "![{caption}]({path})\n\n*{caption}*\n");
                }
                Block::Code(text) => {
                    let _ = writeln!(md, "```\n{text}\n```\n");
                }
            }
        }
        md
    }

    pub fn to_html(&self, title: &str) -> String {
        let mut html = format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n\
             <style>body{{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;line-height:1.45;text-align:left}}\
             table{{border-collapse:collapse;margin:1em 0;font-size:0.9em;max-width:100%}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:left;vertical-align:top;overflow-wrap:anywhere}}\
             th{{background:#eee}}td.num,th.num{{text-align:right;overflow-wrap:normal;white-space:nowrap}}img{{max-width:100%;height:auto;border:1px solid #ddd}}\
             code{{overflow-wrap:anywhere}}details{{margin:1em 0}}summary{{cursor:pointer;color:#333}}\
             figure{{margin:1em 0}}figcaption{{font-style:italic;color:#444}}pre{{background:#f4f4f4;padding:0.8em;overflow-x:auto}}</style>\n\
             </head>\n<body>\n",
            escape(title)
        );
        for block in &self.blocks {
            match block {
                Block::Heading(level, text) => {
                    let _ = writeln!(html, "<h{level}>{}</h{level}>", inline(text));
                }
                Block::Paragraph(text) => {
                    let _ = writeln!(html, "<p>{}</p>", inline(text));
                }
                Block::List(items) => {
                    html += "<ul>\n";
                    for item in items {
                        let _ = writeln!(html, "<li>{}</li>", inline(item));
                    }
                    html += "</ul>\n";
                }
                Block::Table { header, rows } => {
                    let folded = rows.len() > FOLDED_ROWS;
                    if folded {
                        let _ = writeln!(
                            html,
                            "<details><summary>{}</summary>",
                            escape(&fold_label(header, rows))
                        );
                    }
                    let numeric = numeric_columns(header.len(), rows);
                    let class = |column: usize| {
                        if numeric.get(column).copied().unwrap_or(false) {
                            " class=\"num\""
                        } else {
                            ""
                        }
                    };
                    html += "<table>\n<tr>";
                    for (column, h) in header.iter().enumerate() {
                        let _ = write!(html, "<th{}>{}</th>", class(column), inline(h));
                    }
                    html += "</tr>\n";
                    for row in rows {
                        html += "<tr>";
                        for (column, cell) in row.iter().enumerate() {
                            let _ = write!(html, "<td{}>{}</td>", class(column), inline(cell));
                        }
                        html += "</tr>\n";
                    }
                    html += "</table>\n";
                    if folded {
                        html += "</details>\n";
                    }
                }
                Block::Image(path, caption) => {
                    let _ = writeln!(
                        html,
                        "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                        escape(path),
                        escape(caption),
                        inline(caption)
                    );
                }
                Block::Code(text) => {
                    let _ = writeln!(html, "<pre>{}</pre>", escape(text));
                }
            }
        }
        html += "</body>\n</html>\n";
        html
    }
}

/// Tables of more rows than this are folded (`<details>`), so the report's prose stays readable
/// on one screen and the numbers are one click away.
pub const FOLDED_ROWS: usize = 15;

/// The one line a folded table shows: its size and its columns.
fn fold_label(header: &[String], rows: &[Vec<String>]) -> String {
    format!(
        "Table of {} rows: {} (click to open)",
        rows.len(),
        header.join(" · ").replace("**", "").replace('`', "")
    )
}

/// Which columns hold numbers only (right-aligned, so digits line up); every other column, prose
/// above all, stays left-aligned. A column counts as numeric when each of its cells is empty, a
/// dash, or a number with at most a unit, a sign, ± or a bracketed interval, and one has a digit.
pub fn numeric_columns(columns: usize, rows: &[Vec<String>]) -> Vec<bool> {
    (0..columns)
        .map(|column| {
            let cells = || rows.iter().filter_map(|row| row.get(column));
            cells().all(|cell| is_numeric_cell(cell))
                && cells().any(|cell| cell.chars().any(|c| c.is_ascii_digit()))
        })
        .collect()
}

/// A number, an interval or a mean ± spread, perhaps bold, with at most a short unit.
pub fn is_numeric_cell(cell: &str) -> bool {
    let text = cell.replace("**", "");
    let text = text.trim();
    if text.is_empty() || text == "-" || text == "–" {
        return true;
    }
    if !text
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_digit() || "+-−[(.".contains(c))
    {
        return false;
    }
    // An exponent (1.2e-3) or a unit of a few letters (s, ms, deg, µs, m/s).
    text.chars().filter(|c| c.is_alphabetic()).count() <= 3
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Escape, then turn `code` and **bold** spans into HTML.
fn inline(text: &str) -> String {
    let escaped = escape(text);
    let mut out = String::new();
    let mut code = false;
    let mut bold = false;
    let mut chars = escaped.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '`' {
            out += if code { "</code>" } else { "<code>" };
            code = !code;
        } else if c == '*' && chars.peek() == Some(&'*') && !code {
            chars.next();
            out += if bold { "</b>" } else { "<b>" };
            bold = !bold;
        } else {
            out.push(c);
        }
    }
    if code {
        out += "</code>";
    }
    if bold {
        out += "</b>";
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(rows: usize) -> Document {
        let mut doc = Document::default();
        doc.table(
            vec!["estimator".into(), "RMSE (deg)".into(), "verdict".into()],
            (0..rows)
                .map(|i| {
                    vec![
                        format!("EKF_{i}"),
                        format!("{:.3} ± 0.01", i as f64 * 0.1),
                        "beats zero".into(),
                    ]
                })
                .collect(),
        );
        doc
    }

    #[test]
    fn numbers_are_right_aligned_and_prose_left_aligned() {
        let html = table(2).to_html("t");
        assert!(
            html.contains("<td>EKF_0</td><td class=\"num\">0.000 ± 0.01</td><td>beats zero</td>")
        );
        assert!(html.contains("td,th{border:1px solid #bbb;padding:3px 8px;text-align:left"));
        let md = table(2).to_markdown();
        assert!(md.contains("|:---|---:|:---|"), "{md}");
    }

    #[test]
    fn a_cell_is_numeric_when_it_is_a_number_with_at_most_a_short_unit() {
        for cell in [
            "0.123",
            "-1.5e-3",
            "**2.00**",
            "[0.5, 2.0]",
            "12.3 %",
            "4.2 µs",
            "-",
            "",
        ] {
            assert!(is_numeric_cell(cell), "{cell}");
        }
        for cell in ["yes", "model A", "0.5 below the band", "`EKF`"] {
            assert!(!is_numeric_cell(cell), "{cell}");
        }
    }

    #[test]
    fn long_tables_are_folded_short_ones_are_not() {
        assert!(!table(FOLDED_ROWS).to_html("t").contains("<details>"));
        let html = table(FOLDED_ROWS + 1).to_html("t");
        assert!(
            html.contains("<details><summary>Table of 16 rows: estimator · RMSE (deg) · verdict")
        );
        assert!(html.contains("</table>\n</details>"));
        let md = table(FOLDED_ROWS + 1).to_markdown();
        assert!(md.starts_with("<details><summary>Table of 16 rows"), "{md}");
        assert!(md.trim_end().ends_with("</details>"), "{md}");
    }
}
