//! `model.png`, the model icon FMI 2.0 (section 2.3, "model.png // Optional image file of model
//! icon") places at the root of the archive, drawn here from geometry so that it needs no image
//! file in the repository and comes out with the same bytes on every run (no fonts, no clock, a
//! fixed PNG encoder from the workspace lock).
//!
//! Both icons show a car from above, turning left, with its velocity vector at the sideslip angle
//! beta from its heading (ISO 8855: positive to the left); the ReferenceVehicle's adds the path it
//! drives, the estimator's the one-sigma cone of its sideslip estimate.

use anyhow::{anyhow, Context, Result};
use plotters::prelude::*;

/// Width and height in pixels (FMI 2.0 sets no size; tools scale the icon down).
pub const ICON_SIZE: u32 = 128;

/// What the icon adds to the common car drawing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Icon {
    /// The true motion: the path the car drives.
    ReferenceVehicle,
    /// The estimate: the velocity direction with its one-sigma cone.
    Estimator,
}

const BACKGROUND: RGBColor = RGBColor(24, 52, 86);
const BODY: RGBColor = RGBColor(210, 218, 226);
const TYRE: RGBColor = RGBColor(20, 20, 24);
const HEADING: RGBColor = RGBColor(250, 250, 250);
const VELOCITY: RGBColor = RGBColor(255, 150, 30);
const ESTIMATE: RGBColor = RGBColor(90, 220, 120);

/// Drawing geometry in pixels and radians: heading of the car on screen (to the left of up),
/// sideslip angle, front road-wheel angle.
const CENTRE: (f64, f64) = (64.0, 70.0);
const YAW: f64 = 0.35;
const SIDESLIP: f64 = 0.30;
const STEER: f64 = 0.35;
const SIGMA_CONE: f64 = 0.16;

/// Screen pixel of the vehicle-frame point (x forward, y left) of a car at [`CENTRE`] turned by
/// [`YAW`]; screen y points down, so forward is (-sin, -cos) and left (-cos, sin).
fn screen(x: f64, y: f64) -> (i32, i32) {
    let (sin, cos) = YAW.sin_cos();
    let px = CENTRE.0 - x * sin - y * cos;
    let py = CENTRE.1 - x * cos + y * sin;
    (px.round() as i32, py.round() as i32)
}

/// Corners of a rectangle of the given length (along x) and width, centred at (x, y) and turned
/// by `angle` in the vehicle frame.
fn rectangle(x: f64, y: f64, length: f64, width: f64, angle: f64) -> Vec<(i32, i32)> {
    let (sin, cos) = angle.sin_cos();
    [(1.0, 1.0), (1.0, -1.0), (-1.0, -1.0), (-1.0, 1.0)]
        .iter()
        .map(|(a, b)| {
            let (dx, dy) = (a * length / 2.0, b * width / 2.0);
            screen(x + dx * cos - dy * sin, y + dx * sin + dy * cos)
        })
        .collect()
}

/// Points on a circle arc around the centre of gravity, angles in the vehicle frame.
fn arc(radius: f64, from: f64, to: f64, points: usize) -> Vec<(i32, i32)> {
    (0..=points)
        .map(|i| {
            let angle = from + (to - from) * i as f64 / points as f64;
            screen(radius * angle.cos(), radius * angle.sin())
        })
        .collect()
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;
type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

fn draw_car(area: &Area) -> DrawResult {
    area.draw(&Polygon::new(
        rectangle(0.0, 0.0, 66.0, 32.0, 0.0),
        BODY.filled(),
    ))?;
    for (x, y, angle) in [
        (21.0, 17.0, STEER),
        (21.0, -17.0, STEER),
        (-21.0, 17.0, 0.0),
        (-21.0, -17.0, 0.0),
    ] {
        area.draw(&Polygon::new(
            rectangle(x, y, 15.0, 6.0, angle),
            TYRE.filled(),
        ))?;
    }
    // Windscreen, so that front and back differ at a glance.
    area.draw(&Polygon::new(
        rectangle(10.0, 0.0, 8.0, 24.0, 0.0),
        BACKGROUND.mix(0.6).filled(),
    ))?;
    Ok(())
}

/// The ReferenceVehicle's path: a left-hand circle tangent to the velocity at the centre of
/// gravity, drawn under the car.
fn draw_path(area: &Area) -> DrawResult {
    let radius = 150.0;
    let centre = (-radius * SIDESLIP.sin(), radius * SIDESLIP.cos());
    let path = (0..=40).map(|i| {
        let angle = SIDESLIP - 1.2 + 1.9 * i as f64 / 40.0 - std::f64::consts::FRAC_PI_2;
        screen(
            centre.0 + radius * angle.cos(),
            centre.1 + radius * angle.sin(),
        )
    });
    area.draw(&PathElement::new(
        path.collect::<Vec<_>>(),
        VELOCITY.mix(0.5).stroke_width(3),
    ))?;
    Ok(())
}

/// The estimator's one-sigma cone around the velocity direction.
fn draw_cone(area: &Area) -> DrawResult {
    let mut cone = vec![screen(0.0, 0.0)];
    cone.extend(arc(58.0, SIDESLIP - SIGMA_CONE, SIDESLIP + SIGMA_CONE, 12));
    area.draw(&Polygon::new(cone, ESTIMATE.mix(0.55).filled()))?;
    Ok(())
}

/// Heading, sideslip arc and velocity arrow from the centre of gravity.
fn draw_motion(area: &Area) -> DrawResult {
    area.draw(&PathElement::new(
        vec![screen(0.0, 0.0), screen(58.0, 0.0)],
        HEADING.stroke_width(2),
    ))?;
    area.draw(&PathElement::new(
        arc(26.0, 0.0, SIDESLIP, 10),
        HEADING.stroke_width(2),
    ))?;
    let tip = (58.0 * SIDESLIP.cos(), 58.0 * SIDESLIP.sin());
    area.draw(&PathElement::new(
        vec![screen(0.0, 0.0), screen(tip.0, tip.1)],
        VELOCITY.stroke_width(4),
    ))?;
    let head = [SIDESLIP + 2.7, SIDESLIP - 2.7]
        .map(|a| screen(tip.0 + 12.0 * a.cos(), tip.1 + 12.0 * a.sin()));
    area.draw(&Polygon::new(
        vec![screen(tip.0, tip.1), head[0], head[1]],
        VELOCITY.filled(),
    ))?;
    area.draw(&Circle::new(screen(0.0, 0.0), 4, VELOCITY.filled()))?;
    Ok(())
}

/// The RGB pixels of the icon, row by row.
pub fn icon_pixels(icon: Icon) -> Result<Vec<u8>> {
    let mut rgb = vec![0u8; (ICON_SIZE * ICON_SIZE * 3) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut rgb, (ICON_SIZE, ICON_SIZE)).into_drawing_area();
        let drawn: DrawResult = (|| {
            area.fill(&BACKGROUND)?;
            if icon == Icon::ReferenceVehicle {
                draw_path(&area)?;
            }
            draw_car(&area)?;
            if icon == Icon::Estimator {
                draw_cone(&area)?;
            }
            draw_motion(&area)?;
            area.present()?;
            Ok(())
        })();
        drawn.map_err(|error| anyhow!("drawing the {icon:?} icon: {error}"))?;
    }
    Ok(rgb)
}

/// The icon as PNG bytes (8-bit RGB, the png crate's default compression: deterministic).
pub fn model_png(icon: Icon) -> Result<Vec<u8>> {
    let rgb = icon_pixels(icon)?;
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, ICON_SIZE, ICON_SIZE);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .context("writing the PNG header of model.png")?;
    writer
        .write_image_data(&rgb)
        .context("writing the pixels of model.png")?;
    writer.finish().context("finishing model.png")?;
    Ok(bytes)
}
