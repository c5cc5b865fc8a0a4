//! Per-view error bars: each frame's RMS reprojection error in stamp order, used views
//! in blue, rejected ones in red with the reason as their tooltip.

use std::fmt::Write;

use super::ReportError;
use super::html::camera_figure;
use super::svg::{draw_chart, inline, rect};
use super::views::{CameraViews, FrameUse, stamp_text};

const SIZE: (u32, u32) = (640, 300);
const USED: &str = "#3b6fb6";
const REJECTED: &str = "#d9472b";
/// A rejected view's bar is drawn at most this many times the largest used view's RMS
/// high, so that one very bad view does not flatten the others.
const CLIP_RATIO: f64 = 3.0;

/// The per-view error bar chart of one camera, as an HTML figure. Every frame has one
/// bar: class `view-bar used` (height: the view's RMS) or `view-bar rejected` (height:
/// its RMS when the solver measured one, otherwise a pale band over the whole height).
pub(crate) fn chart(camera: &CameraViews) -> Result<String, ReportError> {
    let frames = &camera.frames;
    let used_max = frames
        .iter()
        .filter_map(|f| match f.status {
            FrameUse::Used { fit, .. } => Some(fit.rms),
            FrameUse::Rejected { .. } => None,
        })
        .fold(0.0, f64::max);
    let rejected_max = frames
        .iter()
        .filter_map(|f| match f.status {
            FrameUse::Rejected { rms, .. } => rms,
            FrameUse::Used { .. } => None,
        })
        .fold(0.0, f64::max);
    let top = if used_max > 0.0 {
        used_max.max(rejected_max.min(CLIP_RATIO * used_max))
    } else {
        rejected_max.max(1.0)
    } * 1.15;
    let x_range = -0.5..frames.len().max(1) as f64 - 0.5;
    let (document, map) = draw_chart("per-view error", SIZE, x_range, 0.0..top, |chart| {
        chart
            .configure_mesh()
            .disable_x_mesh()
            .max_light_lines(1)
            .x_labels(frames.len().clamp(2, 20))
            .x_label_formatter(&|x| {
                if (x - x.round()).abs() < 1e-6 {
                    format!("{}", x.round())
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|y| format!("{y:.2}"))
            .x_desc("frame (stamp order)")
            .y_desc("RMS (px)")
            .draw()
    })?;
    let mut marks = String::new();
    for (i, frame) in frames.iter().enumerate() {
        let x0 = map.x(i as f64 - 0.38);
        let x1 = map.x(i as f64 + 0.38);
        let stamp = stamp_text(&frame.stamp);
        match &frame.status {
            FrameUse::Used { fit, .. } => rect(
                &mut marks,
                (x0, map.y(0.0)),
                (x1, map.y(fit.rms)),
                "view-bar used",
                USED,
                &format!(" data-rms=\"{}\"", fit.rms),
                &format!(
                    "frame {i}, {stamp}: used, RMS {:.3} px, largest corner error {:.3} px",
                    fit.rms, fit.max_error
                ),
            ),
            FrameUse::Rejected { reason, rms } => {
                let title = format!("frame {i}, {stamp}: rejected: {reason}");
                match rms {
                    Some(rms) => {
                        let shown = rms.min(top);
                        rect(
                            &mut marks,
                            (x0, map.y(0.0)),
                            (x1, map.y(shown)),
                            "view-bar rejected",
                            REJECTED,
                            &format!(" data-rms=\"{rms}\""),
                            &title,
                        );
                        if *rms > top {
                            let _ = write!(
                                marks,
                                "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"middle\" fill=\"#fff\">{rms:.2}</text>",
                                0.5 * (x0 + x1),
                                map.y(top) + 12.0
                            );
                        }
                    }
                    None => rect(
                        &mut marks,
                        (x0, map.y(0.0)),
                        (x1, map.y(top)),
                        "view-bar rejected",
                        REJECTED,
                        " fill-opacity=\"0.25\"",
                        &title,
                    ),
                }
            }
        }
    }
    let overall = camera.result.calibration.rms;
    let _ = write!(
        marks,
        "<line class=\"overall-rms\" x1=\"{:.1}\" x2=\"{:.1}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#222\" stroke-dasharray=\"5,4\"><title>camera RMS {overall:.3} px</title></line>",
        map.x(-0.5),
        map.x(frames.len() as f64 - 0.5),
        y = map.y(overall.min(top)),
    );
    let used = frames
        .iter()
        .filter(|f| matches!(f.status, FrameUse::Used { .. }))
        .count();
    let caption = format!(
        "{used} views used (<span style=\"color:{USED}\">blue</span>), {} rejected (<span class=\"rejected\">red</span>; pale full-height bands have no RMS: no board or no pose). Dashed: the camera's RMS, {overall:.3} px. Hover a bar for its stamp and the reason.",
        frames.len() - used
    );
    Ok(camera_figure(
        "per-view",
        camera.name(),
        "",
        &inline(&document, &marks),
        &caption,
    ))
}
