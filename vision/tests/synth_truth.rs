//! The rendered images agree with the ground truth: every inner corner measured by a
//! saddle-point fit on noise-free, highly supersampled renders lies within 0.02 px of
//! its true projection, for all three lens models and several poses.

use crate::common;

use common::render::Scene;
use nalgebra::{Point2, Vector2};
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::synth::{
    Chessboard, Coverage, Photometry, SaddleFit, corner_truth, saddle_point,
    saddle_point_through_lens,
};

/// Corner errors (pixels) over `poses` poses of one camera of `model`, measured by
/// the saddle-point fit in the image (which assumes straight edges through the corner)
/// and by the fit in the corner's locally rectified frame, on the same renders.
fn corner_errors(model: DistortionModel, seed: u64, poses: usize) -> (Vec<f64>, Vec<f64>) {
    let board = Chessboard::new(8, 6, 0.04, 0.04).unwrap();
    let scene = Scene::new(seed, model, 800, 600, board, Coverage::Full, poses);
    let fit = SaddleFit::default();
    let (mut in_image, mut through_lens) = (Vec::new(), Vec::new());
    for pose in &scene.poses {
        let image = scene.render_supersampled(pose, Photometry::ideal(), 16, 0);
        for corner in corner_truth(&scene.camera, &scene.board, pose) {
            let [x, y] = corner.pixel.unwrap();
            assert!(corner.visible);
            let truth = Point2::new(x, y);
            // Start off the truth so the fit has to find the corner.
            let start = truth + Vector2::new(0.4, -0.3);
            let no_saddle = || panic!("{model:?}: no saddle near {truth}");
            let found = saddle_point(&image, &start, &fit).unwrap_or_else(no_saddle);
            in_image.push((found - truth).norm());
            let found = saddle_point_through_lens(&image, &scene.camera, &start, &fit)
                .unwrap_or_else(no_saddle);
            through_lens.push((found - truth).norm());
        }
    }
    (in_image, through_lens)
}

/// Mean and largest of `errors`.
fn summary(errors: &[f64]) -> (f64, f64) {
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    (mean, errors.iter().copied().fold(0.0, f64::max))
}

#[test]
fn rendered_corners_match_the_ground_truth_for_every_model() {
    for (model, seed) in [
        (DistortionModel::PlumbBob, 1),
        (DistortionModel::RationalPolynomial, 2),
        (DistortionModel::Equidistant, 3),
    ] {
        let (in_image, through_lens) = corner_errors(model, seed, 4);
        let (image_mean, image_max) = summary(&in_image);
        let (mean, max) = summary(&through_lens);
        println!(
            "{model:?}: {} corners, rectified fit mean {mean:.4} px, max {max:.4} px \
             (straight-edge fit in the image: mean {image_mean:.4} px, max {image_max:.4} px)",
            through_lens.len()
        );
        assert!(mean <= 0.01, "{model:?}: mean corner error {mean} px");
        assert!(max <= 0.02, "{model:?}: max corner error {max} px");
        if model == DistortionModel::Equidistant {
            // The fisheye's edges curve within the fit's reach: a fit that assumes
            // straight edges is pulled off the corners, the rectified fit is not. Both
            // measure the same images, so the difference is the instrument's.
            assert!(image_mean > 1.15 * mean, "{image_mean} vs {mean} px");
            assert!(image_max > 1.15 * max, "{image_max} vs {max} px");
        }
    }
}
