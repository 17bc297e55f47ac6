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
                    let _ = writeln!(
                        md,
                        "| {} |",
                        header.iter().map(escape).collect::<Vec<_>>().join(" | ")
                    );
                    let _ = writeln!(md, "|{}", "---|".repeat(header.len()));
                    for row in rows {
                        let _ = writeln!(
                            md,
                            "| {} |",
                            row.iter().map(escape).collect::<Vec<_>>().join(" | ")
                        );
                    }
                    md.push('\n');
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
             <style>body{{font-family:sans-serif;max-width:1300px;margin:2em auto;padding:0 1em;line-height:1.45}}\
             table{{border-collapse:collapse;margin:1em 0;font-size:0.9em}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}\
             th{{background:#eee}}td:first-child,th:first-child{{text-align:left}}img{{max-width:100%;border:1px solid #ddd}}\
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
                    html += "<table>\n<tr>";
                    for h in header {
                        let _ = write!(html, "<th>{}</th>", inline(h));
                    }
                    html += "</tr>\n";
                    for row in rows {
                        html += "<tr>";
                        for cell in row {
                            let _ = write!(html, "<td>{}</td>", inline(cell));
                        }
                        html += "</tr>\n";
                    }
                    html += "</table>\n";
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
