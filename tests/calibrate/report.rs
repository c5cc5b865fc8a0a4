//! `report.html` of `stereocal calibrate`: one self-contained file whose per-view bars,
//! coverage counts, distortion field and rectified pair agree with the calibration it
//! reports, for a synthetic stereo session (with bad frames) and a mono camera.

use crate::common;

use std::path::Path;

use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use clap::Parser;
use indicatif::ProgressBar;
use nalgebra::Point2;
use stereocal::calibrate::report::{
    EPIPOLAR_LINE_HALF_WIDTH, EPIPOLAR_LINES, ReportError, ReportInputs, render_report,
};
use stereocal::cli::calibrate::{CalibrateArgs, CalibrateReport, calibrate_bag};
use stereocal::cli::synth::SynthArgs;
use stereocal_vision::camera::CameraModel;
use stereocal_vision::synth::GroundTruth;

/// Synthesizes a 1024x768 stereo calibration session of `frames` frames into `dir`
/// with a fraction `bad` of bad frames, the cameras side by side or one above the other
/// (`vertical`), in mono8 or rgb8 (`rgb`).
fn synthesize(dir: &Path, frames: usize, bad: f64, vertical: bool, rgb: bool) -> GroundTruth {
    let scene = SynthArgs {
        bad_frames: Some(bad),
        rgb,
        vertical,
        ..common::calibration_scene(dir, 3, frames)
    };
    common::synthesize_session(&scene, None)
}

/// The epipolar lines the rectified figure lists in its attribute `name`, asserted
/// to be `EPIPOLAR_LINES` lines evenly spaced over `extent` pixels.
fn epipolar_lines(figure: &str, name: &str, extent: u32) -> Vec<u32> {
    let lines: Vec<u32> = attribute(figure, name)
        .unwrap()
        .split(' ')
        .map(|line| line.parse().unwrap())
        .collect();
    let spacing = extent / EPIPOLAR_LINES as u32;
    let expected: Vec<u32> = (0..EPIPOLAR_LINES as u32)
        .map(|k| spacing / 2 + k * spacing)
        .collect();
    assert_eq!(lines, expected, "{name}");
    lines
}

/// `stereocal calibrate`'s arguments, parsed as the command line would be.
#[derive(Parser)]
struct Command {
    #[command(flatten)]
    args: CalibrateArgs,
}

/// Calibrates the session in `dir` into `dir/calibration`: the stereo pair, or the
/// mono camera of `topic`.
fn calibrate(dir: &Path, truth: &GroundTruth, topic: Option<&str>) -> CalibrateReport {
    let mut line: Vec<String> = vec!["calibrate".into(), "--bag".into()];
    line.push(dir.join("bag").display().to_string());
    line.push("--out".into());
    line.push(dir.join("calibration").display().to_string());
    line.push("--size".into());
    line.push(format!("{}x{}", truth.board.cols, truth.board.rows));
    line.push("--square".into());
    line.push(truth.board.square_size.to_string());
    match topic {
        Some(topic) => line.extend(["--topic".into(), topic.to_owned()]),
        None => line.extend([
            "--left".into(),
            "/stereo/left/image_raw".into(),
            "--right".into(),
            "/stereo/right/image_raw".into(),
        ]),
    }
    let command = Command::parse_from(line);
    calibrate_bag(&command.args, &ProgressBar::hidden()).unwrap()
}

/// The text of the first element `<tag class="{class}" data-camera="{camera}"...>`
/// up to its closing tag.
fn element<'a>(html: &'a str, tag: &str, class: &str, camera: Option<&str>) -> &'a str {
    let open = match camera {
        Some(camera) => format!("<{tag} class=\"{class}\" data-camera=\"{camera}\""),
        None => format!("<{tag} class=\"{class}\""),
    };
    let start = html
        .find(&open)
        .unwrap_or_else(|| panic!("no {open} in the report"));
    let close = format!("</{tag}>");
    let end = html[start..].find(&close).unwrap() + start + close.len();
    &html[start..end]
}

/// The value of `attribute="..."` in the first tag of `element`.
fn attribute<'a>(element: &'a str, attribute: &str) -> Option<&'a str> {
    let tag_end = element.find('>')?;
    let key = format!(" {attribute}=\"");
    let start = element[..tag_end].find(&key)? + key.len();
    let len = element[start..].find('"')?;
    Some(&element[start..start + len])
}

/// Every `data-count` of the coverage cells in `figure`.
fn coverage_counts(figure: &str) -> Vec<usize> {
    figure
        .split("class=\"coverage-cell\"")
        .skip(1)
        .map(|cell| {
            let start = cell.find("data-count=\"").unwrap() + "data-count=\"".len();
            let len = cell[start..].find('"').unwrap();
            cell[start..start + len].parse().unwrap()
        })
        .collect()
}

/// The largest distance the lens moves an image corner from its ideal pinhole pixel.
fn largest_corner_displacement(camera: &CameraModel) -> f64 {
    let (w, h) = (
        f64::from(camera.width) - 1.0,
        f64::from(camera.height) - 1.0,
    );
    [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .into_iter()
        .map(|(x, y)| {
            let pixel = Point2::new(x, y);
            (pixel - camera.undistort_pixel(&pixel).unwrap()).norm()
        })
        .fold(0.0, f64::max)
}

/// The embedded picture of the report, decoded.
fn picture(html: &str) -> image::RgbImage {
    let figure = element(html, "figure", "rectified", None);
    let prefix = "src=\"data:image/png;base64,";
    let start = figure.find(prefix).unwrap() + prefix.len();
    let len = figure[start..].find('"').unwrap();
    let png = STANDARD.decode(&figure[start..start + len]).unwrap();
    image::load_from_memory(&png).unwrap().to_rgb8()
}

#[test]
fn stereo_report_shows_the_calibration_it_reports() {
    let dir = tempfile::tempdir().unwrap();
    let truth = synthesize(dir.path(), 14, 0.25, false, false);
    let report = calibrate(dir.path(), &truth, None);
    let outcome = &report.outcome;
    assert_eq!(report.report, dir.path().join("calibration/report.html"));
    let html = std::fs::read_to_string(&report.report).unwrap();

    // One self-contained file: nothing fetched, no scripts.
    assert!(html.starts_with("<!DOCTYPE html>"));
    for forbidden in ["http://", "https://", "<script", "<link", "<iframe"] {
        assert!(!html.contains(forbidden), "the report contains {forbidden}");
    }
    assert_eq!(html.matches("src=\"").count(), 1);
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 1);

    // The warnings on the result head the summary, one item each.
    let warnings = stereocal::calibrate::advice::warnings(outcome);
    assert!(
        !warnings.is_empty(),
        "a 14-frame session is too short to trust"
    );
    let list = element(&html, "ul", "warnings", None);
    assert_eq!(list.matches("<li").count(), warnings.len());
    for warning in &warnings {
        assert!(list.contains(warning.as_str()), "{warning}");
    }

    // One error bar per used and per rejected view of each camera, rejected views with
    // their reason as the tooltip.
    let corners_per_view = truth.board.cols * truth.board.rows;
    let mut rejected_views = 0;
    for camera in &outcome.cameras {
        let figure = element(&html, "figure", "per-view", Some(&camera.name));
        assert_eq!(
            figure.matches("class=\"view-bar used\"").count(),
            camera.used.len(),
            "{}",
            camera.name
        );
        assert_eq!(
            figure.matches("class=\"view-bar rejected\"").count(),
            camera.rejected.len(),
            "{}",
            camera.name
        );
        for rejected in &camera.rejected {
            let reason = rejected
                .reason
                .replace('\'', "&#39;")
                .replace('"', "&quot;");
            assert!(
                figure.contains(&format!(": rejected: {reason}</title>")),
                "{}: no tooltip for {}",
                camera.name,
                rejected.reason
            );
        }
        rejected_views += camera.rejected.len();

        // The summary lists each rejected view with its stamp and reason.
        let summary = element(&html, "table", "camera-summary", Some(&camera.name));
        assert!(summary.contains(&format!(
            "{} used, {} rejected",
            camera.used.len(),
            camera.rejected.len()
        )));
        for rejected in &camera.rejected {
            let stamp = format!("{}.{:09} s", rejected.stamp.sec, rejected.stamp.nanosec);
            assert!(
                html.contains(&format!("<td class=\"stamp\">{stamp}</td>")),
                "{stamp}"
            );
        }

        // The coverage heat-map counts every used corner once.
        let coverage = element(&html, "figure", "coverage", Some(&camera.name));
        let counts = coverage_counts(coverage);
        assert_eq!(counts.len(), 16 * 12);
        assert_eq!(
            counts.iter().sum::<usize>(),
            camera.used.len() * corners_per_view
        );

        // The distortion field's largest displacement is the model's at an image corner.
        let field = element(&html, "figure", "distortion", Some(&camera.name));
        let largest: f64 = attribute(field, "data-largest-displacement")
            .unwrap()
            .parse()
            .unwrap();
        let expected = largest_corner_displacement(&camera.calibration.camera);
        assert!(expected > 1.0, "the synthetic lens distorts");
        assert!(
            (largest - expected).abs() < 1e-9,
            "{}: largest displacement {largest} against {expected} at the corners",
            camera.name
        );
    }
    assert!(rejected_views > 0, "the session has bad frames");

    // The rectified pair side by side, green epipolar lines evenly spaced (each
    // `2 * EPIPOLAR_LINE_HALF_WIDTH + 1` rows) and nothing else green.
    let stereo = outcome.stereo.as_ref().unwrap();
    let baseline = stereo.calibration.right_from_left.translation.vector.norm() * 1e3;
    let summary = element(&html, "table", "stereo-summary", None);
    assert!(
        summary.contains(&format!("<td>{baseline:.3} mm</td>")),
        "{summary}"
    );
    let (width, height) = stereo.rectification.image_size;
    let image = picture(&html);
    assert_eq!(image.dimensions(), (2 * width, height));
    let figure = element(&html, "figure", "rectified", None);
    let rows = epipolar_lines(figure, "data-epipolar-rows", height);
    let half = EPIPOLAR_LINE_HALF_WIDTH as u32;
    let on_line = |y: u32| rows.iter().any(|r| r.abs_diff(y) <= half);
    for (y, row) in image.rows().enumerate() {
        let pixels: Vec<_> = row.collect();
        if on_line(y as u32) {
            assert!(pixels.iter().all(|p| p.0 == [0, 255, 0]), "row {y}");
        } else {
            assert!(
                pixels.iter().all(|p| p[0] == p[1] && p[1] == p[2]),
                "row {y}"
            );
        }
    }
    // Both halves show the rectified images, not an empty canvas.
    for left in [0, width] {
        let sum: u64 = (0..height)
            .filter(|&y| !on_line(y))
            .flat_map(|y| (left..left + width).map(move |x| (x, y)))
            .map(|(x, y)| u64::from(image.get_pixel(x, y)[0]))
            .sum();
        assert!(
            sum > u64::from(width * height) * 20,
            "half at {left} is dark"
        );
    }

    // Frames of other cameras than the calibration's are refused.
    let error = render_report(&ReportInputs {
        outcome,
        result: &report.result,
        frames: &[],
        sample: None,
    })
    .unwrap_err();
    assert!(
        matches!(error, ReportError::CameraMismatch { .. }),
        "{error}"
    );
}

#[test]
fn mono_report_shows_the_undistorted_colour_image() {
    let dir = tempfile::tempdir().unwrap();
    let truth = synthesize(dir.path(), 4, 0.0, false, true);
    let report = calibrate(dir.path(), &truth, Some("/stereo/left/image_raw"));
    let html = std::fs::read_to_string(&report.report).unwrap();
    let [camera] = report.outcome.cameras.as_slice() else {
        panic!("one camera expected");
    };
    let figure = element(&html, "figure", "per-view", Some("camera"));
    assert_eq!(
        figure.matches("class=\"view-bar used\"").count(),
        camera.used.len()
    );
    assert!(html.contains("<h2>Undistorted image</h2>"));
    let rectified = element(&html, "figure", "rectified", None);
    assert!(attribute(rectified, "data-epipolar-rows").is_none());
    let image = picture(&html);
    assert_eq!(image.dimensions(), (1024, 768));
    // An rgb8 camera keeps its colours.
    assert!(image.pixels().any(|p| p[0] != p[1] || p[1] != p[2]));
}

#[test]
fn vertical_rig_has_epipolar_columns() {
    let dir = tempfile::tempdir().unwrap();
    let truth = synthesize(dir.path(), 6, 0.0, true, false);
    let report = calibrate(dir.path(), &truth, None);
    let html = std::fs::read_to_string(&report.report).unwrap();
    let stereo = report.outcome.stereo.as_ref().unwrap();
    let (width, height) = stereo.rectification.image_size;
    let image = picture(&html);
    assert_eq!(image.dimensions(), (width, 2 * height));
    let figure = element(&html, "figure", "rectified", None);
    assert!(attribute(figure, "data-epipolar-rows").is_none());
    let columns = epipolar_lines(figure, "data-epipolar-columns", width);
    let half = EPIPOLAR_LINE_HALF_WIDTH as u32;
    for (x, y, pixel) in image.enumerate_pixels() {
        if columns.iter().any(|c| c.abs_diff(x) <= half) {
            assert_eq!(pixel.0, [0, 255, 0], "({x}, {y})");
        } else {
            assert!(pixel[0] == pixel[1] && pixel[1] == pixel[2], "({x}, {y})");
        }
    }
}
