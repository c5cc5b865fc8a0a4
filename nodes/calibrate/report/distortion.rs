//! Distortion field: how far the lens moves each pixel from where the ideal pinhole
//! camera with the same intrinsics would image it, as arrows over the image on a
//! background shaded by the displacement's magnitude.

use std::fmt::Write;

use nalgebra::{Point2, Vector2};
use stereocal_vision::camera::CameraModel;

use super::ReportError;
use super::html::camera_figure;
use super::svg::{heat, image_chart, inline, rect};
use super::views::CameraViews;

/// Arrows across the image, the first and last on the image's border columns.
const ARROW_COLUMNS: usize = 13;
/// Shaded cells across the image.
const SHADE_COLUMNS: usize = 40;
const WIDTH: u32 = 600;

/// How far the lens moves `pixel` (pixel centres at integer coordinates): `pixel`
/// minus where the distortion-free camera sees the same ray; `None` where the lens
/// model has no ray for the pixel.
pub(crate) fn displacement(camera: &CameraModel, pixel: &Point2<f64>) -> Option<Vector2<f64>> {
    let ideal = camera.undistort_pixel(pixel)?;
    let d = pixel - ideal;
    (d.x.is_finite() && d.y.is_finite()).then_some(d)
}

/// Evenly spaced positions from `0` to `last` inclusive, `count` of them (at least 2).
fn positions(last: f64, count: usize) -> impl Iterator<Item = f64> {
    let count = count.max(2);
    (0..count).map(move |i| last * i as f64 / (count - 1) as f64)
}

/// The distortion field of one camera, as an HTML figure with the largest displacement
/// sampled in `data-largest-displacement` (pixels; the samples include the four image
/// corners).
pub(crate) fn chart(camera: &CameraViews) -> Result<String, ReportError> {
    let model = camera.camera();
    let (width, height) = (f64::from(model.width), f64::from(model.height));
    let arrow_rows = ((ARROW_COLUMNS as f64 - 1.0) * height / width).round() as usize + 1;
    let arrows: Vec<(Point2<f64>, Option<Vector2<f64>>)> = positions(height - 1.0, arrow_rows)
        .flat_map(|y| positions(width - 1.0, ARROW_COLUMNS).map(move |x| Point2::new(x, y)))
        .map(|p| (p, displacement(model, &p)))
        .collect();
    let shade_rows = ((SHADE_COLUMNS as f64 * height / width).round() as usize).max(1);
    let (cell_w, cell_h) = (width / SHADE_COLUMNS as f64, height / shade_rows as f64);
    let shades: Vec<(f64, f64, Option<f64>)> = (0..shade_rows)
        .flat_map(|r| (0..SHADE_COLUMNS).map(move |c| (c, r)))
        .map(|(c, r)| {
            let (x0, y0) = (c as f64 * cell_w - 0.5, r as f64 * cell_h - 0.5);
            let centre = Point2::new(x0 + 0.5 * cell_w, y0 + 0.5 * cell_h);
            (x0, y0, displacement(model, &centre).map(|d| d.norm()))
        })
        .collect();
    let mut largest: Option<(Point2<f64>, f64)> = None;
    for (p, d) in &arrows {
        if let Some(d) = d
            && largest.is_none_or(|(_, m)| d.norm() > m)
        {
            largest = Some((*p, d.norm()));
        }
    }
    let shade_max = shades.iter().filter_map(|s| s.2).fold(0.0, f64::max);
    let scale_max = largest.map_or(0.0, |(_, m)| m).max(shade_max);

    let (document, map) = image_chart("distortion field", WIDTH, (width, height))?;

    let mut marks = String::new();
    for (x0, y0, magnitude) in &shades {
        let (fill, title) = match magnitude {
            Some(m) if scale_max > 0.0 => (heat(m / scale_max), format!("{m:.2} px")),
            Some(m) => (heat(0.0), format!("{m:.2} px")),
            None => (
                "#bbbbbb".to_owned(),
                "no ray: the lens model folds here".to_owned(),
            ),
        };
        rect(
            &mut marks,
            (map.x(*x0), map.y(*y0)),
            (map.x(x0 + cell_w), map.y(y0 + cell_h)),
            "distortion-cell",
            &fill,
            "",
            &title,
        );
    }
    // The longest arrow spans about one arrow spacing.
    let spacing = map.x_scale() * (width - 1.0) / (ARROW_COLUMNS - 1) as f64;
    let arrow_scale = if scale_max > 0.0 {
        0.9 * spacing / (scale_max * map.x_scale())
    } else {
        0.0
    };
    for (p, d) in &arrows {
        let Some(d) = d else { continue };
        let (x0, y0) = (map.x(p.x), map.y(p.y));
        let (x1, y1) = (
            map.x(p.x + arrow_scale * d.x),
            map.y(p.y + arrow_scale * d.y),
        );
        let length = ((x1 - x0).powi(2) + (y1 - y0).powi(2)).sqrt();
        let mut path = format!("M{x0:.1} {y0:.1}L{x1:.1} {y1:.1}");
        if length > 1.0 {
            let (ux, uy) = ((x1 - x0) / length, (y1 - y0) / length);
            let head = length.min(7.0);
            for side in [-1.0, 1.0] {
                let _ = write!(
                    path,
                    "M{x1:.1} {y1:.1}L{:.1} {:.1}",
                    x1 - head * (ux - 0.45 * side * uy),
                    y1 - head * (uy + 0.45 * side * ux)
                );
            }
        }
        let _ = write!(
            marks,
            "<path class=\"distortion-arrow\" d=\"{path}\" stroke=\"#1d2f6f\" stroke-width=\"1.3\" fill=\"none\" data-dx=\"{}\" data-dy=\"{}\"><title>({:.0}, {:.0}): moved {:.2} px</title></path>",
            d.x,
            d.y,
            p.x,
            p.y,
            d.norm()
        );
    }
    let (attributes, caption) = match largest {
        Some((at, m)) => (
            format!(" data-largest-displacement=\"{m}\""),
            format!(
                "Arrows: where the lens moves each pixel from its ideal pinhole position (drawn {arrow_scale:.1} times their length). Shading: displacement magnitude, 0 to {scale_max:.2} px. Largest displacement at the sampled points: {m:.3} px at ({:.0}, {:.0}).",
                at.x, at.y
            ),
        ),
        None => (
            String::new(),
            "The lens model has no ray for any sampled pixel.".to_owned(),
        ),
    };
    Ok(camera_figure(
        "distortion",
        camera.name(),
        &attributes,
        &inline(&document, &marks),
        &caption,
    ))
}
