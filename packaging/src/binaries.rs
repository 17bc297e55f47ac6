//! Which binaries go into an FMU: the Linux x86-64 library built here, portable to glibc 2.17
//! (it loads on older distributions), and libraries for other platforms built elsewhere and
//! placed in a folder.
//!
//! **glibc 2.17.** A library linked on this machine requires the symbol versions of this
//! machine's glibc (`hypot@GLIBC_2.35`, `pthread_key_create@GLIBC_2.34`), so it does not load on
//! RHEL 8/9, Ubuntu 20.04 or Debian 11. `cargo zigbuild --target x86_64-unknown-linux-gnu.2.17`
//! links against the glibc 2.17 symbol set instead (zig ships the stubs), and the result loads
//! on every glibc from 2.17 (2012) on. zig comes from PyPI (`ziglang`) and cargo-zigbuild too
//! (its PyPI wheel), both pinned in `packaging/requirements-zig.txt` and installed into `.venv`
//! by `packaging/setup.sh`.
//!
//! **Other platforms** (FMI 2.0 section 2.3 names the folders): a release job on Windows, macOS
//! or Linux aarch64 builds the two cdylibs with `cargo build --release -p reference-vehicle -p
//! vehicle-state-estimator` and hands them to packaging as
//! `<folder>/<platform>/<modelIdentifier>.<dll|dylib|so>`, e.g. `win64/ReferenceVehicle.dll`;
//! `--binaries-from <folder>` places each in `binaries/<platform>/` of the archive.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use crate::archive::Entry;

/// The cargo-zigbuild target of the portable Linux libraries.
pub const GLIBC_2_17_TARGET: &str = "x86_64-unknown-linux-gnu.2.17";

/// The oldest glibc the shipped Linux libraries may need.
pub const MAX_GLIBC: (u32, u32) = (2, 17);

/// How the Linux x86-64 library is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LinuxBuild {
    /// `cargo zigbuild` for glibc 2.17, stripped: loads on every Linux of the last decade.
    #[default]
    Glibc217,
    /// A plain `cargo build` for this machine: needs this machine's glibc or newer.
    Host,
}

/// Platform folders packaging accepts from `--binaries-from`, with their library suffix: the
/// FMI 2.0 names, and `aarch64-linux` (FMI 2.0 has no 64-bit ARM folder; this is the name FMI
/// 3.0 gives it).
pub const OTHER_PLATFORMS: [(&str, &str); 6] = [
    ("win64", "dll"),
    ("win32", "dll"),
    ("darwin64", "dylib"),
    ("linux32", "so"),
    ("aarch64-linux", "so"),
    ("linux64", "so"),
];

/// The prebuilt libraries of `model_identifier` under `folder`: one entry per platform folder
/// present there. A folder of an unknown platform, or a platform folder without this model's
/// library, is an error: the release must be complete.
pub fn prebuilt_entries(folder: &Path, model_identifier: &str) -> Result<Vec<Entry>> {
    let mut platforms: Vec<PathBuf> = std::fs::read_dir(folder)
        .with_context(|| format!("reading the prebuilt binaries folder {}", folder.display()))?
        .map(|entry| entry.map(|e| e.path()))
        .collect::<std::io::Result<_>>()
        .with_context(|| format!("reading {}", folder.display()))?;
    platforms.sort();
    let mut entries = Vec::new();
    for platform_path in platforms.iter().filter(|p| p.is_dir()) {
        let platform = platform_path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default();
        let Some((_, suffix)) = OTHER_PLATFORMS.iter().find(|(name, _)| *name == platform) else {
            bail!(
                "{}: unknown platform folder {platform:?}; expected one of {}",
                folder.display(),
                OTHER_PLATFORMS.map(|(name, _)| name).join(", ")
            );
        };
        let file_name = format!("{model_identifier}.{suffix}");
        let library = platform_path.join(&file_name);
        let bytes = std::fs::read(&library).with_context(|| {
            format!(
                "{platform} has no {file_name}: expected {}",
                library.display()
            )
        })?;
        entries.push(Entry::executable(
            format!("binaries/{platform}/{file_name}"),
            bytes,
        ));
    }
    Ok(entries)
}

/// `cargo-zigbuild` and the PATH under which it finds zig (`python -m ziglang`): the project's
/// `.venv` (packaging/setup.sh), else whatever PATH holds.
pub fn zigbuild_command(workspace_root: &Path) -> (PathBuf, Option<std::ffi::OsString>) {
    let venv_bin = workspace_root.join(".venv").join("bin");
    let tool = venv_bin.join("cargo-zigbuild");
    if !tool.is_file() {
        return (PathBuf::from("cargo-zigbuild"), None);
    }
    let mut path = std::ffi::OsString::from(venv_bin.as_os_str());
    if let Some(existing) = std::env::var_os("PATH") {
        path.push(":");
        path.push(existing);
    }
    (tool, Some(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder removed when dropped, also when the test fails.
    struct Scratch(PathBuf);

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn scratch(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("packaging-bin-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    #[test]
    fn prebuilt_libraries_land_in_their_platform_folders() {
        let scratch = scratch("ok");
        let dir = &scratch.0;
        for (platform, file) in [("win64", "Model.dll"), ("darwin64", "Model.dylib")] {
            std::fs::create_dir_all(dir.join(platform)).unwrap();
            std::fs::write(dir.join(platform).join(file), platform).unwrap();
        }
        let entries = prebuilt_entries(dir, "Model").unwrap();
        let names: Vec<&str> = entries.iter().map(|e| e.path.as_str()).collect();
        assert_eq!(
            names,
            ["binaries/darwin64/Model.dylib", "binaries/win64/Model.dll"]
        );
    }

    #[test]
    fn an_unknown_platform_or_a_missing_library_is_an_error() {
        let scratch = scratch("bad");
        let dir = &scratch.0;
        std::fs::create_dir_all(dir.join("win64")).unwrap();
        let missing = prebuilt_entries(dir, "Model").unwrap_err().to_string();
        assert!(missing.contains("Model.dll"), "{missing}");
        std::fs::create_dir_all(dir.join("amiga")).unwrap();
        let unknown = prebuilt_entries(dir, "Model").unwrap_err().to_string();
        assert!(unknown.contains("amiga"), "{unknown}");
    }
}
