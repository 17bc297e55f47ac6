//! `generationDateAndTime` (FMI 2.0 section 2.2.1, an `xs:dateTime`) of the archived model
//! descriptions, chosen so that the same sources give the same archive bytes.
//!
//! The time is `SOURCE_DATE_EPOCH` when it is set (the reproducible-builds convention,
//! <https://reproducible-builds.org/specs/source-date-epoch/>), else the committer time of the
//! workspace's last git commit. The repository's `modelDescription/*.xml` stay the single source
//! of every other attribute and never carry this one: packaging inserts it into the copy it
//! archives.

use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};

pub const SOURCE_DATE_EPOCH: &str = "SOURCE_DATE_EPOCH";

const ATTRIBUTE: &str = "generationDateAndTime";
const ROOT_TAG: &str = "<fmiModelDescription";

/// Seconds since 1970-01-01T00:00:00Z of the build: `SOURCE_DATE_EPOCH`, else the last commit.
pub fn generation_epoch(workspace_root: &Path) -> Result<i64> {
    if let Ok(text) = std::env::var(SOURCE_DATE_EPOCH) {
        return parse_epoch(&text)
            .with_context(|| format!("the environment variable {SOURCE_DATE_EPOCH}"));
    }
    let output = Command::new("git")
        .arg("-C")
        .arg(workspace_root)
        .args(["log", "-1", "--format=%ct"])
        .output()
        .with_context(|| format!("running git for the last commit time; set {SOURCE_DATE_EPOCH} to build outside a git checkout"))?;
    if !output.status.success() {
        bail!(
            "git log -1 in {} failed ({}); set {SOURCE_DATE_EPOCH} (seconds since 1970) to build \
             outside a git checkout",
            workspace_root.display(),
            String::from_utf8_lossy(&output.stderr).trim()
        );
    }
    parse_epoch(String::from_utf8_lossy(&output.stdout).trim())
        .context("the committer time git log -1 --format=%ct printed")
}

fn parse_epoch(text: &str) -> Result<i64> {
    match text.trim().parse::<i64>() {
        // Years 1970 to 9999 keep the four-digit year of xs:dateTime.
        Ok(seconds) if (0..=253_402_300_799).contains(&seconds) => Ok(seconds),
        _ => bail!("expected whole seconds since 1970-01-01 up to the year 9999, got {text:?}"),
    }
}

/// `YYYY-MM-DDThh:mm:ssZ` in UTC, the form FMI 2.0 recommends. The calendar date comes from the
/// day count by H. Hinnant's `civil_from_days`
/// (<https://howardhinnant.github.io/date_algorithms.html#civil_from_days>).
pub fn iso8601_utc(epoch_seconds: i64) -> String {
    let days = epoch_seconds.div_euclid(86_400);
    let second_of_day = epoch_seconds.rem_euclid(86_400);
    let shifted = days + 719_468; // days since 0000-03-01
    let era = shifted.div_euclid(146_097);
    let day_of_era = shifted.rem_euclid(146_097);
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let month_from_march = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * month_from_march + 2) / 5 + 1;
    let month = if month_from_march < 10 {
        month_from_march + 3
    } else {
        month_from_march - 9
    };
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        second_of_day / 3600,
        second_of_day % 3600 / 60,
        second_of_day % 60
    )
}

/// The model description with `generationDateAndTime="<time>"` as the root element's first
/// attribute, on its own line like the others; every other byte unchanged.
pub fn stamp_model_description(xml: &[u8], time: &str) -> Result<Vec<u8>> {
    let text = std::str::from_utf8(xml).context("the model description is not UTF-8")?;
    let Some(start) = text.find(ROOT_TAG) else {
        bail!("the model description has no {ROOT_TAG} element to stamp");
    };
    let root_end = text[start..]
        .find('>')
        .map_or(text.len(), |end| start + end);
    if text[start..root_end].contains(&format!("{ATTRIBUTE}=")) {
        bail!(
            "the repository's model description already has {ATTRIBUTE}; remove it: packaging \
             writes it into the archived copy (SOURCE_DATE_EPOCH or the last commit's time)"
        );
    }
    let insert_at = start + ROOT_TAG.len();
    let mut stamped = String::with_capacity(text.len() + 64);
    stamped.push_str(&text[..insert_at]);
    stamped.push_str(&format!("\n  {ATTRIBUTE}=\"{time}\""));
    stamped.push_str(&text[insert_at..]);
    Ok(stamped.into_bytes())
}
