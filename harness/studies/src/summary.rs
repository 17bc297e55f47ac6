//! The report's opening answer: how accurate is the sideslip estimate, on which car, against
//! what? Every study that scores sideslip writes its rows in one CSV format ([`HEADER`]); the
//! summary reads the files the run produced, draws one figure (RMSE per estimator and model,
//! beside answering zero and the steady-state single-track formula of
//! [`fmi_master::yardstick`]) and states what holds and what does not.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use fmi_master::plot::{self, ErrorBar, ErrorChartLegend};
use fmi_master::recording::write_whole;
use fmi_master::report::Document;

use crate::campaigns::{CampaignReport, Row};

/// The header of an accuracy CSV, exactly.
pub const HEADER: [&str; 10] = [
    "source",
    "case",
    "model",
    "estimator",
    "wheel_speeds",
    "rmse_deg",
    "nees",
    "zero_rmse_deg",
    "yardstick_rmse_deg",
    "max_vx_error_mps",
];

/// The source name of the simulated campaign rows.
pub const SIMULATED: &str = "simulated cars";

/// A run may be at most this much worse than the steady-state formula and still count as
/// matching it (the margin the real-road requirements allow).
pub const YARDSTICK_MARGIN_DEG: f64 = 0.02;

/// The band a time-averaged sideslip NEES of an honest filter lies in.
pub const NEES_BAND: (f64, f64) = (0.5, 2.0);

/// One estimator on one case: its sideslip error beside the answers without a filter.
#[derive(Debug, Clone, PartialEq)]
pub struct AccuracyRow {
    /// Where the truth comes from: "simulated cars", a recording's name.
    pub source: String,
    /// The run within the source (car and manoeuvre, laps, ...).
    pub case: String,
    /// The estimator's model: "A", "B", "A+grip".
    pub model: String,
    /// The estimator kind: "EKF", "UKF", ...
    pub estimator: String,
    pub wheel_speeds: bool,
    pub rmse_deg: f64,
    /// Time-averaged sideslip NEES (NaN when the estimator reports no std).
    pub nees: f64,
    /// The RMSE of answering zero sideslip.
    pub zero_rmse_deg: f64,
    /// The RMSE of the steady-state single-track formula, where the study computed it.
    pub yardstick_rmse_deg: Option<f64>,
    /// The largest |vx error|, where the study measured it in m/s.
    pub max_vx_error_mps: Option<f64>,
}

impl AccuracyRow {
    pub fn beats_zero(&self) -> bool {
        self.rmse_deg < self.zero_rmse_deg
    }

    /// Not more than [`YARDSTICK_MARGIN_DEG`] worse than the formula; None where it is unknown.
    pub fn matches_yardstick(&self) -> Option<bool> {
        self.yardstick_rmse_deg
            .map(|y| self.rmse_deg <= y + YARDSTICK_MARGIN_DEG)
    }

    /// The FMU's default configuration: the EKF on the grip model.
    pub fn is_default(&self) -> bool {
        self.estimator.eq_ignore_ascii_case("ekf")
            && (self.model.eq_ignore_ascii_case("a+grip")
                || self.model.eq_ignore_ascii_case("grip"))
    }
}

fn optional(value: Option<f64>) -> String {
    value.map_or(String::new(), |v| v.to_string())
}

/// `rows` as the text of an accuracy CSV ([`HEADER`]); numbers in Rust's shortest round-trip
/// form, the wheel speeds `measured` or `missing` (the studies that write through here simulate
/// them; the replay study writes its own rows, whose wheel speeds are synthesised).
pub fn csv_text(rows: &[AccuracyRow]) -> Result<String> {
    let mut writer = csv::Writer::from_writer(Vec::new());
    writer.write_record(HEADER)?;
    for r in rows {
        writer.write_record([
            r.source.clone(),
            r.case.clone(),
            r.model.clone(),
            r.estimator.clone(),
            if r.wheel_speeds {
                "measured"
            } else {
                "missing"
            }
            .to_string(),
            r.rmse_deg.to_string(),
            r.nees.to_string(),
            r.zero_rmse_deg.to_string(),
            optional(r.yardstick_rmse_deg),
            optional(r.max_vx_error_mps),
        ])?;
    }
    String::from_utf8(writer.into_inner()?).context("the accuracy CSV's text")
}

/// Writes `rows` as an accuracy CSV ([`csv_text`]) to `path`, whole.
pub fn write_rows(path: &Path, rows: &[AccuracyRow]) -> Result<()> {
    write_whole(path, &csv_text(rows)?)
}

/// Reads the rows of every accuracy CSV in `paths`, in order. A file whose header is not
/// [`HEADER`] or a field that is not what its column holds is an error naming file, line and
/// column.
pub fn read_rows(paths: &[PathBuf]) -> Result<Vec<AccuracyRow>> {
    let mut rows = Vec::new();
    for path in paths {
        let mut reader = csv::Reader::from_path(path)
            .with_context(|| format!("reading the accuracy rows {}", path.display()))?;
        let header = reader
            .headers()
            .with_context(|| format!("{}: the header line", path.display()))?
            .clone();
        if !header.iter().eq(HEADER) {
            bail!(
                "{}: header {:?}; expected exactly {}",
                path.display(),
                header.iter().collect::<Vec<_>>().join(","),
                HEADER.join(",")
            );
        }
        for (index, record) in reader.records().enumerate() {
            let line = index + 2;
            let record = record.with_context(|| format!("{}, line {line}", path.display()))?;
            // A configuration the FMU refused (its reason is in the study's own table) has no
            // score to summarise.
            if record.get(5).is_some_and(|rmse| rmse.trim().is_empty()) {
                continue;
            }
            rows.push(
                parse_row(&record).with_context(|| format!("{}, line {line}", path.display()))?,
            );
        }
    }
    Ok(rows)
}

fn parse_row(record: &csv::StringRecord) -> Result<AccuracyRow> {
    let field = |i: usize| record.get(i).unwrap_or("").trim();
    let number = |i: usize| -> Result<f64> {
        field(i)
            .parse::<f64>()
            .with_context(|| format!("{}: {:?} is not a number", HEADER[i], field(i)))
    };
    let maybe = |i: usize| -> Result<Option<f64>> {
        if field(i).is_empty() {
            Ok(None)
        } else {
            number(i).map(Some)
        }
    };
    let wheel_speeds = match field(4).to_ascii_lowercase().as_str() {
        "measured" | "yes" | "with" | "true" | "1" => true,
        "missing" | "no" | "without" | "false" | "0" => false,
        other => bail!(
            "wheel_speeds: {other:?}; expected measured or with (yes), missing or without (no)"
        ),
    };
    Ok(AccuracyRow {
        source: field(0).to_string(),
        case: field(1).to_string(),
        model: field(2).to_string(),
        estimator: field(3).to_string(),
        wheel_speeds,
        rmse_deg: number(5)?,
        nees: maybe(6)?.unwrap_or(f64::NAN),
        zero_rmse_deg: number(7)?,
        yardstick_rmse_deg: maybe(8)?,
        max_vx_error_mps: maybe(9)?,
    })
}

/// The estimator kind of a campaign instance name: `UKF_scaled_G` -> `UKF_scaled`.
fn estimator_kind(instance: &str) -> &str {
    match instance.rsplit_once('_') {
        Some((kind, "A" | "B" | "G")) => kind,
        _ => instance,
    }
}

/// The mismatch campaigns' rows in the accuracy format: the full vehicle with real cars' data,
/// every estimator on each model.
pub fn campaign_rows(report: &CampaignReport) -> Vec<AccuracyRow> {
    report.rows.iter().map(campaign_row).collect()
}

fn campaign_row(row: &Row) -> AccuracyRow {
    AccuracyRow {
        source: SIMULATED.to_string(),
        case: format!("{} {}", row.car.trim_end_matches(".ssv"), row.manoeuvre),
        model: row.model.to_string(),
        estimator: estimator_kind(&row.estimator).to_string(),
        wheel_speeds: true,
        rmse_deg: row.rmse.to_degrees(),
        nees: row.mean_nees,
        zero_rmse_deg: row.zero_baseline.to_degrees(),
        yardstick_rmse_deg: None,
        max_vx_error_mps: None,
    }
}

/// The rows of one source, model, estimator and wheel-speed set-up, summarised.
#[derive(Debug, Clone)]
struct Group {
    source: String,
    model: String,
    estimator: String,
    wheel_speeds: bool,
    rows: Vec<AccuracyRow>,
}

impl Group {
    fn label(&self) -> String {
        let speeds = if self.wheel_speeds {
            ""
        } else {
            ", no wheel speeds"
        };
        format!("{} on {}{speeds}", self.estimator, self.model)
    }
    fn median(&self, value: impl Fn(&AccuracyRow) -> Option<f64>) -> Option<f64> {
        median(self.rows.iter().filter_map(value).collect())
    }
    fn rmse(&self) -> f64 {
        self.median(|r| Some(r.rmse_deg)).unwrap_or(f64::NAN)
    }
    fn worst(&self) -> f64 {
        self.rows
            .iter()
            .map(|r| r.rmse_deg)
            .fold(f64::NAN, f64::max)
    }
    fn zero(&self) -> Option<f64> {
        self.median(|r| Some(r.zero_rmse_deg))
    }
    fn yardstick(&self) -> Option<f64> {
        self.median(|r| r.yardstick_rmse_deg)
    }
    fn mean_nees(&self) -> f64 {
        let finite: Vec<f64> = self
            .rows
            .iter()
            .map(|r| r.nees)
            .filter(|n| n.is_finite())
            .collect();
        if finite.is_empty() {
            f64::NAN
        } else {
            finite.iter().sum::<f64>() / finite.len() as f64
        }
    }
    fn beating_zero(&self) -> usize {
        self.rows.iter().filter(|r| r.beats_zero()).count()
    }
    fn matching_yardstick(&self) -> (usize, usize) {
        let known: Vec<bool> = self
            .rows
            .iter()
            .filter_map(|r| r.matches_yardstick())
            .collect();
        (known.iter().filter(|m| **m).count(), known.len())
    }
}

fn median(mut values: Vec<f64>) -> Option<f64> {
    values.retain(|v| v.is_finite());
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let mid = values.len() / 2;
    Some(if values.len() % 2 == 1 {
        values[mid]
    } else {
        0.5 * (values[mid - 1] + values[mid])
    })
}

/// Groups in the order sources first appear, then by model and estimator.
fn groups(rows: &[AccuracyRow]) -> Vec<Group> {
    let mut sources: Vec<&str> = Vec::new();
    for r in rows {
        if !sources.contains(&r.source.as_str()) {
            sources.push(&r.source);
        }
    }
    let mut keyed: BTreeMap<(usize, String, String, bool), Vec<AccuracyRow>> = BTreeMap::new();
    for r in rows {
        let source = sources.iter().position(|s| *s == r.source).unwrap_or(0);
        keyed
            .entry((
                source,
                r.model.clone(),
                r.estimator.clone(),
                !r.wheel_speeds,
            ))
            .or_default()
            .push(r.clone());
    }
    keyed
        .into_iter()
        .map(|((source, model, estimator, no_speeds), rows)| Group {
            source: sources[source].to_string(),
            model,
            estimator,
            wheel_speeds: !no_speeds,
            rows,
        })
        .collect()
}

fn cases(n: usize) -> String {
    if n == 1 {
        "1 case".into()
    } else {
        format!("{n} cases")
    }
}

fn deg(value: Option<f64>) -> String {
    value
        .filter(|v| v.is_finite())
        .map_or("-".into(), |v| format!("{v:.3}"))
}

/// The report's opening section: the figure, the headline table, what holds and what does not,
/// and every group's figures folded. `png` is written; `relative_png` is how the report names it.
pub fn section(
    doc: &mut Document,
    rows: &[AccuracyRow],
    png: &Path,
    relative_png: &str,
) -> Result<()> {
    doc.heading(2, "The answer: how accurate is the sideslip estimate?");
    if rows.is_empty() {
        doc.paragraph(
            "No study scored the sideslip in this run, so there is no answer to show; the failures are listed below.",
        );
        return Ok(());
    }
    let groups = groups(rows);
    let sources: Vec<String> = groups.iter().fold(Vec::new(), |mut seen, g| {
        if !seen.contains(&g.source) {
            seen.push(g.source.clone());
        }
        seen
    });
    doc.paragraph(format!(
        "Sideslip RMSE of every estimator and model, from {}, beside two answers that need no filter: \
         zero sideslip, and the steady-state linear single-track formula \
         β = (lr − m lf vx² / (L C_r)) · r_ss / vx with r_ss = vx δ / (L (1 + K vx²)) from the road-wheel \
         angle and the measured speed (`fmi_master::yardstick`). A filter earns its place where its bar \
         ends left of both marks. The FMU's default is the EKF on the grip model (A+grip).",
        sources.join(" and ")
    ));
    draw_figure(&groups, &sources, png)?;
    doc.image(
        relative_png,
        "Sideslip RMSE (deg, log scale): bar = median over the cases, dots = each case, black tick = answering zero, orange triangle = the steady-state formula",
    );
    doc.list(verdicts(&groups, &sources));
    headline_table(doc, &groups, &sources);
    doc.paragraph("Every estimator and model, per source:");
    doc.table(group_header(), groups.iter().map(group_row).collect());
    Ok(())
}

fn draw_figure(groups: &[Group], sources: &[String], png: &Path) -> Result<()> {
    let bars: Vec<ErrorBar> = groups
        .iter()
        .map(|g| ErrorBar {
            label: g.label(),
            group: sources.iter().position(|s| *s == g.source).unwrap_or(0),
            cases: g.rows.iter().map(|r| r.rmse_deg).collect(),
            bar: g.rmse(),
            first_mark: g.zero(),
            second_mark: g.yardstick(),
        })
        .collect();
    let legend = ErrorChartLegend {
        groups: sources.to_vec(),
        cases: "one case".into(),
        first_mark: "zero sideslip".into(),
        second_mark: "steady-state formula".into(),
    };
    plot::draw_error_bars(
        png,
        "Sideslip RMSE per estimator and model",
        "sideslip RMSE [deg] (median over the cases)",
        &bars,
        &legend,
        0.01,
    )
}

/// What holds and what does not, in sentences computed from the rows.
fn verdicts(groups: &[Group], sources: &[String]) -> Vec<String> {
    let mut lines = Vec::new();
    for source in sources {
        let of_source: Vec<&Group> = groups.iter().filter(|g| &g.source == source).collect();
        for default in of_source
            .iter()
            .filter(|g| g.rows.iter().all(|r| r.is_default()))
        {
            let (matching, known) = default.matching_yardstick();
            let yardstick = if known == 0 {
                "the steady-state formula not computed".to_string()
            } else {
                format!(
                    "within {YARDSTICK_MARGIN_DEG}° of the steady-state formula or better in {matching} of {known}"
                )
            };
            lines.push(format!(
                "**{source}, the default ({}):** median {}°, worst {}° over {}; better than zero in {} of {}; {yardstick}; mean NEES {:.2} (honest: {}–{}).",
                default.label(),
                deg(Some(default.rmse())),
                deg(Some(default.worst())),
                cases(default.rows.len()),
                default.beating_zero(),
                default.rows.len(),
                default.mean_nees(),
                NEES_BAND.0,
                NEES_BAND.1,
            ));
        }
        let rows: Vec<&AccuracyRow> = of_source.iter().flat_map(|g| &g.rows).collect();
        let worse: Vec<&&AccuracyRow> = rows.iter().filter(|r| !r.beats_zero()).collect();
        let best = of_source
            .iter()
            .min_by(|a, b| a.rmse().total_cmp(&b.rmse()))
            .map(|g| format!("{} ({}°)", g.label(), deg(Some(g.rmse()))))
            .unwrap_or_default();
        lines.push(format!(
            "**{source}:** lowest median {best}; {} of {} runs of all estimators are worse than answering zero{}.",
            worse.len(),
            rows.len(),
            worst_cases(&worse),
        ));
        let dishonest: Vec<String> = of_source
            .iter()
            .filter(|g| {
                let n = g.mean_nees();
                n.is_finite() && !(NEES_BAND.0..=NEES_BAND.1).contains(&n)
            })
            .map(|g| format!("{} ({:.1})", g.label(), g.mean_nees()))
            .collect();
        if !dishonest.is_empty() {
            lines.push(format!(
                "**{source}:** mean NEES outside {}–{} (the std does not match the error): {}.",
                NEES_BAND.0,
                NEES_BAND.1,
                dishonest.join(", ")
            ));
        }
    }
    lines
}

/// The three runs furthest above zero, for the verdict line.
fn worst_cases(worse: &[&&AccuracyRow]) -> String {
    let mut sorted: Vec<&&&AccuracyRow> = worse.iter().collect();
    sorted
        .sort_by(|a, b| (b.rmse_deg - b.zero_rmse_deg).total_cmp(&(a.rmse_deg - a.zero_rmse_deg)));
    let named: Vec<String> = sorted
        .iter()
        .take(3)
        .map(|r| {
            format!(
                "{} on {} in {}: {:.2}° against {:.2}°",
                r.estimator, r.model, r.case, r.rmse_deg, r.zero_rmse_deg
            )
        })
        .collect();
    if named.is_empty() {
        String::new()
    } else {
        format!(" (furthest: {})", named.join("; "))
    }
}

/// Per source the default and the best group of each model: the table a reader needs first.
fn headline_table(doc: &mut Document, groups: &[Group], sources: &[String]) {
    let mut chosen: Vec<&Group> = Vec::new();
    for source in sources {
        let of_source: Vec<&Group> = groups.iter().filter(|g| &g.source == source).collect();
        chosen.extend(
            of_source
                .iter()
                .filter(|g| g.rows.iter().all(|r| r.is_default())),
        );
        let mut models: Vec<&str> = of_source.iter().map(|g| g.model.as_str()).collect();
        models.dedup();
        for model in models {
            if let Some(best) = of_source
                .iter()
                .filter(|g| g.model == model && !chosen.iter().any(|c| std::ptr::eq(*c, **g)))
                .min_by(|a, b| a.rmse().total_cmp(&b.rmse()))
            {
                chosen.push(best);
            }
        }
    }
    doc.paragraph("Per source, the default and the best estimator of each model:");
    doc.table(group_header(), chosen.into_iter().map(group_row).collect());
}

fn group_header() -> Vec<String> {
    [
        "source",
        "estimator on model",
        "cases",
        "median RMSE (deg)",
        "worst (deg)",
        "zero (deg)",
        "formula (deg)",
        "better than zero",
        "mean NEES",
    ]
    .map(String::from)
    .to_vec()
}

fn group_row(g: &Group) -> Vec<String> {
    vec![
        g.source.clone(),
        g.label(),
        g.rows.len().to_string(),
        deg(Some(g.rmse())),
        deg(Some(g.worst())),
        deg(g.zero()),
        deg(g.yardstick()),
        format!("{} / {}", g.beating_zero(), g.rows.len()),
        if g.mean_nees().is_finite() {
            format!("{:.2}", g.mean_nees())
        } else {
            "-".into()
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(estimator: &str, model: &str, rmse: f64, zero: f64) -> AccuracyRow {
        AccuracyRow {
            source: SIMULATED.into(),
            case: "escort step".into(),
            model: model.into(),
            estimator: estimator.into(),
            wheel_speeds: true,
            rmse_deg: rmse,
            nees: 1.0,
            zero_rmse_deg: zero,
            yardstick_rmse_deg: Some(0.3),
            max_vx_error_mps: None,
        }
    }

    #[test]
    fn rows_read_back_as_written_with_the_exact_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rows.csv");
        let mut rows = vec![row("EKF", "A+grip", 0.1234567891234, 1.5)];
        rows[0].yardstick_rmse_deg = None;
        rows[0].max_vx_error_mps = Some(0.25);
        write_rows(&path, &rows).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with(
            "source,case,model,estimator,wheel_speeds,rmse_deg,nees,zero_rmse_deg,yardstick_rmse_deg,max_vx_error_mps\n"
        ));
        assert_eq!(read_rows(&[path]).unwrap(), rows);
    }

    #[test]
    fn a_file_with_another_header_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("other.csv");
        std::fs::write(&path, "source,case\nx,y\n").unwrap();
        let error = format!("{:#}", read_rows(&[path]).unwrap_err());
        assert!(
            error.contains("other.csv") && error.contains("expected exactly source,case,model")
        );
    }

    #[test]
    fn a_campaign_instance_is_named_by_its_estimator_kind() {
        assert_eq!(estimator_kind("UKF_scaled_G"), "UKF_scaled");
        assert_eq!(estimator_kind("EKF_A"), "EKF");
        assert_eq!(estimator_kind("Luenberger"), "Luenberger");
    }

    #[test]
    fn the_verdicts_name_the_default_and_the_runs_worse_than_zero() {
        let rows = vec![
            row("EKF", "A+grip", 0.1, 1.0),
            row("EKF", "A+grip", 0.3, 1.0),
            row("UKF", "B", 2.0, 1.0),
        ];
        let groups = groups(&rows);
        let lines = verdicts(&groups, &[SIMULATED.to_string()]);
        assert!(
            lines[0].contains("the default (EKF on A+grip)"),
            "{lines:?}"
        );
        assert!(lines[0].contains("median 0.200°"), "{lines:?}");
        assert!(lines[0].contains("better than zero in 2 of 2"), "{lines:?}");
        assert!(
            lines[0].contains("formula or better in 2 of 2"),
            "{lines:?}"
        );
        assert!(lines[1].contains("1 of 3 runs"), "{lines:?}");
        assert!(
            lines[1].contains("UKF on B in escort step: 2.00° against 1.00°"),
            "{lines:?}"
        );
    }
}
