//! rational_polynomial calibration of a rendered stereo session (`synth`'s calibration
//! scene: a plumb_bob rig, a 9x6 board, one frame in ten bad), whose views leave the
//! image corners unobserved: the eight coefficients could fit the corners with a lens
//! that folds back or has a pole before the image border. The calibration must stay
//! invertible out to the border, match the truth, and rectify, also when the stereo
//! solve refines the lenses.

use nalgebra::{Point2, Point3};
use stereocal_vision::board::{Chessboard, ChessboardDetector, Target, TargetDetector};
use stereocal_vision::calib::{
    MonoCalibration, MonoOptions, StereoOptions, StereoView, View, calibrate_mono, calibrate_stereo,
};
use stereocal_vision::camera::{CameraModel, DistortionModel};
use stereocal_vision::rectify::{StereoRectifyOptions, stereo_rectify};
use stereocal_vision::synth::{Scene, SceneKind, SceneSpec};

/// Pixels along the image border, every `step` pixels, corners included.
fn border(camera: &CameraModel, step: usize) -> Vec<Point2<f64>> {
    let (w, h) = (
        f64::from(camera.width) - 1.0,
        f64::from(camera.height) - 1.0,
    );
    let mut pixels = Vec::new();
    for x in (0..camera.width as usize)
        .step_by(step)
        .map(|x| x as f64)
        .chain([w])
    {
        pixels.push(Point2::new(x, 0.0));
        pixels.push(Point2::new(x, h));
    }
    for y in (0..camera.height as usize)
        .step_by(step)
        .map(|y| y as f64)
        .chain([h])
    {
        pixels.push(Point2::new(0.0, y));
        pixels.push(Point2::new(w, y));
    }
    pixels
}

/// Largest displacement between the truth and the calibration over `pixels`: each
/// pixel's true ray projected through the calibration.
fn max_error(truth: &CameraModel, calibration: &CameraModel, pixels: &[Point2<f64>]) -> f64 {
    pixels
        .iter()
        .map(|pixel| {
            let ray = truth.unproject(pixel).unwrap();
            let reprojected = calibration.project(&Point3::from(ray)).unwrap();
            (reprojected - pixel).norm()
        })
        .fold(0.0, f64::max)
}

fn calibrated_area(calibration: &MonoCalibration, views: &[View]) -> Vec<Point2<f64>> {
    calibration
        .views
        .iter()
        .flat_map(|fit| views[fit.index].pixels.iter().copied())
        .collect()
}

#[test]
fn rational_polynomial_of_a_rendered_session_stays_invertible_and_rectifies() {
    let scene = Scene::generate(&SceneSpec::new(SceneKind::Calibration, 1)).unwrap();
    let truth = scene.truth();
    let cameras: Vec<CameraModel> = truth
        .cameras
        .iter()
        .map(|c| c.camera_model().unwrap())
        .collect();
    let right_from_left = truth
        .extrinsics
        .right_from_left
        .as_ref()
        .unwrap()
        .isometry();
    let board = Chessboard::new(9, 6, 0.04).unwrap();
    let detector = ChessboardDetector::new(board).unwrap();
    let target = Target::Chessboard(board);
    let mut views: [Vec<View>; 2] = [Vec::new(), Vec::new()];
    let mut pairs = Vec::new();
    for index in 0..truth.frames.len() {
        let images = scene.render_frame(index).unwrap();
        let found: Vec<Option<View>> = images
            .iter()
            .map(|image| {
                let detection = detector.detect(image).unwrap()?;
                Some(View {
                    points_in_target: detection.object_points(&target)?,
                    pixels: detection.corners,
                })
            })
            .collect();
        if let [Some(left), Some(right)] = found.as_slice()
            && left.points_in_target == right.points_in_target
        {
            pairs.push(StereoView {
                points_in_target: left.points_in_target.clone(),
                left: left.pixels.clone(),
                right: right.pixels.clone(),
            });
        }
        for (camera_views, view) in views.iter_mut().zip(found) {
            camera_views.extend(view);
        }
    }
    let options = MonoOptions::new(DistortionModel::RationalPolynomial);
    let mut calibrated = Vec::new();
    for (camera, camera_views) in cameras.iter().zip(&views) {
        let calibration = calibrate_mono(camera_views, 1024, 768, &options).unwrap();
        let lens = &calibration.camera;
        let edge = border(lens, 8);
        assert!(
            edge.iter().all(|p| lens.unproject(p).is_some()),
            "{:?} does not invert to the border",
            lens.distortion
        );
        let area = max_error(camera, lens, &calibrated_area(&calibration, camera_views));
        let whole = max_error(camera, lens, &edge);
        assert!(area < 0.2, "calibrated area moved by {area} px");
        // The right camera's views stop 150 px short of its right edge: the border is
        // extrapolated (0.11 px left, 0.78 px right).
        assert!(whole < 1.0, "image border moved by {whole} px");
        calibrated.push(calibration.camera);
    }
    for refine_intrinsics in [false, true] {
        let stereo = calibrate_stereo(
            &calibrated[0],
            &calibrated[1],
            &pairs,
            &StereoOptions {
                refine_intrinsics,
                ..StereoOptions::default()
            },
        )
        .unwrap();
        let rotation_error = stereo
            .right_from_left
            .rotation
            .angle_to(&right_from_left.rotation)
            .to_degrees();
        let translation_error =
            (stereo.right_from_left.translation.vector - right_from_left.translation.vector).norm();
        assert!(
            rotation_error < 0.05,
            "rotation off by {rotation_error} deg"
        );
        assert!(
            translation_error < 0.3e-3,
            "translation off by {translation_error} m"
        );
        for lens in [&stereo.left, &stereo.right] {
            assert!(
                border(lens, 8).iter().all(|p| lens.unproject(p).is_some()),
                "{:?} does not invert to the border",
                lens.distortion
            );
        }
        stereo_rectify(
            &stereo.left,
            &stereo.right,
            &stereo.right_from_left,
            &StereoRectifyOptions::default(),
        )
        .unwrap();
    }
}
