//! Talking to cargo: where the workspace and its target directory are, building the cdylibs, and
//! listing the crates linked into them.
//!
//! Paths come from cargo itself (`cargo metadata`, the artefact messages of `cargo build`), so
//! `CARGO_TARGET_DIR`, `build.target-dir` in a cargo config and the default `<workspace>/target`
//! are all honoured without re-implementing cargo's rules.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context, Result};

use crate::binaries::{zigbuild_command, LinuxBuild, GLIBC_2_17_TARGET};

/// The cargo that runs us (`cargo run` sets CARGO), else the one on PATH.
fn cargo() -> Command {
    Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
}

/// Reads the JSON string starting at the opening quote `text[start]`; returns it and the index
/// after the closing quote. Enough JSON for cargo's machine-readable output, which is all we parse.
fn json_string(text: &str, start: usize) -> Option<(String, usize)> {
    let bytes = text.as_bytes();
    if bytes.get(start) != Some(&b'"') {
        return None;
    }
    let mut out = String::new();
    let mut chars = text[start + 1..].char_indices();
    while let Some((offset, c)) = chars.next() {
        match c {
            '"' => return Some((out, start + 1 + offset + 1)),
            '\\' => {
                let (_, escaped) = chars.next()?;
                match escaped {
                    '"' => out.push('"'),
                    '\\' => out.push('\\'),
                    '/' => out.push('/'),
                    'b' => out.push('\u{8}'),
                    'f' => out.push('\u{c}'),
                    'n' => out.push('\n'),
                    'r' => out.push('\r'),
                    't' => out.push('\t'),
                    'u' => {
                        let hex: String = (0..4)
                            .filter_map(|_| chars.next().map(|(_, h)| h))
                            .collect();
                        let code = u32::from_str_radix(&hex, 16).ok()?;
                        out.push(char::from_u32(code).unwrap_or('\u{fffd}'));
                    }
                    _ => return None,
                }
            }
            c => out.push(c),
        }
    }
    None
}

/// The string value of the first `"key":"…"` in a JSON text.
pub(crate) fn json_string_field(text: &str, key: &str) -> Option<String> {
    let needle = format!("\"{key}\":");
    let position = text.find(&needle)? + needle.len();
    let start = position + (text[position..].len() - text[position..].trim_start().len());
    json_string(text, start).map(|(value, _)| value)
}

/// The strings of the first `"key":["…","…"]` array in a JSON text.
pub(crate) fn json_string_array(text: &str, key: &str) -> Option<Vec<String>> {
    let needle = format!("\"{key}\":[");
    let mut position = text.find(&needle)? + needle.len();
    let mut values = Vec::new();
    loop {
        let rest = &text[position..];
        let skipped = rest.len() - rest.trim_start_matches([' ', ',', '\n', '\t']).len();
        position += skipped;
        match text.as_bytes().get(position) {
            Some(b']') => return Some(values),
            Some(b'"') => {
                let (value, next) = json_string(text, position)?;
                values.push(value);
                position = next;
            }
            _ => return None,
        }
    }
}

/// Which targets the release build of the FMU libraries compiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BuildScope {
    /// Only the two FMU packages (`cargo build --release -p … -p …`): the quickest build, and
    /// the FMUs exactly as users package them.
    #[default]
    FmuPackages,
    /// Every workspace target (`--workspace --all-targets`, the selection tests/run.sh builds:
    /// libraries, binaries, tests, benches, examples). Cargo unifies dependency features over the packages and
    /// targets of one invocation, so the two-package build compiles its dependencies with other
    /// features than the test build and a CI run would compile them twice; with this scope the
    /// FMU libraries are the test build's and a test run that follows compiles nothing again.
    Workspace,
}

impl BuildScope {
    /// The `cargo build` selection arguments of this scope.
    fn arguments(self, packages: &[&str]) -> Vec<String> {
        match self {
            BuildScope::FmuPackages => packages
                .iter()
                .flat_map(|package| ["-p".to_owned(), (*package).to_owned()])
                .collect(),
            BuildScope::Workspace => ["--workspace", "--all-targets"].map(String::from).to_vec(),
        }
    }
}

/// Where the workspace is and where cargo puts build output.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Workspace {
    pub root: PathBuf,
    pub target_directory: PathBuf,
    pub manifest: PathBuf,
    /// What the release build of the FMU libraries compiles (see [`BuildScope`]).
    pub build_scope: BuildScope,
    /// How the Linux x86-64 libraries are built (see [`LinuxBuild`]).
    pub linux_build: LinuxBuild,
    /// A folder of libraries for other platforms built elsewhere
    /// ([`crate::binaries::prebuilt_entries`]).
    pub prebuilt_binaries: Option<PathBuf>,
}

impl Workspace {
    /// Asks `cargo metadata` about the workspace whose root manifest is `manifest`.
    pub fn locate(manifest: &Path) -> Result<Workspace> {
        let output = cargo()
            .args([
                "metadata",
                "--format-version",
                "1",
                "--no-deps",
                "--manifest-path",
            ])
            .arg(manifest)
            .stderr(Stdio::inherit())
            .output()
            .context("running `cargo metadata` (is cargo on PATH?)")?;
        if !output.status.success() {
            bail!(
                "`cargo metadata --manifest-path {}` failed",
                manifest.display()
            );
        }
        let text = String::from_utf8_lossy(&output.stdout);
        let field = |key: &str| {
            json_string_field(&text, key)
                .map(PathBuf::from)
                .with_context(|| format!("`cargo metadata` printed no {key}"))
        };
        Ok(Workspace {
            root: field("workspace_root")?,
            target_directory: field("target_directory")?,
            manifest: manifest.to_path_buf(),
            build_scope: BuildScope::default(),
            linux_build: LinuxBuild::default(),
            prebuilt_binaries: None,
        })
    }

    /// Where the archives go: `<target dir>/fmu`.
    pub fn fmu_directory(&self) -> PathBuf {
        self.target_directory.join("fmu")
    }
}

/// Builds `packages` in release mode and returns the path of `lib<name>.so` for each requested
/// library name, as reported by cargo's artefact messages.
pub fn build_release_libraries(
    workspace: &Workspace,
    packages: &[&str],
    library_names: &[&str],
) -> Result<Vec<PathBuf>> {
    let (mut command, selection, shown) = match workspace.linux_build {
        LinuxBuild::Host => {
            let selection = workspace.build_scope.arguments(packages);
            let shown = format!("cargo build --release {}", selection.join(" "));
            let mut command = cargo();
            command.arg("build");
            (command, selection, shown)
        }
        // The portable build is of another target, so the workspace build cannot provide it:
        // only the FMU packages are built.
        LinuxBuild::Glibc217 => {
            let selection = BuildScope::FmuPackages.arguments(packages);
            let shown = format!(
                "cargo zigbuild --release --target {GLIBC_2_17_TARGET} {}",
                selection.join(" ")
            );
            let (tool, path) = zigbuild_command(&workspace.root);
            let mut command = Command::new(tool);
            command.args(["zigbuild", "--target", GLIBC_2_17_TARGET]);
            // The shipped libraries are compiled by rustc itself, never by a wrapper the
            // caller's environment names: tests/run.sh lints its build through clippy-driver,
            // which is not meant to produce release artefacts.
            command
                .env_remove("RUSTC_WORKSPACE_WRAPPER")
                .env_remove("CLIPPY_ARGS");
            if let Some(path) = path {
                command.env("PATH", path);
            }
            (command, selection, shown)
        }
    };
    eprintln!("packaging: {shown}");
    let output = command
        .args(["--release", "--message-format=json-render-diagnostics"])
        .arg("--manifest-path")
        .arg(&workspace.manifest)
        .args(&selection)
        .stderr(Stdio::inherit())
        .output()
        .with_context(|| {
            format!("running `{shown}` (for cargo zigbuild: run packaging/setup.sh, or pass --host-glibc)")
        })?;
    if !output.status.success() {
        bail!("`{shown}` failed (see the compiler output above)");
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let mut found = Vec::new();
    for name in library_names {
        let file_name = format!("lib{name}.so");
        let path = stdout
            .lines()
            .filter(|line| line.contains("\"reason\":\"compiler-artifact\""))
            .filter_map(|line| json_string_array(line, "filenames"))
            .flatten()
            .map(PathBuf::from)
            .find(|path| path.file_name().is_some_and(|f| f == file_name.as_str()))
            .with_context(|| {
                format!(
                    "`cargo build` produced no {file_name}; the cdylib's [lib] name must be the \
                     model identifier {name}"
                )
            })?;
        found.push(path);
    }
    Ok(found)
}

/// `name version  license` of every third-party crate linked into `package`: normal dependencies
/// only (no build, dev or proc-macro dependencies, which never reach the binary), sorted, without
/// duplicates, and without the workspace's own crates (their license is LICENSE.txt).
pub fn linked_crates(workspace: &Workspace, package: &str) -> Result<Vec<String>> {
    let output = cargo()
        .args([
            "tree",
            "--edges",
            "normal,no-proc-macro",
            "--prefix",
            "none",
            "--format",
            "{p} | {l}",
        ])
        .arg("--manifest-path")
        .arg(&workspace.manifest)
        .args(["-p", package])
        .stderr(Stdio::inherit())
        .output()
        .context("running `cargo tree`")?;
    if !output.status.success() {
        bail!("`cargo tree -p {package}` failed");
    }
    Ok(third_party_crates(&String::from_utf8_lossy(&output.stdout)))
}

/// Reads `cargo tree --format "{p} | {l}" --prefix none` output into sorted, unique
/// `name version  license` lines, leaving out the workspace's own (path) crates.
pub(crate) fn third_party_crates(tree: &str) -> Vec<String> {
    let mut crates = BTreeSet::new();
    for line in tree.lines() {
        let Some((package_part, license)) = line.split_once(" | ") else {
            continue;
        };
        // "{p}" is "name vX.Y.Z" plus " (path)" for local crates and " (*)" for repeats.
        if package_part.contains(" (/") {
            continue;
        }
        let mut words = package_part.split_whitespace();
        let (Some(name), Some(version)) = (words.next(), words.next()) else {
            continue;
        };
        let license = license.trim_end_matches(" (*)").trim();
        let license = if license.is_empty() {
            "see crate"
        } else {
            license
        };
        crates.insert(format!("{name} {version}  {license}"));
    }
    crates.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn third_party_list_skips_repeats_and_workspace_crates() {
        let tree =
            "reference-vehicle v0.1.0 (/work/main/fmu-src/reference-vehicle) | MIT OR Apache-2.0\n\
                    nalgebra v0.35.0 | Apache-2.0\n\
                    approx v0.5.1 | Apache-2.0\n\
                    nalgebra v0.35.0 | Apache-2.0 (*)\n\
                    odd v1.0.0 | \n\
                    not a tree line\n";
        assert_eq!(
            third_party_crates(tree),
            vec![
                "approx v0.5.1  Apache-2.0".to_string(),
                "nalgebra v0.35.0  Apache-2.0".to_string(),
                "odd v1.0.0  see crate".to_string(),
            ]
        );
    }

    #[test]
    fn json_fields_and_arrays_are_read_with_escapes() {
        let text = r#"{"reason":"compiler-artifact","filenames":["/t/a b/libX.so", "/t/q\"uote\\x.rlib"],"target_directory":"/w/t\u00e4rget"}"#;
        assert_eq!(
            json_string_array(text, "filenames").unwrap(),
            vec![
                "/t/a b/libX.so".to_string(),
                "/t/q\"uote\\x.rlib".to_string()
            ]
        );
        assert_eq!(
            json_string_field(text, "target_directory").unwrap(),
            "/w/tärget"
        );
        assert_eq!(json_string_field(text, "missing"), None);
        assert_eq!(
            json_string_array(r#"{"filenames":[]}"#, "filenames").unwrap(),
            Vec::<String>::new()
        );
        assert_eq!(
            json_string_array(r#"{"filenames":["unterminated]}"#, "filenames"),
            None
        );
    }
}
