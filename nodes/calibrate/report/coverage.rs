//! Coverage heat-map: how many used corners fell in each cell of a grid over the image,
//! so that the operator sees the parts of the image no view covered.

use std::fmt::Write;

use super::ReportError;
use super::html::camera_figure;
use super::svg::{heat, image_chart, inline, rect};
use super::views::CameraViews;

/// Cells across the image; rows follow the image's aspect ratio.
pub const COVERAGE_COLUMNS: usize = 16;
const WIDTH: u32 = 600;
const EMPTY: &str = "#f6d5d1";

/// Used corners per cell, row-major, over `columns` x `rows` cells of the image.
pub(crate) struct CoverageGrid {
    /// Cells across.
    pub columns: usize,
    /// Cells down.
    pub rows: usize,
    /// Corner count of each cell, row after row.
    pub counts: Vec<usize>,
}

impl CoverageGrid {
    /// Counts the used corners of `camera` per cell. The image spans `[-0.5, width -
    /// 0.5]` across (pixel centres at integer coordinates); corners outside it count in
    /// the nearest cell.
    pub fn new(camera: &CameraViews) -> Self {
        let model = camera.camera();
        let (width, height) = (f64::from(model.width), f64::from(model.height));
        let columns = COVERAGE_COLUMNS;
        let rows = ((columns as f64 * height / width).round() as usize).max(1);
        let mut counts = vec![0; columns * rows];
        for (view, _) in camera.used() {
            for pixel in &view.pixels {
                let cell = |v: f64, size: f64, cells: usize| {
                    let c = ((v + 0.5) / size * cells as f64).floor();
                    if c.is_finite() {
                        (c.max(0.0) as usize).min(cells - 1)
                    } else {
                        0
                    }
                };
                let (c, r) = (cell(pixel.x, width, columns), cell(pixel.y, height, rows));
                counts[r * columns + c] += 1;
            }
        }
        Self {
            columns,
            rows,
            counts,
        }
    }
}

/// The coverage heat-map of one camera, as an HTML figure; each cell is a `rect` of
/// class `coverage-cell` with its count in `data-count`.
pub(crate) fn chart(camera: &CameraViews) -> Result<String, ReportError> {
    let grid = CoverageGrid::new(camera);
    let model = camera.camera();
    let (width, height) = (f64::from(model.width), f64::from(model.height));
    let (document, map) = image_chart("coverage", WIDTH, (width, height))?;
    let most = grid.counts.iter().copied().max().unwrap_or(0).max(1);
    let total: usize = grid.counts.iter().sum();
    let empty = grid.counts.iter().filter(|&&c| c == 0).count();
    let (cell_w, cell_h) = (width / grid.columns as f64, height / grid.rows as f64);
    let mut marks = String::new();
    for r in 0..grid.rows {
        for c in 0..grid.columns {
            let count = grid.counts[r * grid.columns + c];
            let (x0, y0) = (c as f64 * cell_w - 0.5, r as f64 * cell_h - 0.5);
            let (x1, y1) = (x0 + cell_w, y0 + cell_h);
            let fill = if count == 0 {
                EMPTY.to_owned()
            } else {
                heat(0.15 + 0.85 * count as f64 / most as f64)
            };
            rect(
                &mut marks,
                (map.x(x0), map.y(y0)),
                (map.x(x1), map.y(y1)),
                "coverage-cell",
                &fill,
                &format!(" data-count=\"{count}\" stroke=\"#fff\" stroke-width=\"0.5\""),
                &format!("x {x0:.0}..{x1:.0}, y {y0:.0}..{y1:.0}: {count} corners"),
            );
            if count > 0 {
                let _ = write!(
                    marks,
                    "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"9\" text-anchor=\"middle\" fill=\"#333\">{count}</text>",
                    map.x(0.5 * (x0 + x1)),
                    map.y(0.5 * (y0 + y1)) + 3.0
                );
            }
        }
    }
    let caption = format!(
        "{total} corners of the used views over {}x{} cells; {empty} cells (pale red) have none: views with the board there would constrain the lens better.",
        grid.columns, grid.rows
    );
    Ok(camera_figure(
        "coverage",
        camera.name(),
        &format!(" data-corners=\"{total}\""),
        &inline(&document, &marks),
        &caption,
    ))
}
