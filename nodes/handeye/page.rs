//! The hand-eye report, `report.html`: one self-contained page (inline SVG, no scripts,
//! nothing fetched) in the calibration report's style. It shows the result and its
//! uncertainty, every method side by side, each sample's residuals with the samples left
//! out and why, and how the robot turned between samples, so an operator sees which
//! motions are missing.

use std::fmt::Write;

use nalgebra::{Isometry3, Vector3};

use super::report::HandEyeReport;
use crate::calibrate::report::ReportError;
use crate::calibrate::report::html::{Page, escape, paragraph};
use crate::calibrate::report::svg::{draw_chart, inline, rect};
use crate::pose::record::{TransformRecord, isometry_of};

const KEPT: &str = "#3b6fb6";
const LEFT_OUT: &str = "#d9472b";
const SIZE: (u32, u32) = (640, 280);

/// The whole page.
pub fn html(report: &HandEyeReport) -> Result<String, ReportError> {
    let mut page = Page::new(&format!("Hand-eye calibration ({})", report.setup));
    page.section("Result", &result_section(report));
    page.section("Methods side by side", &methods_section(report));
    page.section("Samples", &samples_section(report)?);
    page.section("Motions between samples", &motion_section(report)?);
    Ok(page.finish())
}

/// `(camera name, target name)` of the setup's transforms.
fn names(report: &HandEyeReport) -> (&'static str, &'static str) {
    match report.setup.as_str() {
        "eye-in-hand" => ("tool_from_camera", "base_from_target"),
        _ => ("base_from_camera", "tool_from_target"),
    }
}

/// Translation in millimetres and rotation vector in degrees, as table cells.
fn transform_cells(record: &TransformRecord) -> String {
    let pose = isometry_of(record);
    let t = pose.translation.vector * 1e3;
    let r = pose.rotation.scaled_axis().map(f64::to_degrees);
    format!(
        "<td>{:.2}</td><td>{:.2}</td><td>{:.2}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td>",
        t.x, t.y, t.z, r.x, r.y, r.z
    )
}

const TRANSFORM_HEADER: &str = "<th>x (mm)</th><th>y (mm)</th><th>z (mm)</th>\
<th>rotation x (deg)</th><th>rotation y (deg)</th><th>rotation z (deg)</th>";

fn result_section(report: &HandEyeReport) -> String {
    let (camera, target) = names(report);
    let mut out = String::new();
    let _ = write!(
        out,
        "<table><tr><th>transform</th>{TRANSFORM_HEADER}</tr>\
         <tr><td class=\"text\">{camera} ({})</td>{}</tr>\
         <tr><td class=\"text\">{target}</td>{}</tr></table>",
        escape(&report.chosen),
        transform_cells(&report.results[&report.chosen]),
        transform_cells(&report.target)
    );
    let mut facts = vec![
        format!(
            "Frames: base {}, tool {}, camera {}.",
            report.frames.base, report.frames.tool, report.frames.camera
        ),
        format!(
            "{} samples used, {} left out. Residuals of the samples used: median {:.3} deg and {:.2} mm, largest {:.3} deg and {:.2} mm.",
            report.samples,
            report.samples_rejected.len(),
            report.residuals.rotation_deg_median,
            report.residuals.translation_mm_median,
            report.residuals.rotation_deg_max,
            report.residuals.translation_mm_max
        ),
    ];
    if let Some(u) = &report.uncertainty {
        facts.push(format!(
            "Predicted standard deviation of {camera}: {:.4} deg and {:.3} mm along its least certain directions.",
            u.rotation_deg, u.translation_mm
        ));
    }
    if let Some(rms) = report.rms_px {
        facts.push(format!(
            "The target's corners reproject with {rms:.3} px RMS over every sample used."
        ));
    }
    for fact in facts {
        out.push_str(&paragraph(&fact));
    }
    if !report.warnings.is_empty() {
        out.push_str("<ul>");
        for warning in &report.warnings {
            let _ = write!(out, "<li class=\"rejected\">{}</li>", escape(warning));
        }
        out.push_str("</ul>");
    }
    out
}

fn methods_section(report: &HandEyeReport) -> String {
    let (camera, _) = names(report);
    let chosen = isometry_of(&report.results[&report.chosen]);
    let mut out = format!(
        "<table class=\"methods\"><tr><th>method</th>{TRANSFORM_HEADER}<th>from {} (deg)</th><th>from {} (mm)</th></tr>",
        escape(&report.chosen),
        escape(&report.chosen)
    );
    for (method, record) in &report.results {
        let pose: Isometry3<f64> = isometry_of(record);
        let _ = write!(
            out,
            "<tr data-method=\"{m}\"><td class=\"text\">{m}</td>{}<td>{:.4}</td><td>{:.3}</td></tr>",
            transform_cells(record),
            pose.rotation.angle_to(&chosen.rotation).to_degrees(),
            (pose.translation.vector - chosen.translation.vector).norm() * 1e3,
            m = escape(method)
        );
    }
    out.push_str("</table>");
    out.push_str(&paragraph(&format!(
        "{camera} by every method that succeeded; rotations as rotation vectors."
    )));
    out
}

fn samples_section(report: &HandEyeReport) -> Result<String, ReportError> {
    let samples = &report.per_sample;
    let mut out = String::new();
    for (name, unit, value) in [
        (
            "rotation residual",
            "deg",
            (|s| s.rotation_deg) as fn(&super::report::SampleRecord) -> f64,
        ),
        ("translation residual", "mm", |s| s.translation_mm),
    ] {
        let top = samples.iter().map(value).fold(0.0, f64::max).max(1e-9) * 1.15;
        let x = -0.5..samples.len().max(1) as f64 - 0.5;
        let (document, map) = draw_chart("sample residuals", SIZE, x, 0.0..top, |chart| {
            chart
                .configure_mesh()
                .disable_x_mesh()
                .max_light_lines(1)
                .x_desc("sample (stamp order)")
                .y_desc(format!("{name} ({unit})"))
                .draw()
        })?;
        let mut marks = String::new();
        for (i, sample) in samples.iter().enumerate() {
            let (class, fill, status) = match &sample.rejected {
                Some(reason) => (
                    "sample-bar left-out",
                    LEFT_OUT,
                    format!("left out: {reason}"),
                ),
                None => ("sample-bar used", KEPT, "used".to_owned()),
            };
            rect(
                &mut marks,
                (map.x(i as f64 - 0.38), map.y(0.0)),
                (map.x(i as f64 + 0.38), map.y(value(sample))),
                class,
                fill,
                "",
                &format!(
                    "sample {i}, {:.3} s: {:.3} {unit}, {status}",
                    sample.stamp,
                    value(sample)
                ),
            );
        }
        let _ = write!(
            out,
            "<figure class=\"residuals\"><h3>{name}</h3>{}<figcaption>Each sample's {name} under the chosen result: used in <span style=\"color:{KEPT}\">blue</span>, left out in <span class=\"rejected\">red</span> (hover for the reason).</figcaption></figure>",
            inline(&document, &marks)
        );
    }
    out.push_str("<table class=\"samples\"><tr><th>stamp (s)</th><th>rotation (deg)</th><th>translation (mm)</th><th>corners RMS (px)</th><th>status</th></tr>");
    for sample in samples {
        let _ = write!(
            out,
            "<tr><td class=\"stamp\">{:.3}</td><td>{:.4}</td><td>{:.3}</td><td>{}</td><td class=\"text{}\">{}</td></tr>",
            sample.stamp,
            sample.rotation_deg,
            sample.translation_mm,
            sample
                .reprojection_rms_px
                .map_or_else(String::new, |r| format!("{r:.3}")),
            if sample.rejected.is_some() {
                " rejected"
            } else {
                ""
            },
            escape(sample.rejected.as_deref().unwrap_or("used"))
        );
    }
    for rejected in &report.samples_rejected {
        if samples.iter().any(|s| s.stamp == rejected.stamp) {
            continue;
        }
        let _ = write!(
            out,
            "<tr><td class=\"stamp\">{:.3}</td><td></td><td></td><td></td><td class=\"text rejected\">{}</td></tr>",
            rejected.stamp,
            escape(&rejected.reason)
        );
    }
    out.push_str("</table>");
    Ok(out)
}

fn motion_section(report: &HandEyeReport) -> Result<String, ReportError> {
    let motion = &report.motion;
    let tool = report.frames.tool.as_str();
    let mount = match report.setup.as_str() {
        "eye-in-hand" => tool,
        _ => report.frames.base.as_str(),
    };
    // Each axis as a direction on the sphere (an axis and its opposite are the same
    // motion axis: shown in the upper hemisphere), azimuth against elevation.
    let (document, map) = draw_chart(
        "rotation axes",
        (640, 340),
        -180.0..180.0,
        0.0..90.0,
        |chart| {
            chart
                .configure_mesh()
                .x_desc(format!(
                    "azimuth of the rotation axis in the {mount} frame (deg)"
                ))
                .y_desc("elevation (deg)")
                .draw()
        },
    )?;
    let largest = motion.motions.iter().map(|(_, a)| *a).fold(1e-9, f64::max);
    let mut marks = String::new();
    for (axis, angle) in &motion.motions {
        let mut a = Vector3::from(*axis);
        if a.z < 0.0 {
            a = -a;
        }
        let azimuth = a.y.atan2(a.x).to_degrees();
        let elevation = a.z.clamp(-1.0, 1.0).asin().to_degrees();
        let _ = write!(
            marks,
            "<circle class=\"motion\" cx=\"{:.1}\" cy=\"{:.1}\" r=\"{:.1}\" fill=\"{KEPT}\" fill-opacity=\"0.45\"><title>{angle:.1} deg about ({:.2}, {:.2}, {:.2})</title></circle>",
            map.x(azimuth),
            map.y(elevation),
            2.0 + 6.0 * angle / largest,
            a.x,
            a.y,
            a.z
        );
    }
    let mut out = paragraph(&format!(
        "The largest rotation between two samples is {:.1} deg; the rotation axes of the motions stray {:.1} deg (RMS) from their main direction ({:.2}, {:.2}, {:.2}) in the {mount} frame. Hand-eye calibration needs rotations of tens of degrees about axes spread across space: add poses that turn the tool about axes far from the clustered ones.",
        motion.largest_rotation_deg,
        motion.axis_spread_deg,
        motion.main_axis[0],
        motion.main_axis[1],
        motion.main_axis[2]
    ));
    let _ = write!(
        out,
        "<figure class=\"axes\">{}<figcaption>Each motion between two samples: its rotation axis (azimuth and elevation, upper hemisphere), the larger the dot the larger the rotation.</figcaption></figure>",
        inline(&document, &marks)
    );
    Ok(out)
}
