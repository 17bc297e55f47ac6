//! Recorded drives: a CSV file with a header line (plain, or gzip-compressed as `.csv.gz`), or
//! an ASAM MDF4 file (`.mf4`, read with the `mf4-rs` crate). Each signal is a series of (time, value) samples on its own time axis; a
//! missing sample (an empty CSV cell, `NaN`, an MF4 sample flagged invalid) is a NaN value,
//! which alignment skips ([`super::align`]). Every error names the file and, for a CSV, the line
//! and column (column number and header name) at fault.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{anyhow, bail, Context, Result};

/// One logged signal.
#[derive(Debug, Clone)]
pub struct Signal {
    pub name: String,
    /// The unit the file declares (MF4 channels); `None` for CSV columns.
    pub unit: Option<String>,
    /// Time stamps, s, strictly increasing; shared by the signals of one CSV or channel group.
    pub times: Arc<Vec<f64>>,
    pub values: Vec<f64>,
}

/// The signals of one log file that a map asked for.
#[derive(Debug, Clone)]
pub struct Log {
    pub path: PathBuf,
    pub signals: Vec<Signal>,
}

impl Log {
    /// Reads the columns `wanted` (and the time axis) of `path`: MF4 when the extension is
    /// `.mf4` or `.mdf`, otherwise CSV (gzip-compressed when the name ends in `.gz`) with the
    /// time stamps in `time_column` (× `time_factor` to seconds). Columns the file lacks are simply absent from the result.
    pub fn read(path: &Path, time_column: &str, time_factor: f64, wanted: &[&str]) -> Result<Log> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let signals = match extension.as_deref() {
            Some("mf4") | Some("mdf") => read_mf4(path, wanted)?,
            _ => read_csv(path, time_column, time_factor, wanted)?,
        };
        Ok(Log {
            path: path.to_path_buf(),
            signals,
        })
    }

    pub fn signal(&self, name: &str) -> Option<&Signal> {
        self.signals.iter().find(|s| s.name == name)
    }

    /// First and last time stamp of all signals, s.
    pub fn time_span(&self) -> Option<(f64, f64)> {
        let first = self
            .signals
            .iter()
            .filter_map(|s| s.times.first())
            .copied()
            .reduce(f64::min)?;
        let last = self
            .signals
            .iter()
            .filter_map(|s| s.times.last())
            .copied()
            .reduce(f64::max)?;
        Some((first, last))
    }
}

/// A CSV log: a header line naming the columns, then one row per time stamp. Only the time
/// column and the `wanted` ones are parsed, so a text column the map does not use is no error.
fn read_csv(
    path: &Path,
    time_column: &str,
    time_factor: f64,
    wanted: &[&str],
) -> Result<Vec<Signal>> {
    let name = path.display();
    let bytes = read_bytes(path)?;
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        bail!("log {name}, line 1: the file is empty; expected a header line naming the columns ({time_column}, ...) and rows of numbers");
    }
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(bytes.as_slice());
    let header = reader
        .headers()
        .with_context(|| format!("log {name}, line 1: cannot read the header line"))?
        .clone();
    let index_of = |column: &str| header.iter().position(|h| h == column);
    let time_index = index_of(time_column).ok_or_else(|| {
        anyhow!(
            "log {name}, line 1: no time column {time_column:?} (the header names: {}); set log.time in the map",
            header.iter().collect::<Vec<_>>().join(", ")
        )
    })?;
    let columns: Vec<(usize, &str)> = wanted
        .iter()
        .filter_map(|w| index_of(w).map(|i| (i, *w)))
        .collect();
    let mut times = Vec::new();
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); columns.len()];
    let mut record = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                bail!("log {name}, line {line}: {e}");
            }
        }
        let line = record.position().map_or(0, |p| p.line());
        let cell = |index: usize| record.get(index).unwrap_or("");
        let column_name = |index: usize| format!("column {} ({:?})", index + 1, &header[index]);
        let t = parse_cell(cell(time_index)).map_err(|text| {
            anyhow!(
                "log {name}, line {line}, {}: {text:?} is not a number",
                column_name(time_index)
            )
        })? * time_factor;
        if !t.is_finite() {
            bail!(
                "log {name}, line {line}, {}: every row needs a time stamp",
                column_name(time_index)
            );
        }
        if let Some(&previous) = times.last() {
            if t <= previous {
                bail!(
                    "log {name}, line {line}, {}: time {t} s is not after the previous row's {previous} s; time stamps must increase strictly",
                    column_name(time_index)
                );
            }
        }
        times.push(t);
        for ((index, _), column) in columns.iter().zip(values.iter_mut()) {
            column.push(parse_cell(cell(*index)).map_err(|text| {
                anyhow!("log {name}, line {line}, {}: {text:?} is not a number (an empty cell or NaN marks a missing sample)", column_name(*index))
            })?);
        }
    }
    if times.is_empty() {
        bail!("log {name}, line 2: no data rows after the header line");
    }
    let times = Arc::new(times);
    Ok(columns
        .iter()
        .zip(values)
        .map(|((_, column), values)| Signal {
            name: column.to_string(),
            unit: None,
            times: Arc::clone(&times),
            values,
        })
        .collect())
}

/// The file's bytes, decompressed when its name ends in `.gz` (a log kept compressed in the
/// repository, such as the MBDS recording).
fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let name = path.display();
    let bytes = std::fs::read(path).with_context(|| format!("log {name}: cannot read the file"))?;
    let gzip = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    if !gzip {
        return Ok(bytes);
    }
    let mut text = Vec::new();
    std::io::Read::read_to_end(
        &mut flate2::read::GzDecoder::new(bytes.as_slice()),
        &mut text,
    )
    .with_context(|| format!("log {name}: not a readable gzip file"))?;
    Ok(text)
}

/// An empty cell or NaN is a missing sample; anything else must be a number.
fn parse_cell(text: &str) -> Result<f64, String> {
    if text.is_empty() {
        return Ok(f64::NAN);
    }
    text.parse::<f64>().map_err(|_| text.to_string())
}

/// An MF4 log: every channel group has its own master (time) channel; a wanted channel is read
/// with its conversion applied (`values_as_f64`), invalid samples as NaN.
fn read_mf4(path: &Path, wanted: &[&str]) -> Result<Vec<Signal>> {
    let name = path.display();
    let text_path = path
        .to_str()
        .ok_or_else(|| anyhow!("log {name}: the path is not UTF-8"))?;
    let mdf = mf4_rs::api::mdf::MDF::from_file(text_path)
        .map_err(|e| anyhow!("log {name}: not a readable MDF4 file: {e:?}"))?;
    let mut signals = Vec::new();
    for (g, group) in mdf.channel_groups().iter().enumerate() {
        let channels = group.channels();
        let matching: Vec<_> = channels
            .iter()
            .filter_map(|c| {
                c.name()
                    .ok()
                    .flatten()
                    .filter(|n| wanted.contains(&n.as_str()))
                    .map(|n| (n, c))
            })
            .collect();
        if matching.is_empty() {
            continue;
        }
        let master = group
            .master_channel()
            .ok_or_else(|| anyhow!("log {name}, channel group {g}: no master (time) channel"))?;
        let master_name = master.name().ok().flatten().unwrap_or_default();
        let times = master.values_as_f64().map_err(|e| {
            anyhow!("log {name}, channel group {g}, channel {master_name:?}: {e:?}")
        })?;
        if let Some(k) = (1..times.len())
            .find(|&k| times[k].partial_cmp(&times[k - 1]) != Some(std::cmp::Ordering::Greater))
        {
            bail!(
                "log {name}, channel group {g}, master channel {master_name:?}, sample {k}: time {} s is not after the previous sample's {} s; time stamps must increase strictly",
                times[k],
                times[k - 1]
            );
        }
        let times = Arc::new(times);
        for (channel_name, channel) in matching {
            let values = channel.values_as_f64().map_err(|e| {
                anyhow!("log {name}, channel group {g}, channel {channel_name:?}: {e:?}")
            })?;
            if values.len() != times.len() {
                bail!("log {name}, channel group {g}, channel {channel_name:?}: {} samples for {} time stamps", values.len(), times.len());
            }
            signals.push(Signal {
                unit: channel.unit().ok().flatten().filter(|u| !u.is_empty()),
                name: channel_name,
                times: Arc::clone(&times),
                values,
            });
        }
    }
    Ok(signals)
}
