//! Builds the two FMUs, each as an FMI 2.0 and an FMI 3.0 Co-Simulation archive around the same
//! library, and the SSP system that couples the FMI 2.0 ones.
//!
//! Archive names: `<modelIdentifier>.fmu` (FMI 2.0) and `<modelIdentifier>-fmi3.fmu` (FMI 3.0,
//! [`fmi3_archive_name`]). The FMI 3 model description is generated from the FMI 2.0 one and
//! the FMU's FMI 3 supplement (`model_description::fmi3`); both archives carry the same library,
//! icon, documentation and licences.
//!
//! Order of work, so that a bad input never leaves a half-updated output directory:
//! 1. read and check both `modelDescription/<Id>.xml` and the SSP connection plan (nothing built or
//!    written yet; every problem is reported with file and line);
//! 2. build the cdylibs in release mode and check their FMI exports;
//! 3. assemble all three archives in memory;
//! 4. stage every changed archive in a temporary file, then rename them all into place (each
//!    replacement atomic; a failure while writing replaces nothing); unchanged archives stay.

pub mod archive;
pub mod binaries;
pub mod cargo;
pub mod description;
pub mod documentation;
pub mod exports;
pub mod generation_time;
pub mod icon;
pub mod ssp;

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use archive::{Entry, WriteOutcome};
use description::{ModelDescription, Problems};

/// One FMU of the product: its model identifier (= XML file stem = cdylib name) and its crate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FmuSpec {
    pub model_identifier: &'static str,
    pub package: &'static str,
    /// What its `model.png` shows.
    pub icon: icon::Icon,
}

pub const REFERENCE_VEHICLE: FmuSpec = FmuSpec {
    model_identifier: "ReferenceVehicle",
    package: "reference-vehicle",
    icon: icon::Icon::ReferenceVehicle,
};

pub const VEHICLE_STATE_ESTIMATOR: FmuSpec = FmuSpec {
    model_identifier: "VehicleStateEstimator",
    package: "vehicle-state-estimator",
    icon: icon::Icon::Estimator,
};

pub const FMUS: [FmuSpec; 2] = [REFERENCE_VEHICLE, VEHICLE_STATE_ESTIMATOR];

pub const SSP_FILE_NAME: &str = "VehicleWithEstimator.ssp";

pub const GENERATION_TOOL: &str = concat!("packaging ", env!("CARGO_PKG_VERSION"));

/// A model description as read from disk: the parsed view and the exact bytes that get packaged.
#[derive(Debug, Clone)]
pub struct CheckedDescription {
    pub spec: FmuSpec,
    pub description: ModelDescription,
    pub xml: Vec<u8>,
}

pub fn description_path(workspace_root: &Path, spec: FmuSpec) -> PathBuf {
    workspace_root
        .join("modelDescription")
        .join(format!("{}.xml", spec.model_identifier))
}

/// Reads and validates both model descriptions (model-description crate, the parser the FMU build
/// uses) and the SSP connection plan; collects the problems of both files before failing.
pub fn check_descriptions(workspace_root: &Path) -> Result<Vec<CheckedDescription>> {
    let mut problems = Vec::new();
    let mut checked = Vec::new();
    for spec in FMUS {
        let path = description_path(workspace_root, spec);
        match description::load_and_check(&path, spec.model_identifier) {
            Ok(description) => {
                let xml =
                    std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
                checked.push(CheckedDescription {
                    spec,
                    description,
                    xml,
                });
            }
            Err(Problems(found)) => problems.extend(found),
        }
    }
    if !problems.is_empty() {
        bail!(
            "the model descriptions have {} problem(s); nothing was built or written:\n{}",
            problems.len(),
            Problems(problems)
        );
    }
    let (vehicle, estimator) = (&checked[0].description, &checked[1].description);
    ssp::plan(vehicle, estimator).context("the SSP connection plan")?;
    Ok(checked)
}

/// Hand-written prose about the models and filters: `packaging/doc/<Id>.html`.
pub fn prose_path(workspace_root: &Path, spec: FmuSpec) -> PathBuf {
    workspace_root
        .join("packaging")
        .join("doc")
        .join(format!("{}.html", spec.model_identifier))
}

/// License texts shipped in every FMU under `documentation/licenses/`.
pub fn license_files(workspace_root: &Path) -> Result<Vec<(String, Vec<u8>)>> {
    let directory = workspace_root.join("packaging").join("licenses");
    let mut files = Vec::new();
    for name in ["LICENSE.txt", "LICENSE-MIT.txt", "LICENSE-APACHE.txt"] {
        let path = directory.join(name);
        let contents =
            std::fs::read(&path).with_context(|| format!("reading license {}", path.display()))?;
        files.push((name.to_string(), contents));
    }
    Ok(files)
}

/// Everything one FMU archive contains, in the order of the FMI 2.0 standard's layout (§2.3);
/// the model description gets `generationDateAndTime = generation_time` (see
/// [`generation_time`]), the root the project's `model.png`.
pub fn fmu_entries(
    checked: &CheckedDescription,
    generation_time: &str,
    library: Vec<u8>,
    prose_html: &str,
    licenses: &[(String, Vec<u8>)],
    third_party: &[String],
) -> Result<Vec<Entry>> {
    let id = checked.spec.model_identifier;
    let xml = generation_time::stamp_model_description(&checked.xml, generation_time)
        .with_context(|| format!("stamping the {id} model description"))?;
    let mut entries = vec![
        Entry::file("modelDescription.xml", xml),
        Entry::file("model.png", icon::model_png(checked.spec.icon)?),
        Entry::executable(format!("binaries/linux64/{id}.so"), library),
        Entry::file(
            "documentation/index.html",
            documentation::index_html(&checked.description, prose_html),
        ),
    ];
    for (name, contents) in licenses {
        entries.push(Entry::file(
            format!("documentation/licenses/{name}"),
            contents.clone(),
        ));
    }
    let mut notice = format!(
        "Crates statically linked into binaries/linux64/{id}.so (name, version, license):\n\n"
    );
    for line in third_party {
        notice.push_str(line);
        notice.push('\n');
    }
    entries.push(Entry::file(
        "documentation/licenses/THIRD-PARTY.txt",
        notice,
    ));
    Ok(entries)
}

/// The file name of an FMU's FMI 3.0 archive, beside `<modelIdentifier>.fmu` (FMI 2.0).
pub fn fmi3_archive_name(model_identifier: &str) -> String {
    format!("{model_identifier}-fmi3.fmu")
}

/// The FMI 3.0 platform folder of an FMI 2.0 one (FMI 3.0 §2.5.1.4: `<arch>-<sys>`).
pub fn fmi3_platform(fmi2_platform: &str) -> &str {
    match fmi2_platform {
        "linux64" => "x86_64-linux",
        "linux32" => "x86-linux",
        "win64" => "x86_64-windows",
        "win32" => "x86-windows",
        "darwin64" => "x86_64-darwin",
        other => other,
    }
}

/// The FMI 3.0 archive's entries from the FMI 2.0 archive's: the generated FMI 3 model
/// description (stamped with `generation_time`) instead of the FMI 2.0 one, the icon as
/// `terminalsAndIcons/icon.png` as well, the libraries in the FMI 3.0 platform folders, the same
/// documentation and licences.
pub fn fmi3_entries(
    workspace_root: &Path,
    checked: &CheckedDescription,
    generation_time: &str,
    fmi2_entries: &[Entry],
) -> Result<Vec<Entry>> {
    let path = description_path(workspace_root, checked.spec);
    let text = std::str::from_utf8(&checked.xml)
        .with_context(|| format!("{}: not UTF-8", path.display()))?;
    let parsed = model_description::parse_str(text, &path.display().to_string())
        .map_err(|error| anyhow::anyhow!("{error}"))?;
    let supplement = model_description::fmi3::read_supplement(&path, &parsed)
        .map_err(|error| anyhow::anyhow!("{error}"))?;
    let xml =
        model_description::fmi3::model_description_xml(&parsed, &supplement, Some(generation_time));
    let mut entries = vec![Entry::file("modelDescription.xml", xml)];
    for entry in fmi2_entries {
        if entry.path == "modelDescription.xml" {
            continue;
        }
        if entry.path == "model.png" {
            entries.push(Entry::file(
                "terminalsAndIcons/icon.png",
                entry.contents.clone(),
            ));
        }
        let mut entry = entry.clone();
        if let Some(rest) = entry.path.strip_prefix("binaries/") {
            let (platform, file) = rest.split_once('/').unwrap_or((rest, ""));
            entry.path = format!("binaries/{}/{file}", fmi3_platform(platform));
        }
        entries.push(entry);
    }
    Ok(entries)
}

/// Where the ReferenceVehicle's car parameter-value files (.ssv) live,
/// relative to the workspace root; `vehicle_models::parameters::parameter_value_file` writes them.
pub const CAR_PARAMETER_DIR: &str = "fmu-src/reference-vehicle/cars";

/// A file shipped in the SSP's `resources/` folder beside the FMUs: its file name and bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Resource {
    pub file_name: String,
    pub contents: Vec<u8>,
}

/// Every `*.ssv` of [`CAR_PARAMETER_DIR`], sorted by file name so that the archive is the same
/// on every run whatever order the file system lists them in.
pub fn car_parameter_files(workspace_root: &Path) -> Result<Vec<Resource>> {
    let folder = workspace_root.join(CAR_PARAMETER_DIR);
    let listing = std::fs::read_dir(&folder)
        .with_context(|| format!("listing the car parameter files in {}", folder.display()))?;
    let mut files = Vec::new();
    for entry in listing {
        let path = entry
            .with_context(|| format!("listing {}", folder.display()))?
            .path();
        if path.extension().is_none_or(|e| e != "ssv") {
            continue;
        }
        let Some(file_name) = path.file_name().and_then(|n| n.to_str()) else {
            bail!("{}: the file name is not UTF-8", path.display());
        };
        let contents =
            std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
        files.push(Resource {
            file_name: file_name.to_string(),
            contents,
        });
    }
    files.sort_by(|a, b| a.file_name.cmp(&b.file_name));
    Ok(files)
}

/// The SSP archive: `SystemStructure.ssd` plus, under `resources/`, both FMUs, the driver inputs'
/// parameter set the SSD binds ([`ssp::DRIVER_FILE`]) and the `parameter_files` (SSP 1.0
/// parameter-value files a user binds with `ssd:ParameterBinding source="resources/<file>"`).
pub fn ssp_entries(
    vehicle: &ModelDescription,
    estimator: &ModelDescription,
    vehicle_fmu: &[u8],
    estimator_fmu: &[u8],
    parameter_files: &[Resource],
) -> Result<(Vec<Entry>, ssp::SystemPlan)> {
    let plan = ssp::plan(vehicle, estimator)?;
    let ssd = ssp::system_structure(vehicle, estimator, &plan, GENERATION_TOOL)?;
    let driver = ssp::driver_parameter_set(vehicle, GENERATION_TOOL)?;
    let mut entries = vec![
        Entry::file("SystemStructure.ssd", ssd),
        // The FMUs are zip files already; storing them avoids compressing twice.
        Entry::stored(
            format!("resources/{}.fmu", vehicle.model_identifier),
            vehicle_fmu.to_vec(),
        ),
        Entry::stored(
            format!("resources/{}.fmu", estimator.model_identifier),
            estimator_fmu.to_vec(),
        ),
        Entry::file(format!("resources/{}", ssp::DRIVER_FILE), driver),
    ];
    entries.extend(parameter_files.iter().map(|file| {
        Entry::file(
            format!("resources/{}", file.file_name),
            file.contents.clone(),
        )
    }));
    Ok((entries, plan))
}

/// What a run did, for the summary line of each archive.
#[derive(Debug, Clone)]
pub struct Written {
    pub path: PathBuf,
    pub bytes: usize,
    pub outcome: WriteOutcome,
}

/// Builds, assembles and writes everything. Nothing is written unless every check passed and all
/// three archives were assembled.
pub fn package(workspace: &cargo::Workspace) -> Result<(Vec<Written>, ssp::SystemPlan)> {
    let checked = check_descriptions(&workspace.root)?;
    let prose: Vec<String> = checked
        .iter()
        .map(|c| {
            let path = prose_path(&workspace.root, c.spec);
            std::fs::read_to_string(&path)
                .with_context(|| format!("reading the documentation prose {}", path.display()))
        })
        .collect::<Result<_>>()?;
    let licenses = license_files(&workspace.root)?;
    let car_files = car_parameter_files(&workspace.root)?;
    let generated =
        generation_time::iso8601_utc(generation_time::generation_epoch(&workspace.root)?);

    let packages: Vec<&str> = FMUS.iter().map(|spec| spec.package).collect();
    let names: Vec<&str> = FMUS.iter().map(|spec| spec.model_identifier).collect();
    let libraries = cargo::build_release_libraries(workspace, &packages, &names)?;
    for library in &libraries {
        exports::check_library(library)?;
    }

    let mut archives = Vec::new();
    let mut fmi3_archives = Vec::new();
    for ((checked, library_path), prose) in checked.iter().zip(&libraries).zip(&prose) {
        let library = std::fs::read(library_path)
            .with_context(|| format!("reading {}", library_path.display()))?;
        let third_party = cargo::linked_crates(workspace, checked.spec.package)?;
        let mut entries =
            fmu_entries(checked, &generated, library, prose, &licenses, &third_party)?;
        if let Some(folder) = &workspace.prebuilt_binaries {
            let prebuilt = binaries::prebuilt_entries(folder, checked.spec.model_identifier)?;
            // A prebuilt linux64 library replaces the one built here.
            entries.retain(|entry| !prebuilt.iter().any(|p| p.path == entry.path));
            entries.extend(prebuilt);
        }
        let bytes = archive::zip_bytes(&entries)
            .with_context(|| format!("assembling {}.fmu", checked.spec.model_identifier))?;
        archives.push((
            workspace
                .fmu_directory()
                .join(format!("{}.fmu", checked.spec.model_identifier)),
            bytes,
        ));
        let fmi3_name = fmi3_archive_name(checked.spec.model_identifier);
        let fmi3 = fmi3_entries(&workspace.root, checked, &generated, &entries)
            .with_context(|| format!("assembling {fmi3_name}"))?;
        fmi3_archives.push((
            workspace.fmu_directory().join(&fmi3_name),
            archive::zip_bytes(&fmi3).with_context(|| format!("assembling {fmi3_name}"))?,
        ));
    }
    let (ssp_entries, plan) = ssp_entries(
        &checked[0].description,
        &checked[1].description,
        &archives[0].1,
        &archives[1].1,
        &car_files,
    )?;
    let ssp_bytes = archive::zip_bytes(&ssp_entries).context("assembling the SSP")?;
    archives.push((workspace.fmu_directory().join(SSP_FILE_NAME), ssp_bytes));
    archives.extend(fmi3_archives);

    let outcomes = archive::write_all_if_changed(&archives).with_context(|| {
        format!(
            "writing the archives to {}",
            workspace.fmu_directory().display()
        )
    })?;
    let written = archives
        .iter()
        .zip(outcomes)
        .map(|((path, bytes), outcome)| Written {
            path: path.clone(),
            bytes: bytes.len(),
            outcome,
        })
        .collect();
    Ok((written, plan))
}
