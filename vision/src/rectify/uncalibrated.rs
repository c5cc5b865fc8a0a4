//! Rectification of an uncalibrated stereo pair from its fundamental matrix and matched
//! points (Hartley, "Theory and practice of projective rectification", 1999), as
//! OpenCV's `stereoRectifyUncalibrated`: two homographies that send every pair of
//! matched points to one image row, without the cameras' intrinsics or relative pose.
//!
//! Conventions: pixels have their centres at integer coordinates; `F` is OpenCV's
//! (`[r.x r.y 1] F [l.x l.y 1]^T = 0` for a left pixel `l` and its right match `r`), as
//! [`crate::geometry::find_fundamental`] returns it. The homographies are named for the
//! frames they map between: `rectified_left_from_image_left` takes a pixel of the left
//! image to the rectified left image.
//!
//! Unlike Bouguet's calibrated rectification ([`super::stereo_rectify`]) this removes no
//! lens distortion, knows no metric scale and distorts the images projectively: it is
//! exact only for distortion-free cameras, and its disparities give depth only up to an
//! unknown projective transformation.

use nalgebra::{DMatrix, DVector, Matrix3, Point2, Vector3};
use thiserror::Error;

use crate::geometry::{collinear, svd3};

/// Fewest correspondences the rectifying shear of the left image is solved from.
pub const MIN_UNCALIBRATED_POINTS: usize = 3;
/// Largest ratio of the smallest to the largest singular value of `F` still taken as
/// rank 2 (rounding in a stored matrix); above it `F` is refused as rank 3.
const RANK_TWO_TOLERANCE: f64 = 1e-6;
/// Ratio of the middle to the largest singular value of `F` below which `F` has rank 1
/// or less and no epipoles.
const RANK_ONE_TOLERANCE: f64 = 1e-9;
/// Sweeps of the SVD of the shear's least-squares system before it counts as failed.
const SVD_MAX_ITERATIONS: usize = 1000;

/// The two homographies of [`rectify_uncalibrated`], and which correspondences they
/// were computed from.
#[derive(Clone, Debug, PartialEq)]
pub struct UncalibratedRectification {
    /// Maps pixels of the left image to the rectified left image (OpenCV's `H1`).
    pub rectified_left_from_image_left: Matrix3<f64>,
    /// Maps pixels of the right image to the rectified right image (OpenCV's `H2`).
    pub rectified_right_from_image_right: Matrix3<f64>,
    /// Per correspondence, whether it lies within the threshold of its epipolar lines
    /// in both images and was used.
    pub inliers: Vec<bool>,
    /// Number of correspondences used.
    pub inlier_count: usize,
}

/// Why [`rectify_uncalibrated`] refused its input or found no rectification.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum UncalibratedRectifyError {
    /// The epipolar threshold is zero, negative or not a number.
    #[error(
        "epipolar threshold {0} px: expected a distance above 0 px (points farther than it from their epipolar lines are left out)"
    )]
    InvalidThreshold(f64),
    /// The image size is empty.
    #[error("image size {width}x{height}: both sides must be at least 1 pixel")]
    InvalidImageSize {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
    /// The two point lists do not pair up.
    #[error("{left} points in the left image but {right} in the right: they must pair up")]
    MismatchedLengths {
        /// Points in the left image.
        left: usize,
        /// Points in the right image.
        right: usize,
    },
    /// A NaN or infinite value in the input.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// `F` is not of rank 2.
    #[error(
        "the fundamental matrix has rank {rank} (singular values {:.3e}, {:.3e}, {:.3e}); a fundamental matrix has rank 2",
        .singular_values[0], .singular_values[1], .singular_values[2]
    )]
    FundamentalRank {
        /// The rank found.
        rank: usize,
        /// Its singular values, largest first.
        singular_values: [f64; 3],
    },
    /// Fewer correspondences than needed, before or after leaving out those off the
    /// epipolar geometry.
    #[error(
        "{got} correspondences {counted}, at least {needed} needed to solve for the rectification"
    )]
    TooFewPoints {
        /// What was there.
        got: usize,
        /// The minimum, [`MIN_UNCALIBRATED_POINTS`].
        needed: usize,
        /// Which ones were counted: those given, or those within the threshold of
        /// their epipolar lines.
        counted: String,
    },
    /// The left points used lie on one line (or coincide), so the rectifying shear is
    /// not determined.
    #[error(
        "the {count} left points used lie on one line: the rectification needs points that span the image (a scene not on one line)"
    )]
    Collinear {
        /// Points used.
        count: usize,
    },
    /// A homography sends part of its image to infinity: the epipole lies in or near the
    /// image (the cameras look along their baseline), where no homography rectifies.
    #[error(
        "the {image} image's epipole is too near the image: rectifying would send part of it to infinity (the cameras look too much along their baseline for rectification by homographies)"
    )]
    EpipoleInImage {
        /// "left" or "right".
        image: &'static str,
    },
    /// A numerical failure: an SVD failed or a result would not be finite.
    #[error("no solution: {0}")]
    NoSolution(&'static str),
}

/// Rectifying homographies of an uncalibrated stereo pair, as OpenCV's
/// `stereoRectifyUncalibrated` computes them (Hartley's method): `F` made exactly rank
/// 2; correspondences farther than `threshold` pixels from their epipolar line in
/// either image left out; the right image's epipole sent to infinity along the x axis
/// (through the pixel nearest the image centre); the left homography matched to it and
/// its shear fitted to the correspondences kept, by least squares, so that matched
/// points share a row and their columns differ least. Both are turned by 180 degrees
/// about the centre when the epipole lies left of it, as OpenCV does.
///
/// `points_left[i]` and `points_right[i]` are one scene point's pixels; `fundamental`
/// is `F` with `[r.x r.y 1] F [l.x l.y 1]^T = 0`, at the scale it was estimated
/// (OpenCV's result depends on it; [`crate::geometry::find_fundamental`] scales
/// `F[(2, 2)]` to 1 as OpenCV does); `image_size` is `(width, height)`; `threshold` is
/// in pixels, positive (`f64::INFINITY` keeps every point; OpenCV's threshold of 0 or
/// below does the same, here it is refused).
///
/// Errors: [`UncalibratedRectifyError`] for a threshold of 0 or below, an empty image,
/// lists that do not pair up, non-finite values, an `F` not of rank 2, fewer than
/// [`MIN_UNCALIBRATED_POINTS`] correspondences (given or kept), left points on one line,
/// an epipole in or near the image.
pub fn rectify_uncalibrated(
    points_left: &[Point2<f64>],
    points_right: &[Point2<f64>],
    fundamental: &Matrix3<f64>,
    image_size: (u32, u32),
    threshold: f64,
) -> Result<UncalibratedRectification, UncalibratedRectifyError> {
    check_inputs(
        points_left,
        points_right,
        fundamental,
        image_size,
        threshold,
    )?;
    let (u, f) = rank_two(fundamental)?;
    let inliers: Vec<bool> = points_left
        .iter()
        .zip(points_right)
        .map(|(l, r)| within_threshold(&f, l, r, threshold))
        .collect();
    let (left, right): (Vec<Point2<f64>>, Vec<Point2<f64>>) = points_left
        .iter()
        .zip(points_right)
        .zip(&inliers)
        .filter(|(_, keep)| **keep)
        .map(|((l, r), _)| (*l, *r))
        .unzip();
    if left.len() < MIN_UNCALIBRATED_POINTS {
        return Err(UncalibratedRectifyError::TooFewPoints {
            got: left.len(),
            needed: MIN_UNCALIBRATED_POINTS,
            counted: format!(
                "of {} lie within {threshold} px of their epipolar lines",
                points_left.len()
            ),
        });
    }
    if collinear(&left) {
        return Err(UncalibratedRectifyError::Collinear { count: left.len() });
    }

    let (width, height) = image_size;
    // OpenCV rounds the centre to a whole pixel, halves to even.
    let centre = Point2::new(
        ((f64::from(width) - 1.0) * 0.5).round_ties_even(),
        ((f64::from(height) - 1.0) * 0.5).round_ties_even(),
    );
    let epipole_right = oriented_epipole(&u);
    let (rectified_right, mirror) = right_homography(&epipole_right, &centre);
    // Hartley's matching homography: H0 = H2 ([e']x F + e' (1, 1, 1)).
    let matching = rectified_right
        * (epipole_right.cross_matrix() * f
            + epipole_right * Vector3::new(1.0, 1.0, 1.0).transpose());
    let shear = left_shear(&matching, &rectified_right, &left, &right)?;
    let mut rectified_left = shear * matching;
    let mut rectified_right = rectified_right;
    if mirror {
        let turn = Matrix3::new(
            -1.0,
            0.0,
            2.0 * centre.x,
            0.0,
            -1.0,
            2.0 * centre.y,
            0.0,
            0.0,
            1.0,
        );
        rectified_left = turn * rectified_left;
        rectified_right = turn * rectified_right;
    }
    if !(rectified_left.iter().chain(rectified_right.iter())).all(|v| v.is_finite()) {
        return Err(UncalibratedRectifyError::NoSolution(
            "the homographies are not finite",
        ));
    }
    for (image, h) in [("left", &rectified_left), ("right", &rectified_right)] {
        if !keeps_image_finite(h, image_size) {
            return Err(UncalibratedRectifyError::EpipoleInImage { image });
        }
    }
    let inlier_count = left.len();
    Ok(UncalibratedRectification {
        rectified_left_from_image_left: rectified_left,
        rectified_right_from_image_right: rectified_right,
        inliers,
        inlier_count,
    })
}

fn check_inputs(
    points_left: &[Point2<f64>],
    points_right: &[Point2<f64>],
    fundamental: &Matrix3<f64>,
    (width, height): (u32, u32),
    threshold: f64,
) -> Result<(), UncalibratedRectifyError> {
    if threshold.is_nan() || threshold <= 0.0 {
        return Err(UncalibratedRectifyError::InvalidThreshold(threshold));
    }
    if width == 0 || height == 0 {
        return Err(UncalibratedRectifyError::InvalidImageSize { width, height });
    }
    if points_left.len() != points_right.len() {
        return Err(UncalibratedRectifyError::MismatchedLengths {
            left: points_left.len(),
            right: points_right.len(),
        });
    }
    if !fundamental.iter().all(|v| v.is_finite()) {
        return Err(UncalibratedRectifyError::NonFinite(
            "the fundamental matrix",
        ));
    }
    let finite = |points: &[Point2<f64>]| points.iter().all(|p| p.x.is_finite() && p.y.is_finite());
    if !finite(points_left) {
        return Err(UncalibratedRectifyError::NonFinite(
            "the left image's points",
        ));
    }
    if !finite(points_right) {
        return Err(UncalibratedRectifyError::NonFinite(
            "the right image's points",
        ));
    }
    if points_left.len() < MIN_UNCALIBRATED_POINTS {
        return Err(UncalibratedRectifyError::TooFewPoints {
            got: points_left.len(),
            needed: MIN_UNCALIBRATED_POINTS,
            counted: "given".to_owned(),
        });
    }
    Ok(())
}

/// `F` with its smallest singular value set to 0, and the left singular vectors (the
/// third column of `U` is the right image's epipole); refused unless `F` has rank 2 to
/// within [`RANK_TWO_TOLERANCE`].
fn rank_two(f: &Matrix3<f64>) -> Result<(Matrix3<f64>, Matrix3<f64>), UncalibratedRectifyError> {
    let (u, s, v_t) = svd3(f).ok_or(UncalibratedRectifyError::NoSolution("the SVD of F failed"))?;
    let rank = if s[0].is_nan() || s[0] <= 0.0 {
        0
    } else if s[1] <= RANK_ONE_TOLERANCE * s[0] {
        1
    } else if s[2] > RANK_TWO_TOLERANCE * s[0] {
        3
    } else {
        2
    };
    if rank != 2 {
        return Err(UncalibratedRectifyError::FundamentalRank {
            rank,
            singular_values: s,
        });
    }
    let f = u * Matrix3::from_diagonal(&Vector3::new(s[0], s[1], 0.0)) * v_t;
    Ok((u, f))
}

/// Whether both points lie within `threshold` pixels of the epipolar line the other
/// one draws in their image (OpenCV's `computeCorrespondEpilines` lines).
fn within_threshold(
    f: &Matrix3<f64>,
    left: &Point2<f64>,
    right: &Point2<f64>,
    threshold: f64,
) -> bool {
    let in_right = unit_line(f * left.to_homogeneous());
    let in_left = unit_line(f.tr_mul(&right.to_homogeneous()));
    in_left.dot(&left.to_homogeneous()).abs() <= threshold
        && in_right.dot(&right.to_homogeneous()).abs() <= threshold
}

/// A line `ax + by + c = 0` scaled so that `a^2 + b^2 = 1` (left as is when both vanish).
fn unit_line(line: Vector3<f64>) -> Vector3<f64> {
    let norm = line.x.hypot(line.y);
    if norm > 0.0 { line / norm } else { line }
}

/// The right image's epipole (the left null vector of `F`, unit length) with a positive
/// third coordinate, as OpenCV orients it.
fn oriented_epipole(u: &Matrix3<f64>) -> Vector3<f64> {
    let e = u.column(2).into_owned();
    if e.z > 0.0 { e } else { -e }
}

/// The right homography: the epipole moved so the centre is the origin, turned onto the
/// positive x axis, sent to infinity, and the origin moved back to the centre; and
/// whether the epipole lay left of the centre (the pair is then turned by 180 degrees).
fn right_homography(epipole: &Vector3<f64>, centre: &Point2<f64>) -> (Matrix3<f64>, bool) {
    let to_centre = Matrix3::new(1.0, 0.0, -centre.x, 0.0, 1.0, -centre.y, 0.0, 0.0, 1.0);
    let e = to_centre * epipole;
    let mirror = e.x < 0.0;
    let d = e.x.hypot(e.y).max(f64::EPSILON);
    let (alpha, beta) = (e.x / d, e.y / d);
    let turn = Matrix3::new(alpha, beta, 0.0, -beta, alpha, 0.0, 0.0, 0.0, 1.0);
    let e = turn * e;
    let inverse_focal = if e.z.abs() < 1e-6 * e.x.abs() {
        0.0
    } else {
        -e.z / e.x
    };
    let to_infinity = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, inverse_focal, 0.0, 1.0);
    let from_centre = Matrix3::new(1.0, 0.0, centre.x, 0.0, 1.0, centre.y, 0.0, 0.0, 1.0);
    (from_centre * to_infinity * turn * to_centre, mirror)
}

/// The shear `[a b c; 0 1 0; 0 0 1]` that, after `matching`, brings each left point's
/// column nearest (least squares, as OpenCV's SVD solve) to its right match's column
/// after `rectified_right`.
fn left_shear(
    matching: &Matrix3<f64>,
    rectified_right: &Matrix3<f64>,
    left: &[Point2<f64>],
    right: &[Point2<f64>],
) -> Result<Matrix3<f64>, UncalibratedRectifyError> {
    let mut a = DMatrix::<f64>::zeros(left.len(), 3);
    let mut b = DVector::<f64>::zeros(left.len());
    for (i, (l, r)) in left.iter().zip(right).enumerate() {
        let l = perspective(matching, l);
        a[(i, 0)] = l.x;
        a[(i, 1)] = l.y;
        a[(i, 2)] = 1.0;
        b[i] = perspective(rectified_right, r).x;
    }
    let failed = || UncalibratedRectifyError::NoSolution("the least-squares shear failed");
    // Coordinates that overflow through the homographies leave nothing to solve.
    if !(a.iter().all(|v| v.is_finite()) && b.iter().all(|v| v.is_finite())) {
        return Err(failed());
    }
    let x = a
        .try_svd(true, true, f64::EPSILON, SVD_MAX_ITERATIONS)
        .ok_or_else(failed)?
        .solve(&b, f64::EPSILON)
        .map_err(|_| failed())?;
    Ok(Matrix3::new(x[0], x[1], x[2], 0.0, 1.0, 0.0, 0.0, 0.0, 1.0))
}

/// `h` applied to `p`; a point it sends to infinity becomes the origin, as OpenCV's
/// `perspectiveTransform` makes it.
fn perspective(h: &Matrix3<f64>, p: &Point2<f64>) -> Point2<f64> {
    let q = h * p.to_homogeneous();
    if q.z.abs() > f64::from(f32::EPSILON) {
        Point2::new(q.x / q.z, q.y / q.z)
    } else {
        Point2::origin()
    }
}

/// Whether every point of the image's rectangle of pixel centres lies on one side of
/// the line `h` sends to infinity (its third row is affine, so the corners decide).
fn keeps_image_finite(h: &Matrix3<f64>, (width, height): (u32, u32)) -> bool {
    let (x1, y1) = (f64::from(width) - 1.0, f64::from(height) - 1.0);
    let w: Vec<f64> = [(0.0, 0.0), (x1, 0.0), (0.0, y1), (x1, y1)]
        .iter()
        .map(|&(x, y)| h[(2, 0)] * x + h[(2, 1)] * y + h[(2, 2)])
        .collect();
    w.iter().all(|&w| w > 0.0) || w.iter().all(|&w| w < 0.0)
}
