//! Loading an FMI 2.0 Co-Simulation FMU safely.
//!
//! The `fmi` crate's own `import::from_path` extracts every archive entry into a system temporary
//! folder without looking at the entry names. The harness therefore opens the archive itself,
//! refuses what it must not run (not a zip, no `modelDescription.xml`, an entry that would land
//! outside the extraction folder, a symbolic link, no Co-Simulation interface, no binary for this
//! platform), extracts into a temporary folder *inside the run's output folder* (nothing is
//! written elsewhere) and only then hands the folder to `fmi::fmi2::import::Fmi2Import`.

use std::collections::HashMap;
use std::fs;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::str::FromStr;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::schema::{Causality, Fmi2ModelDescription, ScalarVariableElement, Variability};
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
}

/// Limits of what an archive may unpack to (issue 15, point 6); the FMUs of this project are
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
    import: Fmi2Import,
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
            let written = std::io::copy(&mut (&mut entry).take(declared + 1), &mut out)
                .map_err(extract_error)?;
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
            import,
        })
    }

    pub fn variable(&self, name: &str) -> Option<&VariableInfo> {
        self.by_name.get(name).map(|&i| &self.variables[i])
    }

    /// The items (name, value) of Enumeration variable `name`'s declared type; empty when the
    /// variable is no Enumeration or its type declares none.
    pub fn enumeration_items(&self, name: &str) -> &[(String, i32)] {
        self.enumeration_items.get(name).map_or(&[], Vec::as_slice)
    }

    pub fn import(&self) -> &Fmi2Import {
        &self.import
    }

    pub fn model_description(&self) -> &Fmi2ModelDescription {
        self.import.model_description()
    }
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
