//! CSV output of a run: `time` then every recorded column, values printed with Rust's shortest
//! round-trip formatting (parsing them back gives the identical f64).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use crate::cosim::RunResult;

/// Writes the CSV under a temporary name next to `path` and renames it to `path` only when every
/// row is written and flushed: a full disk or a failed write never leaves a
/// truncated file under the final name.
pub fn write_csv(result: &RunResult, path: &Path) -> Result<()> {
    let partial = partial_name(path);
    let written = write_rows(result, &partial).and_then(|()| {
        std::fs::rename(&partial, path)
            .with_context(|| format!("renaming {} to {}", partial.display(), path.display()))
    });
    if written.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    written
}

/// Writes `contents` (a report, a table) to `path` as [`write_csv`] writes a run: under
/// [`partial_name`] first, renamed when complete, so that a failed write leaves the file that
/// was there before, not a truncated one.
pub fn write_whole(path: &Path, contents: &str) -> Result<()> {
    let partial = partial_name(path);
    let written = std::fs::write(&partial, contents)
        .with_context(|| format!("writing {}", partial.display()))
        .and_then(|()| {
            std::fs::rename(&partial, path)
                .with_context(|| format!("renaming {} to {}", partial.display(), path.display()))
        });
    if written.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    written
}

/// `<path>.partial`, where a file is written before it is complete.
pub fn partial_name(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

fn write_rows(result: &RunResult, path: &Path) -> Result<()> {
    let mut writer =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    let mut header = vec!["time".to_string()];
    header.extend(result.columns.iter().cloned());
    writer
        .write_record(&header)
        .with_context(|| format!("writing {}", path.display()))?;
    let mut row: Vec<String> = Vec::with_capacity(header.len());
    for (k, t) in result.times.iter().enumerate() {
        row.clear();
        row.push(t.to_string());
        for column in &result.data {
            row.push(column[k].to_string());
        }
        writer
            .write_record(&row)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let file = writer
        .into_inner()
        .map_err(|e| anyhow::anyhow!("writing {}: {}", path.display(), e.error()))?;
    file.sync_all()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cosim::Columns;

    fn result() -> RunResult {
        let data = Columns::reusing(vec![0.5; 2], 1, 2);
        RunResult {
            scenario: "t".into(),
            times: vec![0.0, 0.1],
            columns: vec!["a.x".into()],
            data,
            step_wall_time: Vec::new(),
            total_wall_time: 0.0,
        }
    }

    #[test]
    fn the_csv_appears_under_its_name_only_when_complete() {
        // Removed when the test ends, also when it fails.
        let scratch = crate::runner::WorkFolder::new(
            std::env::temp_dir().join(format!("recording-test-{}", std::process::id())),
        );
        let dir = scratch.path();
        std::fs::create_dir_all(dir).unwrap();
        let path = dir.join("t.csv");
        write_csv(&result(), &path).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "time,a.x\n0,0.5\n0.1,0.5\n"
        );
        assert!(!partial_name(&path).exists());
        // The final name is taken by a folder: the rename fails, nothing is left behind.
        let blocked = dir.join("blocked.csv");
        std::fs::create_dir_all(blocked.join("inside")).unwrap();
        assert!(write_csv(&result(), &blocked).is_err());
        assert!(!partial_name(&blocked).exists());
        assert!(blocked.join("inside").is_dir());
    }

    #[test]
    fn a_whole_file_replaces_the_old_one_only_when_complete() {
        let scratch = crate::runner::WorkFolder::new(
            std::env::temp_dir().join(format!("recording-whole-test-{}", std::process::id())),
        );
        let dir = scratch.path();
        std::fs::create_dir_all(dir).unwrap();
        let path = dir.join("report.md");
        write_whole(&path, "old").unwrap();
        write_whole(&path, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert!(!partial_name(&path).exists());
        let blocked = dir.join("blocked.md");
        std::fs::create_dir_all(blocked.join("inside")).unwrap();
        let message = format!("{:#}", write_whole(&blocked, "text").unwrap_err());
        assert!(message.contains("blocked.md"), "{message}");
        assert!(!partial_name(&blocked).exists());
        assert!(blocked.join("inside").is_dir());
        let nowhere = dir.join("no such folder").join("report.md");
        let message = format!("{:#}", write_whole(&nowhere, "text").unwrap_err());
        assert!(message.contains("no such folder"), "{message}");
    }
}
