//! The report's summary, from the calibration's [`CalibrationResult`]: warnings on a
//! result not to trust blindly, each camera's K, D with their standard deviations, RMS
//! and the views used and rejected (stamp and reason); for a pair, `right_from_left`,
//! the baseline and the epipolar error.

use std::fmt::Write;

use super::html::escape;
use super::views::stamp_text;
use crate::calibrate::result::{CalibrationResult, CameraSummary, StereoSummary};
use crate::calibrate::stage::RejectedFrame;

/// The summary as HTML: the warnings first, when the result should not be trusted
/// blindly.
pub(crate) fn summary(result: &CalibrationResult) -> String {
    let mut out = String::new();
    if !result.warnings.is_empty() {
        out.push_str("<ul class=\"warnings\">");
        for warning in &result.warnings {
            let _ = write!(out, "<li class=\"rejected\">{}</li>", escape(warning));
        }
        out.push_str("</ul>\n");
    }
    out.push_str("<div class=\"cameras\">");
    for camera in &result.cameras {
        out.push_str("<div>");
        out.push_str(&camera_summary(camera));
        out.push_str("</div>");
    }
    out.push_str("</div>\n");
    if let Some(stereo) = &result.stereo {
        out.push_str(&stereo_summary(stereo));
    }
    out
}

fn with_std(value: f64, std: Option<f64>, decimals: usize) -> String {
    match std {
        Some(s) => format!("{value:.decimals$} ± {s:.decimals$}"),
        None => format!("{value:.decimals$}"),
    }
}

fn camera_summary(camera: &CameraSummary) -> String {
    let [fx, _, cx, _, fy, cy, ..] = camera.k;
    let std = camera.std_dev.as_ref();
    let mut out = String::new();
    let _ = write!(
        out,
        "<h3>Camera {}</h3>\n<table class=\"camera-summary\" data-camera=\"{}\"><tr><th>image</th><td>{}x{}</td></tr><tr><th>model</th><td class=\"text\">{}</td></tr><tr><th>RMS</th><td>{:.4} px</td></tr><tr><th>views</th><td>{} used, {} rejected</td></tr>",
        escape(&camera.name),
        escape(&camera.name),
        camera.width,
        camera.height,
        camera.distortion_model.ros_name(),
        camera.rms,
        camera.views_used,
        camera.views_rejected.len()
    );
    for (name, value, s) in [
        ("fx", fx, std.map(|s| s.fx)),
        ("fy", fy, std.map(|s| s.fy)),
        ("cx", cx, std.map(|s| s.cx)),
        ("cy", cy, std.map(|s| s.cy)),
    ] {
        let _ = write!(
            out,
            "<tr><th>{name}</th><td>{} px</td></tr>",
            with_std(value, s, 3)
        );
    }
    let names = camera.coefficient_names();
    for (i, (name, value)) in names.iter().zip(&camera.d).enumerate() {
        let s = std.and_then(|s| s.distortion.get(i).copied());
        let _ = write!(
            out,
            "<tr><th>{name}</th><td>{}</td></tr>",
            with_std(*value, s, 6)
        );
    }
    out.push_str("</table>\n");
    if std.is_none() {
        out.push_str(
            "<p>The standard deviations are unknown: the normal matrix is singular.</p>\n",
        );
    }
    out.push_str(&rejected_list("views", &camera.views_rejected));
    out
}

fn rejected_list(what: &str, rejected: &[RejectedFrame]) -> String {
    if rejected.is_empty() {
        return format!("<p>No {what} rejected.</p>\n");
    }
    let mut out = format!(
        "<table class=\"rejected-list\"><tr><th>rejected {what}: stamp</th><th>reason</th></tr>"
    );
    for r in rejected {
        let _ = write!(
            out,
            "<tr><td class=\"stamp\">{}</td><td class=\"text rejected\">{}</td></tr>",
            stamp_text(&r.stamp),
            escape(&r.reason)
        );
    }
    out.push_str("</table>\n");
    out
}

fn stereo_summary(stereo: &StereoSummary) -> String {
    let right_from_left = stereo.right_from_left;
    let (axis, angle) = right_from_left
        .rotation
        .axis_angle()
        .map_or(([0.0, 0.0, 1.0], 0.0), |(axis, angle)| {
            ([axis.x, axis.y, axis.z], angle)
        });
    let t = right_from_left.translation.vector * 1e3;
    let mut out = String::new();
    let _ = write!(
        out,
        "<h3>Stereo pair</h3>\n<table class=\"stereo-summary\"><tr><th>right_from_left rotation</th><td>{:.4}° about [{:.4}, {:.4}, {:.4}]</td></tr><tr><th>right_from_left translation</th><td>[{:.3}, {:.3}, {:.3}] mm</td></tr><tr><th>baseline</th><td>{:.3} mm</td></tr><tr><th>RMS</th><td>{:.4} px</td></tr><tr><th>epipolar RMS</th><td>{:.4} px</td></tr><tr><th>pairs</th><td>{} used, {} rejected</td></tr></table>\n",
        angle.to_degrees(),
        axis[0],
        axis[1],
        axis[2],
        t.x,
        t.y,
        t.z,
        t.norm(),
        stereo.rms,
        stereo.epipolar_rms,
        stereo.pairs_used,
        stereo.pairs_rejected.len()
    );
    out.push_str(&rejected_list("pairs", &stereo.pairs_rejected));
    out
}
