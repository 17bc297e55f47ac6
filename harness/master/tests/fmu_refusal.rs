//! Malformed .fmu archives are refused with a clear message, and nothing is written outside the
//! extraction folder.

use std::path::{Path, PathBuf};

use fmi_master::fmu::{platform_folder, FmuError, LoadedFmu};

use crate::common::{write_zip, Scratch};

const DESCRIPTION: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Tiny" guid="{00000000-0000-0000-0000-000000000001}" variableNamingConvention="flat" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="Tiny" canHandleVariableCommunicationStepSize="true"/>
  <ModelVariables>
    <ScalarVariable name="u" valueReference="0" causality="input" variability="continuous"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="1" causality="output" variability="continuous" initial="calculated"><Real/></ScalarVariable>
    <ScalarVariable name="k" valueReference="2" causality="parameter" variability="fixed"><Integer start="1"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="2"/></Outputs><InitialUnknowns><Unknown index="2"/></InitialUnknowns></ModelStructure>
</fmiModelDescription>
"#;

fn binary_entry() -> String {
    format!(
        "binaries/{}/Tiny{}",
        platform_folder().unwrap(),
        std::env::consts::DLL_SUFFIX
    )
}

fn load(scratch: &Scratch, entries: &[(&str, &[u8])]) -> (FmuError, PathBuf) {
    let fmu = scratch.0.join("bad.fmu");
    write_zip(&fmu, entries);
    let out = scratch.0.join("out");
    match LoadedFmu::load(&fmu, &out) {
        Ok(_) => panic!("malformed FMU was accepted"),
        Err(e) => (e, out),
    }
}

#[test]
fn a_file_that_is_not_a_zip_is_refused() {
    let scratch = Scratch::new("notzip");
    let fmu = scratch.0.join("text.fmu");
    std::fs::write(&fmu, "this is not a zip archive").unwrap();
    let e = LoadedFmu::load(&fmu, &scratch.0.join("out")).unwrap_err();
    assert!(matches!(e, FmuError::NotZip { .. }), "{e:?}");
    assert!(
        e.to_string().contains("text.fmu") && e.to_string().contains("not a zip"),
        "{e}"
    );
}

#[test]
fn a_missing_file_is_named() {
    let scratch = Scratch::new("missing");
    let e = LoadedFmu::load(&scratch.0.join("nowhere.fmu"), &scratch.0).unwrap_err();
    assert!(
        matches!(e, FmuError::Unreadable { .. }) && e.to_string().contains("nowhere.fmu"),
        "{e}"
    );
}

#[test]
fn an_archive_without_model_description_is_refused() {
    let scratch = Scratch::new("nomd");
    let binary = binary_entry();
    let (e, _) = load(&scratch, &[(binary.as_str(), b"ELF")]);
    assert!(matches!(e, FmuError::NoModelDescription { .. }), "{e:?}");
    assert!(e.to_string().contains("modelDescription.xml"), "{e}");
}

#[test]
fn an_entry_escaping_the_folder_is_refused_and_nothing_is_written() {
    let scratch = Scratch::new("zipslip");
    let binary = binary_entry();
    let (e, out) = load(
        &scratch,
        &[
            ("modelDescription.xml", DESCRIPTION.as_bytes()),
            (binary.as_str(), b"ELF"),
            ("../../escaped.txt", b"gotcha"),
        ],
    );
    assert!(matches!(e, FmuError::EscapingEntry { .. }), "{e:?}");
    assert!(e.to_string().contains("../../escaped.txt"), "{e}");
    assert!(!scratch.0.join("escaped.txt").exists());
    assert!(!scratch.0.parent().unwrap().join("escaped.txt").exists());
    assert!(
        !out.exists(),
        "refused archive must not create the extraction folder"
    );
}

#[test]
fn an_absolute_entry_is_refused() {
    let scratch = Scratch::new("absolute");
    let binary = binary_entry();
    let (e, _) = load(
        &scratch,
        &[
            ("modelDescription.xml", DESCRIPTION.as_bytes()),
            (binary.as_str(), b"ELF"),
            ("/tmp/harness-absolute-entry.txt", b"gotcha"),
        ],
    );
    assert!(matches!(e, FmuError::EscapingEntry { .. }), "{e:?}");
    assert!(!Path::new("/tmp/harness-absolute-entry.txt").exists());
}

#[test]
fn an_archive_without_a_binary_for_this_platform_is_refused() {
    let scratch = Scratch::new("nobinary");
    let (e, _) = load(
        &scratch,
        &[
            ("modelDescription.xml", DESCRIPTION.as_bytes()),
            ("binaries/win64/Tiny.dll", b"MZ"),
        ],
    );
    assert!(matches!(e, FmuError::NoBinary { .. }), "{e:?}");
    assert!(e.to_string().contains(&binary_entry()), "{e}");
}

#[test]
fn a_model_exchange_only_fmu_is_refused() {
    let scratch = Scratch::new("me");
    let me = DESCRIPTION.replace(
        r#"<CoSimulation modelIdentifier="Tiny" canHandleVariableCommunicationStepSize="true"/>"#,
        r#"<ModelExchange modelIdentifier="Tiny"/>"#,
    );
    let binary = binary_entry();
    let (e, _) = load(
        &scratch,
        &[
            ("modelDescription.xml", me.as_bytes()),
            (binary.as_str(), b"ELF"),
        ],
    );
    assert!(matches!(e, FmuError::NotCoSimulation { .. }), "{e:?}");
}

#[test]
fn an_fmi3_description_is_refused_as_such() {
    let scratch = Scratch::new("fmi3");
    let v3 = DESCRIPTION.replace(r#"fmiVersion="2.0""#, r#"fmiVersion="3.0""#);
    let binary = binary_entry();
    let (e, _) = load(
        &scratch,
        &[
            ("modelDescription.xml", v3.as_bytes()),
            (binary.as_str(), b"ELF"),
        ],
    );
    assert!(matches!(e, FmuError::WrongFmiVersion { .. }), "{e:?}");
}

#[test]
fn garbage_xml_is_refused() {
    let scratch = Scratch::new("xml");
    let binary = binary_entry();
    let (e, _) = load(
        &scratch,
        &[
            ("modelDescription.xml", b"<not really xml"),
            (binary.as_str(), b"ELF"),
        ],
    );
    assert!(matches!(e, FmuError::BadModelDescription { .. }), "{e:?}");
}

#[test]
fn a_well_formed_archive_is_extracted_inside_the_given_folder_and_removed_on_drop() {
    let scratch = Scratch::new("good");
    let fmu = scratch.0.join("good.fmu");
    let binary = binary_entry();
    write_zip(
        &fmu,
        &[
            ("modelDescription.xml", DESCRIPTION.as_bytes()),
            (
                binary.as_str(),
                b"not a real library; loading happens at instantiation",
            ),
            ("resources/data.txt", b"x"),
        ],
    );
    let out = scratch.0.join("out");
    let loaded = LoadedFmu::load(&fmu, &out).unwrap();
    assert_eq!(loaded.model_identifier, "Tiny");
    assert_eq!(loaded.variables.len(), 3);
    assert!(loaded.variable("y").unwrap().is_output());
    assert!(loaded.variable("k").unwrap().is_parameter());
    let extracted: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
    assert_eq!(
        extracted.len(),
        1,
        "one extraction folder under the output folder"
    );
    let folder = extracted[0].as_ref().unwrap().path();
    assert!(folder.join("resources/data.txt").exists());
    drop(loaded);
    assert!(
        !folder.exists(),
        "extraction folder removed with the import"
    );
}
