//! CSV output of a run: `time` then every recorded column, values printed with Rust's shortest
//! round-trip formatting (parsing them back gives the identical f64).

use std::path::Path;

use anyhow::{Context, Result};

use crate::cosim::RunResult;

pub fn write_csv(result: &RunResult, path: &Path) -> Result<()> {
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
    writer
        .flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
