//! Two-view geometry: homographies and their decomposition, fundamental and essential
//! matrices, the relative pose they hold, and triangulation.
//!
//! Conventions. The two images are `a` and `b` (in a stereo pair, left and right).
//! Pixels have their centres at integer coordinates (OpenCV and ROS). Maps are named
//! for the frames they map between: a homography `image_b_from_image_a` takes a pixel
//! of image `a` to image `b`; a relative pose `camera_b_from_camera_a` maps points in
//! camera `a`'s frame to camera `b`'s. Fundamental and essential matrices follow
//! OpenCV: `b^T F a = 0` on pixels, `b^T E a = 0` on normalized image points
//! `(X/Z, Y/Z, 1)`, with `E = [t]x R` for `camera_b_from_camera_a = (R, t)`.
//!
//! The robust estimators ([`find_homography`], [`find_fundamental`],
//! [`find_essential`]) take [`RobustOptions`] with OpenCV's meaning (threshold in
//! pixels, confidence, most iterations) and a seed: the same input gives the same
//! result. Every estimator returns only finite results; refusals are
//! [`GeometryError`]s naming what was wrong.

mod consensus;
mod error;
mod essential;
mod fundamental;
mod homography;
mod homography_decomposition;
mod least_squares;
mod null_space;
mod polynomial;
mod recover_pose;
mod triangulate;

pub use consensus::{RobustMethod, RobustOptions};
pub use error::GeometryError;
pub use essential::{EssentialEstimate, decompose_essential, essential_5point, find_essential};
pub(crate) use fundamental::svd3;
pub use fundamental::{
    FundamentalEstimate, find_fundamental, fundamental_8point, sampson_distance,
};
pub use homography::{HomographyEstimate, find_homography, homography_dlt};
pub use homography_decomposition::{
    HomographyDecomposition, decompose_homography, visible_decompositions,
};
pub use recover_pose::{DEFAULT_MAX_DISTANCE, RecoveredPose, recover_pose};
pub use triangulate::{
    CorrectedMatches, TriangulatedPoint, correct_matches, triangulate_linear, triangulate_optimal,
    triangulate_rectified, triangulate_stereo,
};

use nalgebra::Point2;

/// Checks that two point lists pair up, hold at least `needed` points, and are finite.
fn check_pairs(
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
    needed: usize,
) -> Result<(), GeometryError> {
    if points_a.len() != points_b.len() {
        return Err(GeometryError::MismatchedLengths {
            a: points_a.len(),
            b: points_b.len(),
        });
    }
    if points_a.len() < needed {
        return Err(GeometryError::TooFewPoints {
            needed,
            got: points_a.len(),
        });
    }
    let finite = |points: &[Point2<f64>]| points.iter().all(|p| p.x.is_finite() && p.y.is_finite());
    if !finite(points_a) {
        return Err(GeometryError::NonFinite("the points of the first image"));
    }
    if !finite(points_b) {
        return Err(GeometryError::NonFinite("the points of the second image"));
    }
    Ok(())
}

/// Ratio of the spread of points across their principal direction to their spread along
/// it below which they lie on one line.
const COLLINEAR_RATIO: f64 = 1e-8;

/// Whether the points lie on one line (or coincide): their spread across their
/// principal direction is below [`COLLINEAR_RATIO`] of their spread along it.
pub(crate) fn collinear(points: &[Point2<f64>]) -> bool {
    let n = points.len() as f64;
    let mean_x = points.iter().map(|p| p.x).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.y).sum::<f64>() / n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let (dx, dy) = (p.x - mean_x, p.y - mean_y);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    let half_trace = 0.5 * (sxx + syy);
    let root = (0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy).sqrt();
    let (along, across) = (half_trace + root, (half_trace - root).max(0.0));
    along.is_nan() || along <= 0.0 || across.sqrt() <= COLLINEAR_RATIO * along.sqrt()
}

/// Refuses correspondences whose points all lie on one line (or coincide) in either
/// image: they lie on a plane through that camera's centre and determine no epipolar
/// geometry.
fn check_not_collinear(
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
) -> Result<(), GeometryError> {
    for (points, image) in [(points_a, "first"), (points_b, "second")] {
        if collinear(points) {
            return Err(GeometryError::Degenerate(format!(
                "all points of the {image} image lie on one line: the epipolar geometry needs \
                 points that are not all on one line"
            )));
        }
    }
    Ok(())
}
