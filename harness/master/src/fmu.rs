//! Loading an FMI 2.0 Co-Simulation FMU safely.
//!
//! The `fmi` crate's own `import::from_path` extracts every archive entry into a system temporary
//! folder without looking at the entry names. The harness therefore opens the archive itself,
//! refuses what it must not run (not a zip, no `modelDescription.xml`, an entry that would land
//! outside the extraction folder, a symbolic link, no Co-Simulation interface, no binary for this
//! platform), extracts into a temporary folder *inside the run's output folder* (nothing is
//! written elsewhere) and only then hands the folder to `fmi::fmi2::import::Fmi2Import`. A run
//! through FMI 3.0 also loads the FMU's FMI 3.0 archive the same way
//! ([`LoadedFmu::load_fmi3`], `fmi::fmi3::import::Fmi3Import`).

use std::collections::HashMap;
use std::fs;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::str::FromStr;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::schema::{Causality, Fmi2ModelDescription, ScalarVariableElement, Variability};
use fmi::fmi3::import::Fmi3Import;
use fmi::traits::FmiImport;

/// Why an FMU was refused. Every message names the archive.
#[derive(Debug, thiserror::Error)]
pub enum FmuError {
    #[error("FMU {path}: cannot read the file: {cause}")]
    Unreadable {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("FMU {path}: not a zip archive ({reason}); an .fmu must be a zip file")]
    NotZip { path: PathBuf, reason: String },
    #[error("FMU {path}: no modelDescription.xml at the top level of the archive")]
    NoModelDescription { path: PathBuf },
    #[error(
        "FMU {path}: archive entry {entry:?} would be written outside the extraction folder \
         (absolute path or '..'); refusing the archive"
    )]
    EscapingEntry { path: PathBuf, entry: String },
    #[error("FMU {path}: archive entry {entry:?} is a symbolic link; refusing the archive")]
    SymlinkEntry { path: PathBuf, entry: String },
    #[error("FMU {path}: not a regular file ({kind}); an .fmu must be a zip file")]
    NotAFile { path: PathBuf, kind: String },
    #[error("FMU {path}: {what}; refusing the archive (it may be a zip bomb)")]
    TooLarge { path: PathBuf, what: String },
    #[error("FMU {path}: modelDescription.xml is not valid FMI 2.0: {reason}")]
    BadModelDescription { path: PathBuf, reason: String },
    #[error("FMU {path}: fmiVersion is {found:?}; this master runs FMI 2.0 FMUs only")]
    WrongFmiVersion { path: PathBuf, found: String },
    #[error("FMU {path}: no <CoSimulation> element; this master runs Co-Simulation FMUs only")]
    NotCoSimulation { path: PathBuf },
    #[error(
        "FMU {path}: no binary for this platform ({os}/{arch}): expected archive entry {expected:?}"
    )]
    NoBinary {
        path: PathBuf,
        os: &'static str,
        arch: &'static str,
        expected: String,
    },
    #[error("FMU {path}: extracting into {folder}: {cause}")]
    Extract {
        path: PathBuf,
        folder: PathBuf,
        cause: std::io::Error,
    },
    #[error("FMU {path}: the fmi crate refused the extracted FMU: {reason}")]
    Import { path: PathBuf, reason: String },
    #[error("FMU {path}: not the FMI 3.0 archive of {fmi2}: {reason}")]
    NotItsFmi3Archive {
        path: PathBuf,
        fmi2: PathBuf,
        reason: String,
    },
}

/// Limits of what an archive may unpack to (a zip bomb must not fill the disk); the FMUs of this project are
/// about 3 MB in 10 entries, compressed 3:1.
pub mod limits {
    /// Entries of one archive.
    pub const MAX_ENTRIES: usize = 10_000;
    /// Uncompressed bytes of all entries together (2 GiB would fill a small disk).
    pub const MAX_TOTAL_BYTES: u64 = 1 << 30;
    /// Uncompressed bytes of modelDescription.xml.
    pub const MAX_MODEL_DESCRIPTION_BYTES: u64 = 64 << 20;
    /// Uncompressed / compressed size of one entry, for entries above [`RATIO_FREE_BYTES`].
    pub const MAX_RATIO: u64 = 200;
    /// Entries up to this size may compress arbitrarily well (a text file of zeros).
    pub const RATIO_FREE_BYTES: u64 = 1 << 20;
}

/// FMI 2.0 platform folder of this machine (FMI 2.0 standard, section 2.1).
pub fn platform_folder() -> Option<&'static str> {
    match (std::env::consts::OS, std::env::consts::ARCH) {
        ("linux", "x86_64") => Some("linux64"),
        ("linux", "x86") => Some("linux32"),
        // FMI 2.0 has no aarch64 folder; exporters (and the fmi crate) use linux64 there.
        ("linux", "aarch64") => Some("linux64"),
        ("windows", "x86_64") => Some("win64"),
        ("windows", "x86") => Some("win32"),
        ("macos", "x86_64") => Some("darwin64"),
        ("macos", "aarch64") => Some("darwin64"),
        _ => None,
    }
}

/// Data type of a scalar variable as the FMI 2.0 C API sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariableType {
    Real,
    Integer,
    Boolean,
    /// Set and read through fmi2SetInteger/fmi2GetInteger.
    Enumeration,
    String,
}

/// What the master needs to know about one variable.
#[derive(Debug, Clone, PartialEq)]
pub struct VariableInfo {
    pub name: String,
    pub value_reference: u32,
    pub var_type: VariableType,
    pub causality: Causality,
    pub variability: Variability,
    pub description: Option<String>,
}

impl VariableInfo {
    pub fn is_input(&self) -> bool {
        self.causality == Causality::Input
    }
    pub fn is_output(&self) -> bool {
        self.causality == Causality::Output
    }
    pub fn is_parameter(&self) -> bool {
        self.causality == Causality::Parameter
    }
}

/// An FMU archive checked and extracted, ready to instantiate. Owns the `Fmi2Import` (and with
/// it the extracted folder) — every instance created from it must be dropped before it.
pub struct LoadedFmu {
    pub path: PathBuf,
    pub model_name: String,
    pub model_identifier: String,
    pub guid: String,
    /// Variables in modelDescription order.
    pub variables: Vec<VariableInfo>,
    by_name: HashMap<String, usize>,
    /// Items (name, value) of each Enumeration variable's declared type, by variable name.
    enumeration_items: HashMap<String, Vec<(String, i32)>>,
    /// The FMU's FMI 3.0 archive, when a run asks for FMI 3 ([`LoadedFmu::load_fmi3`]).
    fmi3: Option<Fmi3Archive>,
    import: Fmi2Import,
}

/// The FMI 3.0 archive of an FMU, loaded beside its FMI 2.0 one: the plan (names, value
/// references, types) is made from the FMI 2.0 description, which [`LoadedFmu::load_fmi3`]
/// checks the FMI 3.0 one against variable by variable; the instances of an FMI 3 run are created
/// and driven through this import only.
pub struct Fmi3Archive {
    pub path: PathBuf,
    /// Value references of the Enumeration variables, sorted: FMI 3.0 reads and sets them as
    /// Int64, the other integers as Int32.
    pub enumerations: Vec<u32>,
    import: Fmi3Import,
}

impl Fmi3Archive {
    pub fn import(&self) -> &Fmi3Import {
        &self.import
    }
}

impl std::fmt::Debug for LoadedFmu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoadedFmu")
            .field("path", &self.path)
            .field("model_name", &self.model_name)
            .finish_non_exhaustive()
    }
}

impl LoadedFmu {
    /// Check `fmu_path` and extract it into a fresh temporary folder under `extract_root`
    /// (created when missing). The folder is removed when the `LoadedFmu` is dropped.
    pub fn load(fmu_path: &Path, extract_root: &Path) -> Result<LoadedFmu, FmuError> {
        let path = fmu_path.to_path_buf();
        let (mut archive, entry_names, xml) = open_checked(fmu_path)?;
        let description = Fmi2ModelDescription::from_str(&xml).map_err(|e| {
            // A 3.0 description fails the 2.0 schema; say so rather than print a parser error.
            if let Some(version) = fmi_version_attribute(&xml).filter(|v| !v.starts_with("2.")) {
                FmuError::WrongFmiVersion {
                    path: path.clone(),
                    found: version,
                }
            } else {
                FmuError::BadModelDescription {
                    path: path.clone(),
                    reason: e.to_string(),
                }
            }
        })?;
        if !description.fmi_version.starts_with("2.") {
            return Err(FmuError::WrongFmiVersion {
                path,
                found: description.fmi_version.clone(),
            });
        }
        let model_identifier = description
            .co_simulation
            .as_ref()
            .map(|cs| cs.model_identifier.clone())
            .ok_or_else(|| FmuError::NotCoSimulation { path: path.clone() })?;
        let expected_binary = match platform_folder() {
            Some(folder) => format!(
                "binaries/{folder}/{model_identifier}{}",
                std::env::consts::DLL_SUFFIX
            ),
            None => format!("binaries/<no FMI 2.0 platform folder>/{model_identifier}"),
        };
        if !entry_names.contains(&expected_binary) {
            return Err(FmuError::NoBinary {
                path,
                os: std::env::consts::OS,
                arch: std::env::consts::ARCH,
                expected: expected_binary,
            });
        }

        let variables = variable_table(&description);
        let enumeration_items = crate::ssv::enumeration_items(&xml);
        let by_name = variables
            .iter()
            .enumerate()
            .map(|(i, v)| (v.name.clone(), i))
            .collect();

        let temp_dir = extract_checked(&mut archive, &path, extract_root)?;
        let import = Fmi2Import::new(temp_dir, &xml).map_err(|e| FmuError::Import {
            path: path.clone(),
            reason: e.to_string(),
        })?;
        Ok(LoadedFmu {
            path,
            model_name: description.model_name.clone(),
            model_identifier,
            guid: description.guid.clone(),
            variables,
            by_name,
            enumeration_items,
            fmi3: None,
            import,
        })
    }

    /// Loads the FMU's FMI 3.0 archive `fmi3_path` (checked and extracted as [`LoadedFmu::load`]
    /// does) after checking that it is this FMU's: FMI version 3.0, the same model identifier,
    /// instantiation token = GUID, and every variable of the FMI 2.0 description with the same
    /// name, value reference and mapped type (FMI 3.0 section 2.4: Real -> Float64, Integer ->
    /// Int32, Enumeration, Boolean).
    pub fn load_fmi3(&mut self, fmi3_path: &Path, extract_root: &Path) -> Result<(), FmuError> {
        let path = fmi3_path.to_path_buf();
        let mismatch = |reason: String| FmuError::NotItsFmi3Archive {
            path: path.clone(),
            fmi2: self.path.clone(),
            reason,
        };
        let (mut archive, entry_names, xml) = open_checked(fmi3_path)?;
        let version = fmi_version_attribute(&xml).unwrap_or_default();
        if version != "3.0" {
            return Err(mismatch(format!(
                "fmiVersion is {version:?}; expected \"3.0\""
            )));
        }
        let declared = fmi3_declarations(&xml);
        let token = declared.instantiation_token.as_deref().unwrap_or("");
        if token != self.guid {
            return Err(mismatch(format!(
                "instantiationToken {token:?} is not the GUID {:?}",
                self.guid
            )));
        }
        if declared.model_identifier.as_deref() != Some(self.model_identifier.as_str()) {
            return Err(mismatch(format!(
                "modelIdentifier {:?}; expected {:?}",
                declared.model_identifier, self.model_identifier
            )));
        }
        for variable in &self.variables {
            let element = match variable.var_type {
                VariableType::Real => "Float64",
                VariableType::Integer => "Int32",
                VariableType::Enumeration => "Enumeration",
                VariableType::Boolean => "Boolean",
                VariableType::String => "String",
            };
            let found = declared
                .variables
                .iter()
                .find(|(_, name, _)| *name == variable.name);
            if found
                != Some(&(
                    element.to_string(),
                    variable.name.clone(),
                    variable.value_reference,
                ))
            {
                return Err(mismatch(format!(
                    "variable {:?} (valueReference {}, {element}) is declared as {found:?}",
                    variable.name, variable.value_reference
                )));
            }
        }
        let expected_binary = format!(
            "binaries/{}-{}/{}{}",
            std::env::consts::ARCH,
            std::env::consts::OS,
            self.model_identifier,
            std::env::consts::DLL_SUFFIX
        );
        if !entry_names.contains(&expected_binary) {
            return Err(FmuError::NoBinary {
                path,
                os: std::env::consts::OS,
                arch: std::env::consts::ARCH,
                expected: expected_binary,
            });
        }
        let temp_dir = extract_checked(&mut archive, &path, extract_root)?;
        let import =
            Fmi3Import::new(temp_dir, &for_the_fmi_crate(&xml)).map_err(|e| FmuError::Import {
                path: path.clone(),
                reason: e.to_string(),
            })?;
        let mut enumerations: Vec<u32> = (self.variables.iter())
            .filter(|v| v.var_type == VariableType::Enumeration)
            .map(|v| v.value_reference)
            .collect();
        enumerations.sort_unstable();
        self.fmi3 = Some(Fmi3Archive {
            path,
            enumerations,
            import,
        });
        Ok(())
    }

    /// The FMI 3.0 archive, when [`LoadedFmu::load_fmi3`] loaded one.
    pub fn fmi3(&self) -> Option<&Fmi3Archive> {
        self.fmi3.as_ref()
    }

    pub fn variable(&self, name: &str) -> Option<&VariableInfo> {
        self.by_name.get(name).map(|&i| &self.variables[i])
    }

    /// The items (name, value) of Enumeration variable `name`'s declared type; empty when the
    /// variable is no Enumeration or its type declares none.
    pub fn enumeration_items(&self, name: &str) -> &[(String, i32)] {
        self.enumeration_items.get(name).map_or(&[], Vec::as_slice)
    }

    /// The start value of Real variable `name`, when the model description declares one.
    pub fn real_start(&self, name: &str) -> Option<f64> {
        let variable = self.model_description().model_variable_by_name(name).ok()?;
        match &variable.elem {
            ScalarVariableElement::Real(real) => real.start,
            _ => None,
        }
    }

    /// The extracted modelDescription.xml, for what the `fmi` crate's schema does not keep
    /// (a variable's `unit`, say).
    pub fn model_description_path(&self) -> PathBuf {
        self.import.archive_path().join("modelDescription.xml")
    }

    pub fn import(&self) -> &Fmi2Import {
        &self.import
    }

    pub fn model_description(&self) -> &Fmi2ModelDescription {
        self.import.model_description()
    }
}

/// Opens an archive and checks it before anything is extracted: a regular file, a zip, every
/// entry inside the extraction folder and no link, sizes within [`limits`], a
/// `modelDescription.xml` of bounded size. Returns the archive, its entry names and the XML.
fn open_checked(
    fmu_path: &Path,
) -> Result<(zip::ZipArchive<fs::File>, Vec<String>, String), FmuError> {
    let path = fmu_path.to_path_buf();
    // A FIFO or a device would block or never end; only a regular file is opened.
    let metadata = fs::metadata(fmu_path).map_err(|cause| FmuError::Unreadable {
        path: path.clone(),
        cause,
    })?;
    if !metadata.is_file() {
        let kind = if metadata.is_dir() {
            "a folder"
        } else {
            "a FIFO, socket or device"
        };
        return Err(FmuError::NotAFile {
            path,
            kind: kind.into(),
        });
    }
    let file = fs::File::open(fmu_path).map_err(|cause| FmuError::Unreadable {
        path: path.clone(),
        cause,
    })?;
    let mut archive = zip::ZipArchive::new(file).map_err(|e| FmuError::NotZip {
        path: path.clone(),
        reason: e.to_string(),
    })?;

    // Pass 1: every entry must stay inside the extraction folder, none may be a link, and
    // what the entries declare must stay within the limits (pass 2 enforces them on the
    // bytes actually written, as declared sizes can lie).
    if archive.len() > limits::MAX_ENTRIES {
        return Err(FmuError::TooLarge {
            path,
            what: format!(
                "{} entries, more than {}",
                archive.len(),
                limits::MAX_ENTRIES
            ),
        });
    }
    let mut entry_names = Vec::with_capacity(archive.len());
    let mut declared_total = 0u64;
    for index in 0..archive.len() {
        let entry = archive.by_index(index).map_err(|e| FmuError::NotZip {
            path: path.clone(),
            reason: format!("entry {index}: {e}"),
        })?;
        let name = entry
            .name()
            .map(|n| n.to_string())
            .unwrap_or_else(|_| format!("<entry {index}: undecodable name>"));
        // An absolute name (which the zip crate would quietly make relative) or a drive
        // letter is as malformed as a '..' that leaves the folder.
        let absolute = name.starts_with('/')
            || name.starts_with('\\')
            || name.as_bytes().get(1) == Some(&b':');
        if absolute || entry.enclosed_name().is_none() {
            return Err(FmuError::EscapingEntry { path, entry: name });
        }
        if entry.is_symlink() {
            return Err(FmuError::SymlinkEntry { path, entry: name });
        }
        declared_total = declared_total.saturating_add(entry.size());
        if let Err(what) = check_entry_size(&name, entry.size(), entry.compressed_size())
            .and_then(|()| check_total(declared_total))
        {
            return Err(FmuError::TooLarge { path, what });
        }
        entry_names.push(name);
    }

    let xml = {
        let mut entry = archive
            .by_name("modelDescription.xml")
            .map_err(|_| FmuError::NoModelDescription { path: path.clone() })?;
        let mut xml = String::new();
        entry
            .by_ref()
            .take(limits::MAX_MODEL_DESCRIPTION_BYTES + 1)
            .read_to_string(&mut xml)
            .map_err(|e| FmuError::BadModelDescription {
                path: path.clone(),
                reason: format!("cannot read it as UTF-8 text: {e}"),
            })?;
        if xml.len() as u64 > limits::MAX_MODEL_DESCRIPTION_BYTES {
            return Err(FmuError::TooLarge {
                path,
                what: format!(
                    "modelDescription.xml is larger than {} bytes",
                    limits::MAX_MODEL_DESCRIPTION_BYTES
                ),
            });
        }
        xml
    };
    Ok((archive, entry_names, xml))
}

/// Extracts a checked archive into a fresh temporary folder under `extract_root`, enforcing
/// [`limits`] on the bytes actually written.
fn extract_checked(
    archive: &mut zip::ZipArchive<fs::File>,
    path: &Path,
    extract_root: &Path,
) -> Result<tempfile::TempDir, FmuError> {
    let path = path.to_path_buf();
    // Pass 2: extract into <extract_root>/fmu-XXXX/.
    fs::create_dir_all(extract_root).map_err(|cause| FmuError::Extract {
        path: path.clone(),
        folder: extract_root.to_path_buf(),
        cause,
    })?;
    let temp_dir = tempfile::Builder::new()
        .prefix("fmu-")
        .tempdir_in(extract_root)
        .map_err(|cause| FmuError::Extract {
            path: path.clone(),
            folder: extract_root.to_path_buf(),
            cause,
        })?;
    let extract_error = |cause: std::io::Error| FmuError::Extract {
        path: path.clone(),
        folder: temp_dir.path().to_path_buf(),
        cause,
    };
    let mut written_total = 0u64;
    for index in 0..archive.len() {
        let mut entry = archive
            .by_index(index)
            .map_err(|e| extract_error(std::io::Error::other(e)))?;
        let declared = entry.size();
        let Some(relative) = entry.enclosed_name() else {
            unreachable!("checked in pass 1")
        };
        let target = temp_dir.path().join(&relative);
        if entry.is_dir() {
            fs::create_dir_all(&target).map_err(extract_error)?;
            continue;
        }
        if let Some(parent) = target.parent() {
            fs::create_dir_all(parent).map_err(extract_error)?;
        }
        let mut out = fs::File::create(&target).map_err(extract_error)?;
        // Never more than the entry declared (checked against the limits in pass 1): one
        // byte more is read only to detect an entry that lied about its size.
        let written =
            std::io::copy(&mut (&mut entry).take(declared + 1), &mut out).map_err(extract_error)?;
        out.flush().map_err(extract_error)?;
        written_total = written_total.saturating_add(written);
        if written > declared || written_total > limits::MAX_TOTAL_BYTES {
            return Err(FmuError::TooLarge {
                path,
                what: format!(
                    "entry {:?} unpacks to more than the {declared} bytes it declares",
                    relative.display()
                ),
            });
        }
    }

    Ok(temp_dir)
}

/// One entry's declared size against [`limits::MAX_TOTAL_BYTES`] and [`limits::MAX_RATIO`].
fn check_entry_size(name: &str, size: u64, compressed: u64) -> Result<(), String> {
    if size > limits::RATIO_FREE_BYTES && size / compressed.max(1) > limits::MAX_RATIO {
        return Err(format!(
            "entry {name:?} unpacks {compressed} bytes to {size}, a ratio above {}",
            limits::MAX_RATIO
        ));
    }
    Ok(())
}

fn check_total(total: u64) -> Result<(), String> {
    if total > limits::MAX_TOTAL_BYTES {
        return Err(format!(
            "the entries unpack to more than {} bytes",
            limits::MAX_TOTAL_BYTES
        ));
    }
    Ok(())
}

/// The FMI 3.0 description as the `fmi` crate's parser takes it: fmi-schema 0.8 refuses the
/// standard's `unit`, `displayUnit` and `nominal` attributes of Float64 variables (its strict
/// mode knows no such attribute, though fmi3Variable.xsd declares them), and the import needs
/// none of them to instantiate and drive the FMU, so they are left out of the copy it parses;
/// the archive keeps the full description, which [`LoadedFmu::load_fmi3`] checks itself.
fn for_the_fmi_crate(xml: &str) -> String {
    let mut kept = String::with_capacity(xml.len());
    let mut rest = xml;
    while let Some(start) = rest.find("<Float64 ") {
        kept.push_str(&rest[..start]);
        let end = rest[start..].find('>').map_or(rest.len(), |e| start + e);
        let mut tag = rest[start..end].to_string();
        for attribute in ["unit", "displayUnit", "nominal"] {
            let key = format!(" {attribute}=\"");
            if let Some(at) = tag.find(&key) {
                let value_end = tag[at + key.len()..]
                    .find('"')
                    .map_or(tag.len(), |e| at + key.len() + e + 1);
                tag.replace_range(at..value_end, "");
            }
        }
        kept.push_str(&tag);
        rest = &rest[end..];
    }
    kept.push_str(rest);
    kept
}

/// What an FMI 3.0 model description declares, as far as [`LoadedFmu::load_fmi3`] checks it.
#[derive(Debug, Default)]
struct Fmi3Declarations {
    instantiation_token: Option<String>,
    model_identifier: Option<String>,
    /// (element, name, value reference) of each variable.
    variables: Vec<(String, String, u32)>,
}

fn fmi3_declarations(xml: &str) -> Fmi3Declarations {
    use quick_xml::events::Event;
    let mut declared = Fmi3Declarations::default();
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut in_variables = false;
    let text = |e: &quick_xml::events::BytesStart<'_>, key: &str| {
        e.try_get_attribute(key).ok().flatten().and_then(|a| {
            a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .ok()
                .map(|v| v.into_owned())
        })
    };
    loop {
        match reader.read_event() {
            Ok(Event::Start(e)) | Ok(Event::Empty(e)) => {
                let element = e.local_name().into_inner().to_string();
                match element.as_str() {
                    "fmiModelDescription" => {
                        declared.instantiation_token = text(&e, "instantiationToken")
                    }
                    "CoSimulation" => declared.model_identifier = text(&e, "modelIdentifier"),
                    "ModelVariables" => in_variables = true,
                    _ if in_variables => {
                        if let (Some(name), Some(vr)) = (
                            text(&e, "name"),
                            text(&e, "valueReference").and_then(|v| v.parse().ok()),
                        ) {
                            declared.variables.push((element, name, vr));
                        }
                    }
                    _ => {}
                }
            }
            Ok(Event::End(e)) if e.local_name().into_inner() == "ModelVariables" => {
                in_variables = false
            }
            Ok(Event::Eof) | Err(_) => break,
            _ => {}
        }
    }
    declared
}

fn fmi_version_attribute(xml: &str) -> Option<String> {
    let start = xml.find("fmiVersion")?;
    let rest = &xml[start..];
    let quote_start = rest.find(['"', '\''])?;
    let quote = rest.as_bytes()[quote_start] as char;
    let value = &rest[quote_start + 1..];
    let end = value.find(quote)?;
    Some(value[..end].to_string())
}

fn variable_table(description: &Fmi2ModelDescription) -> Vec<VariableInfo> {
    description
        .model_variables
        .variables
        .iter()
        .map(|v| VariableInfo {
            name: v.name.clone(),
            value_reference: v.value_reference,
            var_type: match v.elem {
                ScalarVariableElement::Real(_) => VariableType::Real,
                ScalarVariableElement::Integer(_) => VariableType::Integer,
                ScalarVariableElement::Boolean(_) => VariableType::Boolean,
                ScalarVariableElement::Enumeration => VariableType::Enumeration,
                ScalarVariableElement::String => VariableType::String,
            },
            causality: v.causality.clone(),
            // FMI 2.0: variability defaults to "continuous".
            variability: v.variability.unwrap_or(Variability::Continuous),
            description: v.description.clone(),
        })
        .collect()
}
