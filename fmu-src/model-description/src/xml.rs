//! A minimal element tree read with quick-xml: element names, attributes (unescaped), children
//! and the line of each start tag. Text content is not needed by modelDescription.xml.

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::Error;

#[derive(Debug)]
pub(crate) struct Element {
    pub name: String,
    pub attributes: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub line: usize,
}

impl Element {
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(key, _)| key == name)
            .map(|(_, value)| value.as_str())
    }
}

/// 1-based line number of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

fn element_from(
    start: &BytesStart<'_>,
    text: &str,
    offset: usize,
    file: &str,
) -> Result<Element, Error> {
    let line = line_of(text, offset);
    let name = start.name().as_ref().to_owned();
    let mut attributes = Vec::new();
    for attribute in start.attributes() {
        let attribute = attribute.map_err(|error| {
            Error::new(
                file,
                Some(line),
                format!("<{name}>"),
                format!("malformed attribute: {error}"),
            )
        })?;
        let key = attribute.key.as_ref().to_owned();
        let value = attribute
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|error| {
                Error::new(
                    file,
                    Some(line),
                    format!("<{name}> attribute '{key}'"),
                    format!("cannot unescape the value: {error}"),
                )
            })?
            .into_owned();
        attributes.push((key, value));
    }
    Ok(Element {
        name,
        attributes,
        children: Vec::new(),
        line,
    })
}

/// Parses the document and returns its root element.
pub(crate) fn parse_tree(text: &str, file: &str) -> Result<Element, Error> {
    let mut reader = Reader::from_str(text);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    loop {
        let offset = reader.buffer_position() as usize;
        let event = reader.read_event().map_err(|error| {
            Error::new(
                file,
                Some(line_of(text, reader.error_position() as usize)),
                "XML syntax",
                error.to_string(),
            )
        })?;
        // `buffer_position` before the event points at the whitespace preceding the tag; skip it
        // so the line is the tag's own.
        let tag_offset = offset + text[offset.min(text.len())..].len()
            - text[offset.min(text.len())..].trim_start().len();
        match event {
            Event::Start(start) => {
                stack.push(element_from(&start, text, tag_offset, file)?);
            }
            Event::Empty(start) => {
                let element = element_from(&start, text, tag_offset, file)?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(element),
                    None => root = Some(element),
                }
            }
            Event::End(_) => {
                // quick-xml checks that end tags match their start tags.
                let element = stack.pop().ok_or_else(|| {
                    Error::new(
                        file,
                        Some(line_of(text, tag_offset)),
                        "XML syntax",
                        "end tag without a start tag",
                    )
                })?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(element),
                    None => root = Some(element),
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(Error::new(
            file,
            Some(open.line),
            format!("<{}>", open.name),
            "the element is not closed before the end of the file",
        ));
    }
    root.ok_or_else(|| Error::new(file, None, "document", "no root element found"))
}
