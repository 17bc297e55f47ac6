//! Deterministic zip archives and atomic file replacement.
//!
//! Archives are assembled in memory with a fixed timestamp and fixed permissions, so the same inputs
//! give the same bytes; that makes "nothing changed" a plain byte comparison with the file on disk.

use std::fs;
use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

/// One file inside an archive.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entry {
    /// Path inside the archive, '/'-separated, relative.
    pub path: String,
    pub contents: Vec<u8>,
    /// Sets the Unix mode to 0755 (shared libraries) instead of 0644.
    pub executable: bool,
    /// Already-compressed payloads (nested archives) are stored, everything else deflated.
    pub stored: bool,
}

impl Entry {
    pub fn file(path: impl Into<String>, contents: impl Into<Vec<u8>>) -> Self {
        Entry {
            path: path.into(),
            contents: contents.into(),
            executable: false,
            stored: false,
        }
    }

    pub fn executable(path: impl Into<String>, contents: impl Into<Vec<u8>>) -> Self {
        Entry {
            executable: true,
            ..Entry::file(path, contents)
        }
    }

    pub fn stored(path: impl Into<String>, contents: impl Into<Vec<u8>>) -> Self {
        Entry {
            stored: true,
            ..Entry::file(path, contents)
        }
    }
}

fn check_entry_path(path: &str) -> Result<()> {
    // FMI 2.0 and SSP 1.0 both require '/' separators and paths relative to the archive root;
    // fmpy's validation flags backslashes explicitly.
    if path.is_empty()
        || path.starts_with('/')
        || path.contains('\\')
        || path
            .split('/')
            .any(|part| part.is_empty() || part == "." || part == "..")
    {
        bail!(
            "archive entry path {path:?} must be relative, '/'-separated, without '.'/'..' parts"
        );
    }
    Ok(())
}

/// Builds the zip archive in memory; entries keep the given order, duplicates are an error.
pub fn zip_bytes(entries: &[Entry]) -> Result<Vec<u8>> {
    let mut seen = std::collections::BTreeSet::new();
    let mut writer = ZipWriter::new(Cursor::new(Vec::new()));
    for entry in entries {
        check_entry_path(&entry.path)?;
        if !seen.insert(entry.path.as_str()) {
            bail!("archive entry {:?} appears twice", entry.path);
        }
        let options = SimpleFileOptions::default()
            .compression_method(if entry.stored {
                CompressionMethod::Stored
            } else {
                CompressionMethod::Deflated
            })
            // A fixed timestamp keeps archives byte-identical across rebuilds.
            .last_modified_time(DateTime::DEFAULT)
            .unix_permissions(if entry.executable { 0o755 } else { 0o644 });
        writer
            .start_file(entry.path.as_str(), options)
            .with_context(|| format!("starting archive entry {}", entry.path))?;
        writer
            .write_all(&entry.contents)
            .with_context(|| format!("writing archive entry {}", entry.path))?;
    }
    let cursor = writer.finish().context("finishing the zip archive")?;
    Ok(cursor.into_inner())
}

/// Reads back the names of the entries of an archive (for tests and the summary).
pub fn entry_names(bytes: &[u8]) -> Result<Vec<String>> {
    let archive = zip::ZipArchive::new(Cursor::new(bytes)).context("reading zip archive")?;
    archive
        .file_names()
        .map(|name| {
            name.map(|name| name.into_owned())
                .context("reading an entry name")
        })
        .collect()
}

/// Reads one entry of an in-memory archive.
pub fn read_entry(bytes: &[u8], path: &str) -> Result<Vec<u8>> {
    let mut archive = zip::ZipArchive::new(Cursor::new(bytes)).context("reading zip archive")?;
    let mut file = archive
        .by_name(path)
        .with_context(|| format!("archive has no entry {path}"))?;
    let mut contents = Vec::new();
    std::io::Read::read_to_end(&mut file, &mut contents)
        .with_context(|| format!("reading archive entry {path}"))?;
    Ok(contents)
}

/// What [`write_if_changed`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriteOutcome {
    Written,
    Unchanged,
}

/// Removes the temporary file unless the rename succeeded.
struct TemporaryFile {
    path: PathBuf,
    keep: bool,
}

impl Drop for TemporaryFile {
    fn drop(&mut self) {
        if !self.keep {
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Writes `bytes` to a temporary file next to `destination` and flushes it to disk; the guard
/// removes it again unless [`commit`] renamed it into place.
fn stage(destination: &Path, bytes: &[u8]) -> Result<TemporaryFile> {
    let directory = destination
        .parent()
        .filter(|parent| !parent.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    fs::create_dir_all(directory)
        .with_context(|| format!("creating directory {}", directory.display()))?;
    let file_name = destination
        .file_name()
        .with_context(|| format!("{} has no file name", destination.display()))?
        .to_string_lossy();
    let guard = TemporaryFile {
        path: directory.join(format!(".{file_name}.tmp-{}", std::process::id())),
        keep: false,
    };
    let mut file = fs::File::create(&guard.path)
        .with_context(|| format!("creating {}", guard.path.display()))?;
    file.write_all(bytes)
        .with_context(|| format!("writing {}", guard.path.display()))?;
    file.sync_all()
        .with_context(|| format!("flushing {}", guard.path.display()))?;
    Ok(guard)
}

/// Renames a staged file over its destination (atomic within one file system).
fn commit(mut staged: TemporaryFile, destination: &Path) -> Result<()> {
    fs::rename(&staged.path, destination).with_context(|| {
        format!(
            "renaming {} to {}",
            staged.path.display(),
            destination.display()
        )
    })?;
    staged.keep = true;
    Ok(())
}

/// Replaces `destination` with `bytes` atomically: the bytes go to a temporary file in the same
/// directory, are flushed to disk and only then renamed over the destination, so a reader (or a
/// failure half-way) never sees a half-written archive.
pub fn write_atomically(destination: &Path, bytes: &[u8]) -> Result<()> {
    let staged = stage(destination, bytes)?;
    commit(staged, destination)
}

/// Writes several files as one update: every changed file is staged (written and flushed) first,
/// and only when all are staged are they renamed into place, so a failure while writing (disk
/// full, permissions) leaves all destinations as they were. Files whose bytes did not change are
/// not touched.
pub fn write_all_if_changed(files: &[(PathBuf, Vec<u8>)]) -> Result<Vec<WriteOutcome>> {
    let mut outcomes = Vec::new();
    let mut staged = Vec::new();
    for (destination, bytes) in files {
        if fs::read(destination).is_ok_and(|existing| existing == *bytes) {
            outcomes.push(WriteOutcome::Unchanged);
        } else {
            staged.push((stage(destination, bytes)?, destination));
            outcomes.push(WriteOutcome::Written);
        }
    }
    for (file, destination) in staged {
        commit(file, destination)?;
    }
    Ok(outcomes)
}

/// Writes atomically unless the destination already holds exactly these bytes.
pub fn write_if_changed(destination: &Path, bytes: &[u8]) -> Result<WriteOutcome> {
    if let Ok(existing) = fs::read(destination) {
        if existing == bytes {
            return Ok(WriteOutcome::Unchanged);
        }
    }
    write_atomically(destination, bytes)?;
    Ok(WriteOutcome::Written)
}
