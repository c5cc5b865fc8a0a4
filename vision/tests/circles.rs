//! Circle-grid detection on synthetic frames rendered with `vision::synth`, whose
//! circle centres are known exactly: every layout and lens model at tilts up to 40
//! degrees about each board axis, blur, noise and uneven light, and the grids that must
//! not be found (a wrong size, a partial grid, two grids, a chessboard).

use crate::common;

use common::render::Scene;
use nalgebra::{Isometry3, Point2};
use stereocal_vision::board::{
    CircleGrid, CircleGridDetector, CircleGridMiss, CircleLayout, Detection, Target,
    circle_centre_errors, detector_for,
};
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::synth::{Chessboard, Coverage, Photometry, corner_truth};

const SPACING: f64 = 0.02;

fn target(layout: CircleLayout, cols: usize, rows: usize) -> Target {
    let grid = CircleGrid::new(cols, rows, SPACING, layout).unwrap();
    match layout {
        CircleLayout::Symmetric => Target::Circles(grid),
        CircleLayout::Asymmetric => Target::Acircles(grid),
    }
}

/// OpenCV's 4x11 asymmetric grid, and a 9x6 symmetric one.
fn targets() -> [Target; 2] {
    [
        target(CircleLayout::Asymmetric, 4, 11),
        target(CircleLayout::Symmetric, 9, 6),
    ]
}

fn scene(seed: u64, model: DistortionModel, target: &Target, views: usize) -> Scene {
    let board = Chessboard::from_target(target).unwrap();
    Scene::new(seed, model, 1280, 720, board, Coverage::Full, views)
}

/// Distance of each detected centre from its true projection; asserts every circle
/// was found, in target order.
fn errors(scene: &Scene, pose: &Isometry3<f64>, detection: &Detection) -> Vec<f64> {
    let truth = corner_truth(&scene.camera, &scene.board, pose);
    assert_eq!(detection.ids, (0..truth.len()).collect::<Vec<_>>());
    detection
        .corners
        .iter()
        .zip(&truth)
        .map(|(found, record)| {
            let [x, y] = record.pixel.unwrap();
            (Point2::new(x, y) - found).norm()
        })
        .collect()
}

fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}

#[test]
fn clean_views_give_every_centre_within_three_hundredths_median() {
    let models = [
        DistortionModel::PlumbBob,
        DistortionModel::RationalPolynomial,
        DistortionModel::Equidistant,
    ];
    for (t, target) in targets().iter().enumerate() {
        let detector = detector_for(target).unwrap();
        for (m, model) in models.into_iter().enumerate() {
            let scene = scene(40 + (3 * t + m) as u64, model, target, 6);
            let mut all = Vec::new();
            for (index, pose) in scene.poses.iter().enumerate() {
                let image = scene.render(pose, Photometry::ideal(), index as u64);
                let detection = detector
                    .detect(&image)
                    .unwrap()
                    .unwrap_or_else(|| panic!("{model:?} view {index} not detected"));
                let errors = errors(&scene, pose, &detection);
                let max = errors.iter().copied().fold(0.0, f64::max);
                // A wrong order would put a centre a spacing (tens of pixels) off.
                assert!(max < 0.5, "{model:?} view {index}: max error {max} px");
                all.extend(errors);
            }
            let median = median(&all);
            println!(
                "{} {model:?}: median {median:.4} px, max {:.4} px over {} centres",
                target.describe(),
                all.iter().copied().fold(0.0, f64::max),
                all.len()
            );
            assert!(median <= 0.03, "{model:?}: median error {median} px");
        }
    }
}

#[test]
fn the_errors_predicted_through_the_lens_take_out_what_the_detector_leaves() {
    // A fisheye lens bends a circle's image beyond the detector's second-order model
    // near the image border; knowing the camera and the pose, as a calibration does,
    // predicts what is left.
    for (t, target) in targets().iter().enumerate() {
        let detector = detector_for(target).unwrap();
        let scene = scene(
            40 + (3 * t + 2) as u64,
            DistortionModel::Equidistant,
            target,
            6,
        );
        let (mut before, mut after) = (Vec::new(), Vec::new());
        for (index, pose) in scene.poses.iter().enumerate() {
            let image = scene.render(pose, Photometry::ideal(), index as u64);
            let detection = detector.detect(&image).unwrap().unwrap();
            let predicted = circle_centre_errors(target, &scene.camera, pose).unwrap();
            let corrected = Detection {
                corners: detection
                    .corners
                    .iter()
                    .zip(&predicted)
                    .map(|(c, e)| c - e)
                    .collect(),
                ..detection.clone()
            };
            before.extend(errors(&scene, pose, &detection));
            after.extend(errors(&scene, pose, &corrected));
        }
        let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        println!(
            "{} through a fisheye: median {:.4} -> {:.4} px, max {:.4} -> {:.4} px",
            target.describe(),
            median(&before),
            median(&after),
            max(&before),
            max(&after)
        );
        assert!(median(&after) < median(&before) && max(&after) < 0.5 * max(&before));
    }
}

#[test]
fn blurred_noisy_unevenly_lit_views_are_detected() {
    let hard = common::render::hard_photometry();
    for (t, target) in targets().iter().enumerate() {
        let detector = detector_for(target).unwrap();
        let scene = scene(50 + t as u64, DistortionModel::PlumbBob, target, 5);
        for (index, pose) in scene.poses.iter().enumerate() {
            for (what, photometry) in [("realistic", Photometry::realistic()), ("hard", hard)] {
                let image = scene.render(pose, photometry, 100 + index as u64);
                let detection = detector
                    .detect(&image)
                    .unwrap()
                    .unwrap_or_else(|| panic!("{what} view {index} not detected"));
                let errors = errors(&scene, pose, &detection);
                let mean = errors.iter().sum::<f64>() / errors.len() as f64;
                let max = errors.iter().copied().fold(0.0, f64::max);
                println!(
                    "{} {what} view {index}: mean {mean:.4} px, max {max:.4} px",
                    target.describe()
                );
                assert!(
                    mean < 0.1 && max < 0.5,
                    "{what} view {index}: mean {mean}, max {max}"
                );
            }
        }
    }
}

fn circle_detector(target: &Target) -> CircleGridDetector {
    CircleGridDetector::new(target).unwrap()
}

fn gray_of(image: &Image) -> stereocal_vision::board::Gray {
    stereocal_vision::board::Gray::from_image(image).unwrap()
}

#[test]
fn a_grid_of_another_size_is_refused_with_the_count_seen() {
    let shown = target(CircleLayout::Asymmetric, 4, 11);
    let scene = scene(60, DistortionModel::PlumbBob, &shown, 2);
    for (asked, found) in [
        (target(CircleLayout::Asymmetric, 4, 9), Some(44)),
        (target(CircleLayout::Asymmetric, 5, 11), Some(44)),
        (target(CircleLayout::Symmetric, 4, 11), None),
    ] {
        for (index, pose) in scene.poses.iter().enumerate() {
            let image = scene.render(pose, Photometry::realistic(), index as u64);
            let miss = circle_detector(&asked).find(&gray_of(&image)).unwrap_err();
            match found {
                Some(found) => assert_eq!(
                    miss,
                    CircleGridMiss::WrongGrid {
                        found,
                        expected: asked.object_points().len()
                    },
                    "{} view {index}",
                    asked.describe()
                ),
                None => assert!(
                    matches!(miss, CircleGridMiss::WrongGrid { .. }),
                    "{} view {index}: {miss}",
                    asked.describe()
                ),
            }
        }
    }
}

#[test]
fn a_partly_visible_grid_is_not_found() {
    let target = target(CircleLayout::Asymmetric, 4, 11);
    let board = Chessboard::from_target(&target).unwrap();
    let scene = Scene::new(
        61,
        DistortionModel::PlumbBob,
        1280,
        720,
        board,
        Coverage::Partial,
        4,
    );
    for (index, pose) in scene.poses.iter().enumerate() {
        let image = scene.render(pose, Photometry::realistic(), index as u64);
        let miss = circle_detector(&target).find(&gray_of(&image));
        assert!(
            matches!(
                miss,
                Err(CircleGridMiss::WrongGrid { .. } | CircleGridMiss::NoCircles)
            ),
            "view {index}: {miss:?}"
        );
    }
}

#[test]
fn two_grids_in_view_are_refused() {
    let target = target(CircleLayout::Symmetric, 4, 3);
    let board = Chessboard::from_target(&target).unwrap();
    let scene = Scene::new(
        62,
        DistortionModel::PlumbBob,
        640,
        720,
        board,
        Coverage::Full,
        1,
    );
    let half = scene.render(&scene.poses[0], Photometry::realistic(), 1);
    // The same view twice, side by side.
    let Samples::U8(pixels) = &half.samples else {
        panic!("mono8 expected");
    };
    let mut both = Vec::with_capacity(2 * pixels.len());
    for row in pixels.chunks(half.width) {
        both.extend_from_slice(row);
        both.extend_from_slice(row);
    }
    let image = Image {
        width: 2 * half.width,
        height: half.height,
        channels: 1,
        samples: Samples::U8(both),
    };
    assert!(circle_detector(&target).find(&gray_of(&half)).is_ok());
    assert_eq!(
        circle_detector(&target).find(&gray_of(&image)),
        Err(CircleGridMiss::TwoGrids)
    );
}

#[test]
fn a_chessboard_is_not_a_circle_grid() {
    let chessboard = Chessboard::new(7, 5, SPACING, SPACING).unwrap();
    let scene = Scene::hd(63, chessboard, Coverage::Full, 3);
    let target = target(CircleLayout::Symmetric, 7, 5);
    for (index, pose) in scene.poses.iter().enumerate() {
        let image = scene.render(pose, Photometry::realistic(), index as u64);
        assert!(
            circle_detector(&target).find(&gray_of(&image)).is_err(),
            "view {index}"
        );
    }
}
