//! The report's summary: warnings on a result not to trust blindly, each camera's K, D with their standard deviations, RMS and the
//! views used and rejected (stamp and reason); for a pair, `right_from_left`, the
//! baseline and the epipolar error.

use std::fmt::Write;

use stereocal_vision::camera::DistortionModel;

use super::html::escape;
use super::views::stamp_text;
use crate::calibration_advice;
use crate::calibration_stage::{CalibrationOutcome, CameraResult, RejectedFrame, StereoResult};

/// The summary as HTML: the warnings first, when the result should not be trusted
/// blindly.
pub(crate) fn summary(outcome: &CalibrationOutcome) -> String {
    let mut out = String::new();
    let warnings = calibration_advice::warnings(outcome);
    if !warnings.is_empty() {
        out.push_str("<ul class=\"warnings\">");
        for warning in &warnings {
            let _ = write!(out, "<li class=\"rejected\">{}</li>", escape(warning));
        }
        out.push_str("</ul>\n");
    }
    out.push_str("<div class=\"cameras\">");
    for camera in &outcome.cameras {
        out.push_str("<div>");
        out.push_str(&camera_summary(camera));
        out.push_str("</div>");
    }
    out.push_str("</div>\n");
    if let Some(stereo) = &outcome.stereo {
        out.push_str(&stereo_summary(stereo));
    }
    out
}

/// Names of a model's coefficients, camera_info order.
fn coefficient_names(model: DistortionModel) -> &'static [&'static str] {
    match model {
        DistortionModel::PlumbBob => &["k1", "k2", "p1", "p2", "k3"],
        DistortionModel::RationalPolynomial => &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"],
        DistortionModel::Equidistant => &["k1", "k2", "k3", "k4"],
    }
}

fn with_std(value: f64, std: Option<f64>, decimals: usize) -> String {
    match std {
        Some(s) => format!("{value:.decimals$} ± {s:.decimals$}"),
        None => format!("{value:.decimals$}"),
    }
}

fn camera_summary(camera: &CameraResult) -> String {
    let calibration = &camera.calibration;
    let model = &calibration.camera;
    let k = model.intrinsics;
    let std = calibration.std_dev.as_ref();
    let mut out = String::new();
    let _ = write!(
        out,
        "<h3>Camera {}</h3>\n<table class=\"camera-summary\" data-camera=\"{}\"><tr><th>image</th><td>{}x{}</td></tr><tr><th>model</th><td class=\"text\">{}</td></tr><tr><th>RMS</th><td>{:.4} px</td></tr><tr><th>views</th><td>{} used, {} rejected</td></tr>",
        escape(&camera.name),
        escape(&camera.name),
        model.width,
        model.height,
        model.distortion.model().ros_name(),
        calibration.rms,
        camera.used.len(),
        camera.rejected.len()
    );
    for (name, value, s) in [
        ("fx", k.fx, std.map(|s| s.fx)),
        ("fy", k.fy, std.map(|s| s.fy)),
        ("cx", k.cx, std.map(|s| s.cx)),
        ("cy", k.cy, std.map(|s| s.cy)),
    ] {
        let _ = write!(
            out,
            "<tr><th>{name}</th><td>{} px</td></tr>",
            with_std(value, s, 3)
        );
    }
    let names = coefficient_names(model.distortion.model());
    for (i, (name, value)) in names.iter().zip(model.distortion.coeffs()).enumerate() {
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
    out.push_str(&rejected_list("views", &camera.rejected));
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

fn stereo_summary(stereo: &StereoResult) -> String {
    let calibration = &stereo.calibration;
    let right_from_left = calibration.right_from_left;
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
        calibration.rms,
        calibration.epipolar_rms,
        stereo.used.len(),
        stereo.rejected.len()
    );
    out.push_str(&rejected_list("pairs", &stereo.rejected));
    out
}
