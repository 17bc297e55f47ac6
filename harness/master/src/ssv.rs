//! SSP 1.0 parameter-value files (`.ssv`, SSP 1.0 Sect. 6, namespace
//! `http://ssp-standard.org/SSP1/SystemStructureParameterValues`) that a scenario's `[[fmu]]`
//! applies with `parameter_files = [...]`, and the enumeration items of a model description
//! that turn an `ssv:Enumeration value="item"` into the integer an FMU is set with.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use quick_xml::events::{BytesStart, Event};
use quick_xml::{Reader, XmlVersion};

/// The value of one `ssv:Parameter`, as typed in the file (SSP 1.0 Sect. 6.2: `ssv:Real`,
/// `ssv:Integer`, `ssv:Boolean`, `ssv:String`, `ssv:Enumeration`).
#[derive(Debug, Clone, PartialEq)]
pub enum SsvValue {
    Real(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    /// The name of an item of the variable's enumeration type.
    Enumeration(String),
}

/// One `ssv:Parameter` and the line it starts on.
#[derive(Debug, Clone, PartialEq)]
pub struct SsvParameter {
    pub name: String,
    pub value: SsvValue,
    pub line: usize,
}

/// A parameter-value file could not be used; the message names the file and the line.
#[derive(Debug, thiserror::Error)]
pub enum SsvError {
    #[error("parameter file {path}: cannot read the file: {cause}")]
    Unreadable {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("parameter file {path}, line {line}: {message}")]
    Invalid {
        path: PathBuf,
        line: usize,
        message: String,
    },
}

/// Read the `ssv:Parameter` entries of an SSP 1.0 parameter-value file, in file order.
pub fn read_parameter_file(path: &Path) -> Result<Vec<SsvParameter>, SsvError> {
    let text = std::fs::read_to_string(path).map_err(|cause| SsvError::Unreadable {
        path: path.to_path_buf(),
        cause,
    })?;
    parse_parameter_values(&text).map_err(|(line, message)| SsvError::Invalid {
        path: path.to_path_buf(),
        line,
        message,
    })
}

fn line_of(text: &str, byte: usize) -> usize {
    1 + text.as_bytes()[..byte.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

fn attribute(element: &BytesStart, key: &str) -> Result<Option<String>, String> {
    for attr in element.attributes() {
        let attr = attr.map_err(|e| e.to_string())?;
        if attr.key.local_name().into_inner() == key {
            let value = attr
                .normalized_value(XmlVersion::Implicit1_0)
                .map_err(|e| e.to_string())?;
            return Ok(Some(value.into_owned()));
        }
    }
    Ok(None)
}

fn typed_value(kind: &str, value: &str) -> Result<SsvValue, String> {
    let bad = |expected: &str| format!("value {value:?} is not {expected}");
    Ok(match kind {
        "Real" => SsvValue::Real(value.trim().parse().map_err(|_| bad("a number"))?),
        "Integer" => SsvValue::Integer(value.trim().parse().map_err(|_| bad("an integer"))?),
        "Boolean" => match value.trim() {
            "true" | "1" => SsvValue::Boolean(true),
            "false" | "0" => SsvValue::Boolean(false),
            _ => return Err(bad("true, false, 1 or 0 (xs:boolean)")),
        },
        "String" => SsvValue::String(value.to_string()),
        "Enumeration" => SsvValue::Enumeration(value.to_string()),
        other => {
            return Err(format!(
            "unknown value element ssv:{}; expected Real, Integer, Boolean, String or Enumeration",
            other
        ))
        }
    })
}

/// Parse the text of a parameter-value file; an error is `(line, message)`.
pub fn parse_parameter_values(text: &str) -> Result<Vec<SsvParameter>, (usize, String)> {
    let mut reader = Reader::from_str(text);
    let mut parameters = Vec::new();
    let mut open: Option<(String, usize)> = None;
    let mut saw_parameter_set = false;
    loop {
        let position = reader.buffer_position() as usize;
        let event = reader
            .read_event()
            .map_err(|e| (line_of(text, position), format!("not well-formed XML: {e}")))?;
        let line = line_of(text, position);
        let fail = |message: String| (line, message);
        match event {
            Event::Start(element) | Event::Empty(element) => {
                match element.local_name().into_inner() {
                    "ParameterSet" => saw_parameter_set = true,
                    "Parameter" => {
                        let name = attribute(&element, "name")
                            .map_err(fail)?
                            .ok_or_else(|| fail("ssv:Parameter without a name".into()))?;
                        open = Some((name, line));
                    }
                    kind @ ("Real" | "Integer" | "Boolean" | "String" | "Enumeration") => {
                        let Some((name, start)) = open.take() else {
                            continue;
                        };
                        let value = attribute(&element, "value")
                            .map_err(fail)?
                            .ok_or_else(|| fail(format!("parameter {name:?} has no value")))?;
                        let value = typed_value(kind, &value)
                            .map_err(|m| fail(format!("parameter {name:?}: {m}")))?;
                        parameters.push(SsvParameter {
                            name,
                            value,
                            line: start,
                        });
                    }
                    _ => {}
                }
            }
            Event::End(element) if element.local_name().into_inner() == "Parameter" => {
                if let Some((name, start)) = open.take() {
                    return Err((start, format!("parameter {name:?} has no value element")));
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if !saw_parameter_set {
        return Err((1, "expected an ssv:ParameterSet (SSP 1.0 Sect. 6)".into()));
    }
    Ok(parameters)
}

/// For each Enumeration variable of a model description, its type's items (name, value)
/// (FMI 2.0 Sect. 2.2.3: `TypeDefinitions/SimpleType/Enumeration/Item`, referenced by the
/// variable's `Enumeration declaredType`).
pub fn enumeration_items(model_description: &str) -> HashMap<String, Vec<(String, i32)>> {
    let mut types: HashMap<String, Vec<(String, i32)>> = HashMap::new();
    let mut declared: Vec<(String, String)> = Vec::new();
    let mut reader = Reader::from_str(model_description);
    let mut simple_type: Option<String> = None;
    let mut variable: Option<String> = None;
    while let Ok(event) = reader.read_event() {
        match event {
            Event::Start(e) | Event::Empty(e) => {
                let name = attribute(&e, "name").ok().flatten();
                match e.local_name().into_inner() {
                    "SimpleType" => simple_type = name,
                    "ScalarVariable" => variable = name,
                    "Item" => {
                        let value = attribute(&e, "value").ok().flatten();
                        let value = value.and_then(|v| v.trim().parse::<i32>().ok());
                        if let (Some(t), Some(item), Some(value)) = (&simple_type, name, value) {
                            types.entry(t.clone()).or_default().push((item, value));
                        }
                    }
                    "Enumeration" => {
                        let t = attribute(&e, "declaredType").ok().flatten();
                        if let (Some(v), Some(t)) = (&variable, t) {
                            declared.push((v.clone(), t));
                        }
                    }
                    _ => {}
                }
            }
            Event::End(e) if e.local_name().into_inner() == "SimpleType" => simple_type = None,
            Event::End(e) if e.local_name().into_inner() == "ScalarVariable" => variable = None,
            Event::Eof => break,
            _ => {}
        }
    }
    declared
        .into_iter()
        .filter_map(|(v, t)| Some((v, types.get(&t)?.clone())))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_value_kind_is_read_with_its_line() {
        let text = "<?xml version=\"1.0\"?>\n<ssv:ParameterSet xmlns:ssv=\"x\" version=\"1.0\" name=\"c\">\n<ssv:Parameters>\n\
            <ssv:Parameter name=\"model\"><ssv:Enumeration value=\"full_vehicle\"/></ssv:Parameter>\n\
            <ssv:Parameter name=\"abs\"><ssv:Boolean value=\"true\"/></ssv:Parameter>\n\
            <ssv:Parameter name=\"mass\"><ssv:Real value=\"1093.3\"/></ssv:Parameter>\n\
            <ssv:Parameter name=\"seed\"><ssv:Integer value=\"7\"/></ssv:Parameter>\n\
            </ssv:Parameters></ssv:ParameterSet>\n";
        let parameters = parse_parameter_values(text).unwrap();
        let values: Vec<_> = parameters
            .iter()
            .map(|p| (p.name.as_str(), &p.value, p.line))
            .collect();
        assert_eq!(
            values,
            [
                ("model", &SsvValue::Enumeration("full_vehicle".into()), 4),
                ("abs", &SsvValue::Boolean(true), 5),
                ("mass", &SsvValue::Real(1093.3), 6),
                ("seed", &SsvValue::Integer(7), 7),
            ]
        );
    }

    #[test]
    fn a_bad_number_is_refused_with_its_line_and_name() {
        let text = "<ssv:ParameterSet>\n<ssv:Parameters>\n\
            <ssv:Parameter name=\"mass\"><ssv:Real value=\"heavy\"/></ssv:Parameter>\n\
            </ssv:Parameters></ssv:ParameterSet>";
        let (line, message) = parse_parameter_values(text).unwrap_err();
        assert_eq!(line, 3);
        assert!(
            message.contains("\"mass\"") && message.contains("a number"),
            "{message}"
        );
    }

    #[test]
    fn enumeration_items_follow_the_declared_type() {
        let xml = r#"<fmiModelDescription><TypeDefinitions>
            <SimpleType name="M"><Enumeration><Item name="a" value="1"/><Item name="b" value="3"/></Enumeration></SimpleType>
            </TypeDefinitions><ModelVariables>
            <ScalarVariable name="model" valueReference="1"><Enumeration declaredType="M" start="1"/></ScalarVariable>
            <ScalarVariable name="x" valueReference="2"><Real/></ScalarVariable>
            </ModelVariables></fmiModelDescription>"#;
        let items = enumeration_items(xml);
        assert_eq!(items["model"], [("a".to_string(), 1), ("b".to_string(), 3)]);
        assert!(!items.contains_key("x"));
    }
}
