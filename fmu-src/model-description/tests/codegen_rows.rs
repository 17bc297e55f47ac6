//! The generated `variable_row` look-up names, for every variable, its row in the generated
//! `VARIABLES` table (sorted by base type, then value reference): through a direct `u16` table
//! where the value references are dense, through a `match` where they are sparse.

use std::collections::BTreeMap;

use model_description::{generate_rust, parse_file, parse_str, BaseType, ModelDescription};

fn path(model: &str) -> String {
    format!(
        "{}/../../modelDescription/{model}.xml",
        env!("CARGO_MANIFEST_DIR")
    )
}

const TYPES: [(BaseType, &str); 3] = [
    (BaseType::Real, "Real"),
    (BaseType::Integer, "Integer"),
    (BaseType::Boolean, "Boolean"),
];

fn rank(base: BaseType) -> u8 {
    match base {
        BaseType::Real => 0,
        BaseType::Integer => 1,
        BaseType::Boolean => 2,
        BaseType::String => 3,
    }
}

/// (value reference -> row) of one base type, derived from the description independently of
/// the generator: the rows of the table sorted by (base type, value reference).
fn expected_rows(description: &ModelDescription, base: BaseType) -> BTreeMap<u32, usize> {
    let mut sorted: Vec<_> = description.variables.iter().collect();
    sorted.sort_by_key(|v| (rank(v.base_type()), v.value_reference));
    sorted
        .iter()
        .enumerate()
        .filter(|(_, v)| v.base_type() == base)
        .map(|(row, v)| (v.value_reference, row))
        .collect()
}

/// The non-empty cells of the generated `<TYPE>_ROWS` table, if there is one.
fn dense_rows(code: &str, name: &str) -> Option<BTreeMap<u32, usize>> {
    let start = code.find(&format!(
        "static {}_ROWS: [u16; ",
        name.to_ascii_uppercase()
    ))?;
    let length: usize = code[start..]
        .split(['[', ';', ']'])
        .nth(2)?
        .trim()
        .parse()
        .ok()?;
    let body = &code[start..];
    let open = body.find("\n    [")? + "\n    [".len();
    let close = open + body[open..].find(']')?;
    let cells: Vec<&str> = body[open..close].split(", ").collect();
    assert_eq!(cells.len(), length, "{name}: table length");
    Some(
        cells
            .iter()
            .enumerate()
            .filter(|(_, cell)| **cell != "NO")
            .map(|(vr, cell)| (vr as u32, cell.parse().expect("a row number")))
            .collect(),
    )
}

/// The arms of the generated `ValueType::<name> => match value_reference { … }`, if there is one.
fn matched_rows(code: &str, name: &str) -> Option<BTreeMap<u32, usize>> {
    let head = format!("::fmi_export::ValueType::{name} => match value_reference {{\n");
    let start = code.find(&head)? + head.len();
    let end = start + code[start..].find("_ => None")?;
    Some(
        code[start..end]
            .lines()
            .filter_map(|line| {
                let (vr, row) = line.trim().split_once(" => Some(")?;
                Some((vr.parse().ok()?, row.trim_end_matches("),").parse().ok()?))
            })
            .collect(),
    )
}

#[test]
fn the_project_descriptions_get_a_direct_table_with_the_right_rows() {
    for model in ["ReferenceVehicle", "VehicleStateEstimator"] {
        let description = parse_file(path(model)).unwrap();
        let code = generate_rust(&description, model).unwrap();
        assert!(code.contains("fn variable_row("), "{model}");
        for (base, name) in TYPES {
            let expected = expected_rows(&description, base);
            if expected.is_empty() {
                assert!(dense_rows(&code, name).is_none(), "{model} {name}");
                assert!(matched_rows(&code, name).is_none(), "{model} {name}");
                continue;
            }
            let rows = dense_rows(&code, name)
                .unwrap_or_else(|| panic!("{model}: no direct table for {name}"));
            assert_eq!(rows, expected, "{model} {name}");
        }
    }
}

#[test]
fn sparse_value_references_get_a_match_with_the_right_rows() {
    // Any u32 is a valid value reference; a table up to 4e9 would be absurd.
    let text = std::fs::read_to_string(path("ReferenceVehicle"))
        .unwrap()
        .replacen("valueReference=\"229\"", "valueReference=\"4000000000\"", 1);
    let description = parse_str(&text, "sparse.xml").unwrap();
    let code = generate_rust(&description, "sparse.xml").unwrap();
    assert!(dense_rows(&code, "Real").is_none());
    let rows = matched_rows(&code, "Real").expect("a match for the Real references");
    assert_eq!(rows, expected_rows(&description, BaseType::Real));
    assert!(rows.contains_key(&4_000_000_000));
    // The other types stay dense.
    assert_eq!(
        dense_rows(&code, "Integer").expect("Integer table"),
        expected_rows(&description, BaseType::Integer)
    );
}
