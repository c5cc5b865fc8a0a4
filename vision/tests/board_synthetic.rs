//! Chessboard detection on synthetic frames rendered with `vision::synth`, whose
//! corners are known exactly: accuracy on clean frames, detection under blur, noise,
//! uneven light and clutter, and refusal of wrong board sizes and partial boards.

use crate::common;

use common::render::Scene;
use nalgebra::{Isometry3, Point2};
use stereocal_vision::board::{self, ChessboardDetector, TargetDetector};
use stereocal_vision::image::Image;
use stereocal_vision::synth::{Chessboard, Coverage, Photometry, corner_truth};

const COLS: usize = 9;
const ROWS: usize = 6;

fn session(seed: u64, coverage: Coverage, views: usize) -> Scene {
    let board = Chessboard::new(COLS, ROWS, 0.04, 0.03).unwrap();
    Scene::hd(seed, board, coverage, views)
}

fn detector(cols: usize, rows: usize) -> ChessboardDetector {
    ChessboardDetector::new(board::Chessboard::new(cols, rows, 0.04).unwrap()).unwrap()
}

/// Distances of the detected corners from the truth, or `None` when not detected.
fn errors(session: &Scene, pose: &Isometry3<f64>, image: &Image) -> Option<Vec<f64>> {
    let detection = detector(COLS, ROWS).detect(image).unwrap()?;
    let truth = corner_truth(&session.camera, &session.board, pose);
    assert_eq!(detection.corners.len(), truth.len());
    Some(
        truth
            .iter()
            .zip(&detection.corners)
            .map(|(t, found)| {
                let [x, y] = t.pixel.unwrap();
                (Point2::new(x, y) - found).norm()
            })
            .collect(),
    )
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

#[test]
fn clean_frames_median_error_within_three_hundredths() {
    let session = session(11, Coverage::Full, 8);
    let mut all = Vec::new();
    for (index, pose) in session.poses.iter().enumerate() {
        let image = session.render(pose, Photometry::ideal(), index as u64);
        let errors = errors(&session, pose, &image)
            .unwrap_or_else(|| panic!("clean view {index} not detected"));
        // Every corner is the right one (a wrong order would be squares off).
        let max = errors.iter().cloned().fold(0.0, f64::max);
        assert!(max < 0.2, "view {index}: max error {max} px");
        all.extend(errors);
    }
    let median = median(all.clone());
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    println!(
        "clean frames: median {median:.4} px, mean {mean:.4} px over {} corners",
        all.len()
    );
    assert!(median <= 0.03, "median corner error {median} px");
}

#[test]
fn blurred_noisy_unevenly_lit_cluttered_frames_are_detected() {
    let session = session(12, Coverage::Full, 6);
    let hard = common::render::hard_photometry();
    for (index, pose) in session.poses.iter().enumerate() {
        for (what, photometry) in [("realistic", Photometry::realistic()), ("hard", hard)] {
            let image = session.render(pose, photometry, 100 + index as u64);
            let errors = errors(&session, pose, &image)
                .unwrap_or_else(|| panic!("{what} view {index} not detected"));
            let mean = errors.iter().sum::<f64>() / errors.len() as f64;
            let max = errors.iter().cloned().fold(0.0, f64::max);
            println!("{what} view {index}: mean {mean:.3} px, max {max:.3} px");
            assert!(
                mean < 0.1 && max < 0.5,
                "{what} view {index}: mean {mean}, max {max}"
            );
        }
    }
}

#[test]
fn wrong_board_sizes_are_rejected() {
    let session = session(13, Coverage::Full, 3);
    for (index, pose) in session.poses.iter().enumerate() {
        let image = session.render(pose, Photometry::realistic(), index as u64);
        assert!(detector(COLS, ROWS).detect(&image).unwrap().is_some());
        // (6x9 is the same board turned a quarter, not a wrong size.)
        for (cols, rows) in [(8, 6), (9, 5), (7, 5), (10, 6), (9, 7), (5, 8)] {
            assert!(
                detector(cols, rows).detect(&image).unwrap().is_none(),
                "view {index}: a {COLS}x{ROWS} board accepted as {cols}x{rows}"
            );
        }
    }
}

#[test]
fn partial_boards_are_rejected() {
    let session = session(14, Coverage::Partial, 6);
    for (index, pose) in session.poses.iter().enumerate() {
        let image = session.render(pose, Photometry::realistic(), index as u64);
        assert!(
            detector(COLS, ROWS).detect(&image).unwrap().is_none(),
            "partial view {index} accepted"
        );
    }
}
