//! PNG plots with plotters. The DejaVu Sans font (harness/master/assets, Bitstream Vera licence) is
//! compiled into the binary and registered with plotters' ab_glyph backend, so plots render the
//! same on a machine without any system font.

use std::path::Path;
use std::sync::Once;

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::cosim::RunResult;
use crate::scenario::{Scenario, VarRef};
use crate::scoring::matching_columns;

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();
const FAMILY: &str = "sans-serif";

fn register_font() {
    REGISTER.call_once(|| {
        // The bytes are a valid TrueType font shipped with the crate; a failure would be a
        // packaging error that the plot tests catch.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

/// One line in a panel.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// The reference line (drawn thick, red, underneath).
    pub is_truth: bool,
}

#[derive(Clone, Debug)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

/// Colours of the estimators in order of appearance (seed 000 uses blue EKF, magenta UKF, green
/// LKF against a red reference; our scenarios list LKF, EKF, UKF, UKF scaled, ...).
const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 150, 0),
    RGBColor(0, 70, 220),
    RGBColor(210, 0, 210),
    RGBColor(240, 140, 0),
    RGBColor(0, 170, 190),
    RGBColor(120, 70, 20),
    RGBColor(90, 90, 90),
    RGBColor(160, 160, 0),
];
const TRUTH: RGBColor = RGBColor(220, 0, 0);
/// Series with at most this many points are drawn with point markers.
const MARKED_POINTS: usize = 60;

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let mut range: Option<(f64, f64)> = None;
    for v in values.filter(|v| v.is_finite()) {
        range = Some(match range {
            None => (v, v),
            Some((lo, hi)) => (lo.min(v), hi.max(v)),
        });
    }
    range
}

/// Draw `panels` in a grid of `columns` columns into a PNG at `path`.
pub fn draw_panels(path: &Path, title: &str, panels: &[Panel], columns: usize) -> Result<()> {
    register_font();
    let columns = columns.max(1).min(panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    let size = (620 * columns as u32, 330 * rows as u32 + 40);
    let root = BitMapBackend::new(path, size).into_drawing_area();
    let fail = |e: &dyn std::fmt::Display| anyhow!("plot {}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let root = root
        .titled(title, (FAMILY, 22).into_font())
        .map_err(|e| fail(&e))?;
    let areas = root.split_evenly((rows, columns));
    for (area, panel) in areas.iter().zip(panels) {
        let x = finite_range(panel.series.iter().flat_map(|s| s.x.iter().copied()));
        let y = finite_range(panel.series.iter().flat_map(|s| s.y.iter().copied()));
        let (Some((x0, x1)), Some((y0, y1))) = (x, y) else {
            continue;
        };
        let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
        let span = (y1 - y0).max(1e-9 * y0.abs().max(1e-12));
        let (y0, y1) = (y0 - 0.08 * span, y1 + 0.08 * span);
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, (FAMILY, 16).into_font())
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(72)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| fail(&e))?;
        // An axis of a few whole numbers (EM iterations) is labelled at the whole numbers only.
        let whole_numbers = panel
            .series
            .iter()
            .flat_map(|s| s.x.iter())
            .all(|x| x.fract() == 0.0)
            && x1 - x0 <= 20.0;
        let x_labels = if whole_numbers {
            (x1 - x0) as usize + 1
        } else {
            10
        };
        chart
            .configure_mesh()
            .x_labels(x_labels)
            .x_label_formatter(&|x| {
                if whole_numbers {
                    format!("{x:.0}")
                } else {
                    format!("{x}")
                }
            })
            .x_desc(panel.x_label.as_str())
            .y_desc(panel.y_label.as_str())
            .label_style((FAMILY, 12).into_font())
            .axis_desc_style((FAMILY, 13).into_font())
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(|e| fail(&e))?;
        let mut colour = 0;
        for series in &panel.series {
            let style = if series.is_truth {
                TRUTH.stroke_width(3)
            } else {
                let c = PALETTE[colour % PALETTE.len()];
                colour += 1;
                c.stroke_width(1)
            };
            let points = series
                .x
                .iter()
                .zip(&series.y)
                .filter(|(a, b)| a.is_finite() && b.is_finite())
                .map(|(a, b)| (*a, *b));
            let points: Vec<(f64, f64)> = points.collect();
            // A short series (an iteration history) gets a marker on every point, so that the
            // individual iterations stay visible; time series have thousands of points, and a
            // constant series is a reference level.
            let constant = points.len() > 1 && points.windows(2).all(|w| w[0].1 == w[1].1);
            if !series.is_truth && !constant && points.len() <= MARKED_POINTS {
                chart
                    .draw_series(
                        points
                            .iter()
                            .map(|p| Circle::new(*p, 3, style.color.filled())),
                    )
                    .map_err(|e| fail(&e))?;
            }
            chart
                .draw_series(LineSeries::new(points, style))
                .map_err(|e| fail(&e))?
                .label(series.name.as_str())
                .legend(move |(px, py)| PathElement::new(vec![(px, py), (px + 18, py)], style));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font((FAMILY, 12).into_font())
            .draw()
            .map_err(|e| fail(&e))?;
    }
    root.present().map_err(|e| fail(&e))?;
    Ok(())
}

/// Panels "estimators against truth" for the scenario's score labels (in scenario order),
/// values multiplied by each score's display scale.
pub fn estimate_panels(scenario: &Scenario, result: &RunResult, labels: &[String]) -> Vec<Panel> {
    let mut panels = Vec::new();
    for label in labels {
        let Some(section) = scenario.scores.iter().find(|s| &s.label == label) else {
            continue;
        };
        let Some(truth) = result.column(&section.truth) else {
            continue;
        };
        let (scale, unit) = section.display();
        let truth_name = VarRef::parse(&section.truth)
            .map(|r| format!("truth ({})", r.instance))
            .unwrap_or_else(|| "truth".into());
        let mut series = vec![Series {
            name: truth_name,
            x: result.times.clone(),
            y: truth.iter().map(|v| v * scale).collect(),
            is_truth: true,
        }];
        for (instance, column) in matching_columns(result, &section.estimate) {
            series.push(Series {
                name: instance,
                x: result.times.clone(),
                y: result.data[column].iter().map(|v| v * scale).collect(),
                is_truth: false,
            });
        }
        panels.push(Panel {
            title: label.clone(),
            x_label: "t [s]".into(),
            y_label: if unit.is_empty() {
                label.clone()
            } else {
                format!("{label} [{unit}]")
            },
            series,
        });
    }
    panels
}

/// Panels of the manoeuvre's signals as recorded (steering wheel in degrees, torques) and, for a
/// closed-loop manoeuvre, the driven path against the course centre line.
pub fn manoeuvre_panels(result: &RunResult, course: Option<&dyn Fn(f64) -> f64>) -> Vec<Panel> {
    let mut panels = Vec::new();
    let line = |column: &str, scale: f64| {
        result.column(column).map(|v| Series {
            name: column.to_string(),
            x: result.times.clone(),
            y: v.iter().map(|x| x * scale).collect(),
            is_truth: false,
        })
    };
    if let Some(s) = line(
        "manoeuvre.steering_wheel_angle",
        180.0 / std::f64::consts::PI,
    ) {
        panels.push(Panel {
            title: "steering-wheel angle".into(),
            x_label: "t [s]".into(),
            y_label: "[deg]".into(),
            series: vec![s],
        });
    }
    let torques: Vec<Series> = ["manoeuvre.drive_torque", "manoeuvre.brake_torque"]
        .iter()
        .filter_map(|c| line(c, 1.0))
        .collect();
    if !torques.is_empty() {
        panels.push(Panel {
            title: "drive and brake torque".into(),
            x_label: "t [s]".into(),
            y_label: "[N·m]".into(),
            series: torques,
        });
    }
    if let (Some(x), Some(y), Some(course)) =
        (result.column("driver.x"), result.column("driver.y"), course)
    {
        panels.push(Panel {
            title: "path: driven (master-integrated) vs course centre line".into(),
            x_label: "x [m]".into(),
            y_label: "y [m]".into(),
            series: vec![
                Series {
                    name: "course".into(),
                    x: x.to_vec(),
                    y: x.iter().map(|&p| course(p)).collect(),
                    is_truth: true,
                },
                Series {
                    name: "vehicle".into(),
                    x: x.to_vec(),
                    y: y.to_vec(),
                    is_truth: false,
                },
            ],
        });
    }
    panels
}

/// One row of an error chart: a label, the values of every case (dots), the bar's value (for
/// example their median) and up to two reference marks (answers without a filter).
#[derive(Clone, Debug)]
pub struct ErrorBar {
    pub label: String,
    /// Which group (colour) the row belongs to, e.g. its data source.
    pub group: usize,
    pub cases: Vec<f64>,
    pub bar: f64,
    /// Drawn as a black vertical tick.
    pub first_mark: Option<f64>,
    /// Drawn as an orange triangle.
    pub second_mark: Option<f64>,
}

/// Legend of an error chart: what the groups (bar colours), the dots and the marks are.
#[derive(Clone, Debug)]
pub struct ErrorChartLegend {
    pub groups: Vec<String>,
    pub cases: String,
    pub first_mark: String,
    pub second_mark: String,
}

/// Draws `rows` as horizontal bars on a logarithmic axis from `floor` into a PNG at `path`: one
/// line per row, labelled on the left, the cases as dots on the bar. Values below `floor` are
/// drawn at it; non-finite values are left out.
pub fn draw_error_bars(
    path: &Path,
    title: &str,
    x_label: &str,
    rows: &[ErrorBar],
    legend: &ErrorChartLegend,
    floor: f64,
) -> Result<()> {
    register_font();
    let fail = |e: &dyn std::fmt::Display| anyhow!("plot {}: {e}", path.display());
    let values = rows.iter().flat_map(|r| {
        r.cases
            .iter()
            .copied()
            .chain([r.bar])
            .chain(r.first_mark)
            .chain(r.second_mark)
    });
    let top = finite_range(values)
        .map_or(1.0, |(_, hi)| hi)
        .max(floor * 10.0)
        * 1.5;
    let height = 90 + 24 * rows.len().max(1) as u32 + 30;
    let root = BitMapBackend::new(path, (1000, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let (area, legend_area) = root.split_vertically(height - 30);
    let n = rows.len().max(1) as f64;
    let labels: Vec<String> = rows.iter().map(|r| r.label.clone()).collect();
    let mut chart = ChartBuilder::on(&area)
        .caption(title, (FAMILY, 18).into_font())
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(250)
        .build_cartesian_2d((floor..top).log_scale(), -0.5..n - 0.5)
        .map_err(|e| fail(&e))?;
    chart
        .configure_mesh()
        .y_labels(rows.len().max(1) * 2 + 1)
        .y_label_formatter(&|y| {
            let index = y.round();
            if (y - index).abs() > 1e-6 || index < 0.0 {
                return String::new();
            }
            // Row 0 at the top.
            let row = labels.len() as f64 - 1.0 - index;
            labels.get(row as usize).cloned().unwrap_or_default()
        })
        .x_desc(x_label)
        .x_label_formatter(&|x| format!("{x}"))
        .label_style((FAMILY, 12).into_font())
        .axis_desc_style((FAMILY, 13).into_font())
        .disable_y_mesh()
        .draw()
        .map_err(|e| fail(&e))?;
    let clamp = |v: f64| v.max(floor).min(top);
    let y_of = |i: usize| n - 1.0 - i as f64;
    let colour = |group: usize| PALETTE[(group + 1) % PALETTE.len()];
    let bars = rows.iter().enumerate().filter(|(_, r)| r.bar.is_finite());
    chart
        .draw_series(bars.map(|(i, r)| {
            let y = y_of(i);
            Rectangle::new(
                [(floor, y - 0.32), (clamp(r.bar), y + 0.32)],
                colour(r.group).mix(0.45).filled(),
            )
        }))
        .map_err(|e| fail(&e))?;
    let dots = rows.iter().enumerate().flat_map(|(i, r)| {
        let y = y_of(i);
        r.cases
            .iter()
            .filter(|v| v.is_finite())
            .map(move |&v| Circle::new((clamp(v), y), 2, colour(r.group).filled()))
    });
    chart.draw_series(dots).map_err(|e| fail(&e))?;
    let ticks = rows.iter().enumerate().filter_map(|(i, r)| {
        let v = r.first_mark.filter(|v| v.is_finite())?;
        let y = y_of(i);
        Some(PathElement::new(
            vec![(clamp(v), y - 0.42), (clamp(v), y + 0.42)],
            BLACK.stroke_width(3),
        ))
    });
    chart.draw_series(ticks).map_err(|e| fail(&e))?;
    let diamonds = rows.iter().enumerate().filter_map(|(i, r)| {
        let v = r.second_mark.filter(|v| v.is_finite())?;
        Some(TriangleMarker::new(
            (clamp(v), y_of(i)),
            6,
            YARDSTICK.filled(),
        ))
    });
    chart.draw_series(diamonds).map_err(|e| fail(&e))?;
    draw_error_legend(&legend_area, legend).map_err(|e| fail(&e))?;
    root.present().map_err(|e| fail(&e))?;
    Ok(())
}

const YARDSTICK: RGBColor = RGBColor(230, 120, 0);

/// The legend line under an error chart.
fn draw_error_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    legend: &ErrorChartLegend,
) -> Result<()> {
    let fail = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("legend: {e}");
    let font = (FAMILY, 12).into_font();
    let y = 15;
    let mut x = 20;
    for (group, name) in legend.groups.iter().enumerate() {
        let c = PALETTE[(group + 1) % PALETTE.len()];
        root.draw(&Rectangle::new(
            [(x, y - 6), (x + 18, y + 6)],
            c.mix(0.45).filled(),
        ))
        .map_err(fail)?;
        root.draw(&Text::new(name.clone(), (x + 22, y - 7), font.clone()))
            .map_err(fail)?;
        x += 30 + 7 * name.chars().count() as i32;
    }
    root.draw(&Circle::new((x, y), 3, BLACK.filled()))
        .map_err(fail)?;
    root.draw(&Text::new(
        legend.cases.clone(),
        (x + 8, y - 7),
        font.clone(),
    ))
    .map_err(fail)?;
    x += 18 + 7 * legend.cases.chars().count() as i32;
    root.draw(&PathElement::new(
        vec![(x, y - 7), (x, y + 7)],
        BLACK.stroke_width(3),
    ))
    .map_err(fail)?;
    root.draw(&Text::new(
        legend.first_mark.clone(),
        (x + 8, y - 7),
        font.clone(),
    ))
    .map_err(fail)?;
    x += 18 + 7 * legend.first_mark.chars().count() as i32;
    root.draw(&TriangleMarker::new((x, y), 6, YARDSTICK.filled()))
        .map_err(fail)?;
    root.draw(&Text::new(
        legend.second_mark.clone(),
        (x + 10, y - 7),
        font,
    ))
    .map_err(fail)?;
    Ok(())
}
