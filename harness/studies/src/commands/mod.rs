//! One function per `harness` command, grouped by what the command works on. The clap argument
//! structs live next to the function that takes them; `main.rs` only dispatches.

pub mod identify;
pub mod logs;
pub mod scenarios;
pub mod studies;

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use indicatif::{ProgressBar, ProgressStyle};

use fmi_master::runner;
use harness::demo;

/// Where a command prints. Every command returns its write errors, so a reader that goes away
/// (`harness ... | head -1`) ends it without a panic (see `main`).
pub type Stdout<'a> = &'a mut (dyn Write + Send);

/// The FMU folder of a study: the one given (used as it is), else the project's own, packaged
/// first when missing or stale, as `demo` does.
pub fn packaged_fmus(fmu_dir: Option<PathBuf>) -> Result<PathBuf> {
    let custom_dir = fmu_dir.is_some();
    let fmu_dir = fmu_dir_or_default(fmu_dir);
    demo::ensure_fmus(&fmu_dir, !custom_dir)?;
    Ok(fmu_dir)
}

/// The FMU folder given on the command line, else where packaging writes.
pub fn fmu_dir_or_default(fmu_dir: Option<PathBuf>) -> PathBuf {
    absolute(fmu_dir).unwrap_or_else(runner::default_fmu_dir)
}

/// An FMU folder given on the command line is relative to the working directory, not to the
/// scenario file.
pub fn absolute(dir: Option<PathBuf>) -> Option<PathBuf> {
    dir.map(|d| std::path::absolute(&d).unwrap_or(d))
}

pub fn progress_bar(length: u64) -> ProgressBar {
    let bar = ProgressBar::new(length);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}
