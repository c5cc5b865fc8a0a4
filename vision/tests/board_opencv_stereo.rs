//! Chessboard detection on OpenCV's real stereo sample pairs
//! (`../shared/data/opencv-stereo`, 9x6 inner corners): every image is detected with
//! all 54 corners, in the board's order, the same in both images of a pair, and
//! close to OpenCV's own corners when its fixture is present.

use std::path::{Path, PathBuf};

use nalgebra::Point2;
use stereocal_vision::board::{Chessboard, ChessboardDetector, Detection, Gray, TargetDetector};

fn data_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/opencv-stereo");
    if dir.join("left01.jpg").exists() {
        Some(dir)
    } else {
        eprintln!("skipping: {} is absent", dir.display());
        None
    }
}

fn load(path: &Path) -> Gray {
    let image = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8();
    Gray {
        width: image.width() as usize,
        height: image.height() as usize,
        data: image.into_raw(),
    }
}

const PAIRS: [u32; 13] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14];

fn detect_all(dir: &Path) -> Vec<(String, Detection)> {
    let detector = ChessboardDetector::new(Chessboard::new(9, 6, 1.0).unwrap()).unwrap();
    let mut found = Vec::new();
    for side in ["left", "right"] {
        for pair in PAIRS {
            let name = format!("{side}{pair:02}.jpg");
            let detection = detector
                .detect_gray(&load(&dir.join(&name)))
                .unwrap_or_else(|| panic!("{name}: board not detected"));
            found.push((name, detection));
        }
    }
    found
}

/// Mean grey level sampled at `p`.
fn level(gray: &Gray, p: Point2<f64>) -> f64 {
    gray.sample(p.x, p.y).unwrap_or(f64::NAN)
}

#[test]
fn every_image_is_detected_in_board_order() {
    let Some(dir) = data_dir() else { return };
    for (name, detection) in detect_all(&dir) {
        let corners = &detection.corners;
        assert_eq!(corners.len(), 54, "{name}");
        assert_eq!(detection.ids, (0..54).collect::<Vec<_>>(), "{name}");
        // Rows and columns are straight-ish and evenly stepped: neighbours along a row
        // are about one square apart, never folded back.
        for j in 0..6 {
            for i in 0..8 {
                let step = corners[j * 9 + i + 1] - corners[j * 9 + i];
                let next_row =
                    corners[(j + 1).min(5) * 9 + i] - corners[j.saturating_sub(1) * 9 + i];
                assert!(step.norm() > 0.5 * detection.square_px, "{name} ({i}, {j})");
                // Right-handed: x turned clockwise is y.
                assert!(
                    step.x * next_row.y - step.y * next_row.x > 0.0,
                    "{name} ({i}, {j})"
                );
            }
        }
        // The square diagonally outside the first corner is black, the square beside
        // it along the first row white.
        let gray = load(&dir.join(&name));
        let (c0, c1, c9) = (corners[0], corners[1], corners[9]);
        // A quarter of a step: the outer squares of these prints are cut narrow.
        let outside = c0 - (c1 - c0) * 0.25 - (c9 - c0) * 0.25;
        let beside = c0 + (c1 - c0) * 0.25 - (c9 - c0) * 0.25;
        assert!(
            level(&gray, outside) + 40.0 < level(&gray, beside),
            "{name} {outside} {} {beside} {} {c0} {c1} {c9}",
            level(&gray, outside),
            level(&gray, beside)
        );
    }
}

#[test]
fn stereo_pairs_get_the_same_order() {
    let Some(dir) = data_dir() else { return };
    let found = detect_all(&dir);
    let (left, right) = found.split_at(PAIRS.len());
    for ((name, l), (_, r)) in left.iter().zip(right) {
        // The rig is side by side: the board's x axis points the same way in both.
        let dl = l.corners[8] - l.corners[0];
        let dr = r.corners[8] - r.corners[0];
        assert!(dl.dot(&dr) > 0.5 * dl.norm() * dr.norm(), "{name}");
    }
}

#[test]
fn corners_agree_with_opencv() {
    let Some(dir) = data_dir() else { return };
    let fixture: serde_json::Value =
        serde_json::from_str(include_str!("fixtures/opencv_stereo_corners.json"))
            .expect("fixture is JSON");
    let mut means = Vec::new();
    for (name, detection) in detect_all(&dir) {
        let theirs = fixture["images"][&name]["corners"]
            .as_array()
            .unwrap_or_else(|| panic!("{name} missing from the fixture"));
        assert_eq!(theirs.len(), 54, "{name}");
        let distances: Vec<f64> = theirs
            .iter()
            .zip(&detection.corners)
            .map(|(p, ours)| {
                let p = Point2::new(p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
                (p - ours).norm()
            })
            .collect();
        let mean = distances.iter().sum::<f64>() / distances.len() as f64;
        let max = distances.iter().cloned().fold(0.0, f64::max);
        println!("{name}: mean {mean:.3} px, max {max:.3} px from OpenCV");
        // Same order as OpenCV: a different order would put corners squares apart.
        // (OpenCV's 11x11 window pulls some outer corners of these small squares by
        // a few pixels, so single corners may differ that much.)
        assert!(
            max < 0.25 * detection.square_px,
            "{name}: max distance {max} px"
        );
        means.push(mean);
    }
    let overall = means.iter().sum::<f64>() / means.len() as f64;
    println!("all images: mean distance {overall:.4} px from OpenCV");
    assert!(overall < 0.2, "mean distance {overall} px");
}
