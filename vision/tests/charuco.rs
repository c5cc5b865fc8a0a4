//! ChArUco detection on synthetic frames rendered with `vision::synth`, whose corners
//! are known exactly: ids and accuracy on clean frames, partly visible boards, blur
//! and noise, and refusal of chessboards and of a board printed from another
//! dictionary.

use crate::common;

use std::collections::BTreeSet;

use common::render::Scene;
use nalgebra::{Isometry3, Point2};
use stereocal_vision::board::{
    self, ArucoDictionary, CharucoDetector, MIN_CHARUCO_CORNERS, Target, TargetDetector,
    detector_for,
};
use stereocal_vision::image::Image;
use stereocal_vision::synth::{CharucoMarkers, Chessboard, Coverage, Photometry, corner_truth};

/// Squares of the board (inner corners one fewer).
const SQUARES_X: usize = 7;
const SQUARES_Y: usize = 5;
const SQUARE: f64 = 0.04;
const MARKER: f64 = 0.03;
const DICTIONARY: ArucoDictionary = ArucoDictionary::Dict5x5_100;

fn synth_board(dictionary: ArucoDictionary) -> Chessboard {
    let markers = CharucoMarkers::new(MARKER, dictionary).unwrap();
    Chessboard::charuco(SQUARES_X - 1, SQUARES_Y - 1, SQUARE, SQUARE, markers).unwrap()
}

fn target(dictionary: ArucoDictionary) -> board::Charuco {
    board::Charuco {
        squares_x: SQUARES_X,
        squares_y: SQUARES_Y,
        square_size: SQUARE,
        marker_size: MARKER,
        dictionary,
    }
}

fn detector() -> CharucoDetector {
    CharucoDetector::new(target(DICTIONARY)).unwrap()
}

/// Per detected corner, its distance from the truth; asserts the ids are ascending
/// and every one is a corner the camera sees.
fn errors(session: &Scene, pose: &Isometry3<f64>, detection: &board::Detection) -> Vec<f64> {
    let truth = corner_truth(&session.camera, &session.board, pose);
    assert!(
        detection.ids.windows(2).all(|w| w[0] < w[1]),
        "ids not ascending"
    );
    assert_eq!(detection.ids.len(), detection.corners.len());
    detection
        .ids
        .iter()
        .zip(&detection.corners)
        .map(|(&id, found)| {
            let record = &truth[id];
            assert!(record.visible, "corner {id} detected but not in view");
            let [x, y] = record.pixel.unwrap();
            (Point2::new(x, y) - found).norm()
        })
        .collect()
}

/// Ids of the corners whose two marker squares are in the image: the corners a
/// ChArUco detector can be asked for (one square's side from every image border).
fn well_inside(session: &Scene, pose: &Isometry3<f64>, image: &Image) -> Vec<usize> {
    let truth = corner_truth(&session.camera, &session.board, pose);
    let cols = SQUARES_X - 1;
    let pixel = |id: usize| truth[id].pixel.map(|[x, y]| Point2::new(x, y));
    let (w, h) = (image.width as f64 - 1.0, image.height as f64 - 1.0);
    truth
        .iter()
        .filter(|c| c.visible)
        .filter_map(|c| {
            let here = pixel(c.id)?;
            let neighbour = if c.id % cols + 1 < cols {
                c.id + 1
            } else {
                c.id - 1
            };
            let side = (pixel(neighbour)? - here).norm();
            let inside =
                here.x >= side && here.y >= side && here.x <= w - side && here.y <= h - side;
            inside.then_some(c.id)
        })
        .collect()
}

fn summary(values: &[f64]) -> (f64, f64, f64) {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mean = sorted.iter().sum::<f64>() / sorted.len() as f64;
    (mean, sorted[sorted.len() / 2], sorted[sorted.len() - 1])
}

#[test]
fn clean_frames_give_the_corners_with_their_ids_within_three_hundredths_median() {
    let session = Scene::hd(21, synth_board(DICTIONARY), Coverage::Full, 8);
    let detector = detector();
    let mut all = Vec::new();
    for (index, pose) in session.poses.iter().enumerate() {
        let image = session.render(pose, Photometry::ideal(), index as u64);
        let detection = detector
            .detect(&image)
            .unwrap()
            .unwrap_or_else(|| panic!("clean view {index} not detected"));
        let inside = well_inside(&session, pose, &image);
        let missed: Vec<&usize> = inside
            .iter()
            .filter(|id| !detection.ids.contains(id))
            .collect();
        assert!(missed.is_empty(), "view {index}: missed corners {missed:?}");
        let errors = errors(&session, pose, &detection);
        let (_, _, max) = summary(&errors);
        // A wrong id would be a square (tens of pixels) off.
        assert!(max < 0.2, "view {index}: max error {max} px");
        all.extend(errors);
    }
    let (mean, median, max) = summary(&all);
    println!(
        "clean ChArUco frames: mean {mean:.4} px, median {median:.4} px, max {max:.4} px over {} corners",
        all.len()
    );
    assert!(median <= 0.03, "median corner error {median} px");
}

#[test]
fn partly_visible_boards_give_the_visible_corners_with_their_ids() {
    let session = Scene::hd(22, synth_board(DICTIONARY), Coverage::Partial, 6);
    let detector = detector();
    let mut detected = 0;
    for (index, pose) in session.poses.iter().enumerate() {
        let image = session.render(pose, Photometry::realistic(), 50 + index as u64);
        let inside = well_inside(&session, pose, &image);
        let rows: BTreeSet<usize> = inside.iter().map(|id| id / (SQUARES_X - 1)).collect();
        let cols: BTreeSet<usize> = inside.iter().map(|id| id % (SQUARES_X - 1)).collect();
        let Some(detection) = detector.detect(&image).unwrap() else {
            // With its corners in one row or column, a board does not fix a view.
            assert!(
                inside.len() < MIN_CHARUCO_CORNERS || rows.len() < 2 || cols.len() < 2,
                "view {index}: corners {inside:?} in view, none found"
            );
            continue;
        };
        detected += 1;
        let errors = errors(&session, pose, &detection);
        let (mean, _, max) = summary(&errors);
        println!(
            "partial view {index}: {} corners, {} well inside the image, mean {mean:.3} px, max {max:.3} px",
            detection.ids.len(),
            inside.len()
        );
        assert!(detection.ids.len() >= MIN_CHARUCO_CORNERS);
        assert!(detection.ids.len() < (SQUARES_X - 1) * (SQUARES_Y - 1));
        let found = inside
            .iter()
            .filter(|id| detection.ids.contains(id))
            .count();
        assert!(
            3 * found >= 2 * inside.len(),
            "view {index}: found {:?} of {inside:?}",
            detection.ids
        );
        assert!(max < 0.5, "view {index}: max error {max} px");
    }
    assert!(detected >= 4, "only {detected} of 6 partial views detected");
}

#[test]
fn blurred_noisy_unevenly_lit_frames_are_detected() {
    let session = Scene::hd(23, synth_board(DICTIONARY), Coverage::Full, 6);
    let detector = detector();
    let hard = common::render::hard_photometry();
    for (index, pose) in session.poses.iter().enumerate() {
        for (what, photometry) in [("realistic", Photometry::realistic()), ("hard", hard)] {
            let image = session.render(pose, photometry, 100 + index as u64);
            let detection = detector
                .detect(&image)
                .unwrap()
                .unwrap_or_else(|| panic!("{what} view {index} not detected"));
            let errors = errors(&session, pose, &detection);
            let (mean, _, max) = summary(&errors);
            println!(
                "{what} view {index}: {} corners, mean {mean:.3} px, max {max:.3} px",
                errors.len()
            );
            assert!(
                errors.len() >= 20,
                "{what} view {index}: {} corners",
                errors.len()
            );
            assert!(
                mean < 0.1 && max < 0.5,
                "{what} view {index}: mean {mean}, max {max}"
            );
        }
    }
}

/// Asserts the ChArUco detector finds nothing in any realistic view of `session`.
fn assert_never_detected(session: &Scene) {
    let detector = detector();
    for (index, pose) in session.poses.iter().enumerate() {
        let image = session.render(pose, Photometry::realistic(), index as u64);
        assert_eq!(detector.detect(&image).unwrap(), None, "view {index}");
    }
}

#[test]
fn a_chessboard_is_not_a_charuco_board() {
    let chessboard = Chessboard::new(SQUARES_X - 1, SQUARES_Y - 1, SQUARE, SQUARE).unwrap();
    let session = Scene::hd(24, chessboard, Coverage::Full, 3);
    assert_never_detected(&session);
}

#[test]
fn a_board_from_another_dictionary_is_not_found() {
    let session = Scene::hd(
        25,
        synth_board(ArucoDictionary::Dict4x4_50),
        Coverage::Full,
        3,
    );
    assert_never_detected(&session);
}

#[test]
fn the_detector_follows_the_target() {
    let charuco = Target::Charuco(target(DICTIONARY));
    assert_eq!(detector_for(&charuco).unwrap().target(), &charuco);
    let chessboard = Target::Chessboard(board::Chessboard::new(9, 6, 0.025).unwrap());
    assert_eq!(detector_for(&chessboard).unwrap().target(), &chessboard);
}
