//! Residual scatter: every used corner's residual vector (detected minus reprojected
//! pixel), coloured by view, with the camera's RMS as a circle.

use std::fmt::Write;

use plotters::prelude::*;

use super::ReportError;
use super::html::camera_figure;
use super::svg::{draw_chart, inline};
use super::views::CameraViews;

const SIZE: (u32, u32) = (440, 420);

/// The residual scatter of one camera, as an HTML figure. The y axis points down, as
/// image rows do.
pub(crate) fn chart(camera: &CameraViews) -> Result<String, ReportError> {
    let views: Vec<_> = camera.used().map(|(_, residuals)| residuals).collect();
    let largest = views
        .iter()
        .flat_map(|r| r.iter())
        .map(|r| r.x.abs().max(r.y.abs()))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let half = if largest > 0.0 { largest * 1.1 } else { 1.0 };
    let corners: usize = views.iter().map(|r| r.len()).sum();
    let (document, map) = draw_chart(
        "residual scatter",
        SIZE,
        -half..half,
        half..-half,
        |chart| {
            chart
                .configure_mesh()
                .max_light_lines(1)
                .x_label_formatter(&|x| format!("{x:.2}"))
                .y_label_formatter(&|y| format!("{y:.2}"))
                .x_desc("dx (px)")
                .y_desc("dy (px)")
                .draw()?;
            let count = views.len().max(1) as f64;
            for (k, residuals) in views.iter().enumerate() {
                let colour = HSLColor(k as f64 / count, 0.75, 0.42);
                chart.draw_series(
                    residuals
                        .iter()
                        .map(|r| Circle::new((r.x, r.y), 2, colour.mix(0.7).filled())),
                )?;
            }
            Ok(())
        },
    )?;
    let rms = camera.result.calibration.rms;
    let mut marks = String::new();
    let _ = write!(
        marks,
        "<circle class=\"rms-circle\" cx=\"{:.1}\" cy=\"{:.1}\" r=\"{:.1}\" fill=\"none\" stroke=\"#222\" stroke-dasharray=\"5,4\"><title>RMS {rms:.3} px</title></circle>",
        map.x(0.0),
        map.y(0.0),
        rms * map.x_scale()
    );
    let caption = format!(
        "{corners} corner residuals of {} used views, one colour per view. Dashed circle: the camera's RMS, {rms:.3} px. A pattern (a ring, a drift) rather than a round cloud means the model misses something.",
        views.len()
    );
    Ok(camera_figure(
        "residuals",
        camera.name(),
        &format!(" data-corners=\"{corners}\""),
        &inline(&document, &marks),
        &caption,
    ))
}
