//! Triangulation of two-view correspondences: the linear DLT (OpenCV's
//! `triangulatePoints`), the optimal two-view correction (Hartley and Sturm, OpenCV's
//! `correctMatches`), and triangulation from a calibrated stereo pair, raw or
//! rectified. Every point comes with its reprojection error in each image.
//!
//! Projection matrices `P` (3x4) map homogeneous points of one frame (the "scene
//! frame", for a stereo pair the left camera's) to homogeneous pixels, pixel centres at
//! integer coordinates.

use nalgebra::{Isometry3, Matrix3, Matrix3x4, Matrix4, Point2, Point3, Vector3, Vector4};

use super::fundamental::svd3;
use super::polynomial::real_roots;
use super::{GeometryError, check_pairs};
use crate::camera::CameraModel;
use crate::rectify::StereoRectification;

/// A triangulated point and how well it explains its two pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangulatedPoint {
    /// The point, in the scene frame of the projections (for a stereo pair, the left
    /// camera's frame; for a rectified pair, the rectified left camera's), metres when
    /// the projections are.
    pub point: Point3<f64>,
    /// Distance in pixels between the point's projection and its measured pixel in the
    /// first image.
    pub error_a_px: f64,
    /// The same in the second image.
    pub error_b_px: f64,
}

/// Two-view correspondences moved, each by the least total squared distance, onto the
/// epipolar geometry: `b^T F a = 0` holds exactly for each pair.
#[derive(Clone, Debug, PartialEq)]
pub struct CorrectedMatches {
    /// The corrected points of the first image.
    pub points_a: Vec<Point2<f64>>,
    /// The corrected points of the second image.
    pub points_b: Vec<Point2<f64>>,
}

/// Triangulates each correspondence by the linear DLT (OpenCV's `triangulatePoints`):
/// the homogeneous point minimizing the algebraic error of `a ~ P_a X` and
/// `b ~ P_b X`, the right singular vector of the 4x4 system. A point is `None` when it
/// is at infinity (or projects to infinity) or is not finite. Points behind a camera
/// are kept, as OpenCV keeps them.
///
/// Errors: [`GeometryError::MismatchedLengths`], [`GeometryError::NonFinite`] (in the
/// points or the projections).
pub fn triangulate_linear(
    projection_a: &Matrix3x4<f64>,
    projection_b: &Matrix3x4<f64>,
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
) -> Result<Vec<Option<TriangulatedPoint>>, GeometryError> {
    check_pairs(points_a, points_b, 0)?;
    check_projections(projection_a, projection_b)?;
    Ok(points_a
        .iter()
        .zip(points_b)
        .map(|(a, b)| {
            let point = linear_point(projection_a, projection_b, a, b)?;
            with_errors(projection_a, projection_b, point, a, b)
        })
        .collect())
}

/// Moves each correspondence the least (in the summed squared pixel distance in both
/// images) onto the epipolar geometry `F` (`b^T F a = 0`), by Hartley and Sturm's
/// optimal method (OpenCV's `correctMatches`): with both points moved to the origin
/// and both epipoles onto the x axis, the pencil of epipolar lines is parametrized by
/// one number `t`, whose optimum is among the real roots of a polynomial of degree 6
/// and `t = infinity`. A point at its epipole is left where it is.
///
/// Errors: [`GeometryError::MismatchedLengths`], [`GeometryError::NonFinite`],
/// [`GeometryError::NoSolution`] when the SVD of `F` fails.
pub fn correct_matches(
    fundamental: &Matrix3<f64>,
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
) -> Result<CorrectedMatches, GeometryError> {
    check_pairs(points_a, points_b, 0)?;
    if !fundamental.iter().all(|v| v.is_finite()) {
        return Err(GeometryError::NonFinite("the fundamental matrix"));
    }
    let (u, _, v_t) =
        svd3(fundamental).ok_or_else(|| GeometryError::NoSolution("the SVD of F failed".into()))?;
    let epipole_a: Vector3<f64> = v_t.row(2).transpose();
    let epipole_b: Vector3<f64> = u.column(2).into_owned();
    let (points_a, points_b) = points_a
        .iter()
        .zip(points_b)
        .map(|(a, b)| correct(fundamental, &epipole_a, &epipole_b, a, b).unwrap_or((*a, *b)))
        .unzip();
    Ok(CorrectedMatches { points_a, points_b })
}

/// Triangulates each correspondence optimally for Gaussian pixel noise: the pixels are
/// first corrected onto the epipolar geometry of the two projections
/// ([`correct_matches`]), so that their rays meet, then intersected by the linear DLT.
/// Errors are those of the point against the measured (uncorrected) pixels.
///
/// Errors: as [`triangulate_linear`]; [`GeometryError::Degenerate`] when the two
/// projections share their centre (no epipolar geometry).
pub fn triangulate_optimal(
    projection_a: &Matrix3x4<f64>,
    projection_b: &Matrix3x4<f64>,
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
) -> Result<Vec<Option<TriangulatedPoint>>, GeometryError> {
    check_pairs(points_a, points_b, 0)?;
    check_projections(projection_a, projection_b)?;
    let f = fundamental_from_projections(projection_a, projection_b).ok_or_else(|| {
        GeometryError::Degenerate("the two projections share their centre".into())
    })?;
    let corrected = correct_matches(&f, points_a, points_b)?;
    Ok(corrected
        .points_a
        .iter()
        .zip(&corrected.points_b)
        .zip(points_a.iter().zip(points_b))
        .map(|((ca, cb), (a, b))| {
            let point = linear_point(projection_a, projection_b, ca, cb)?;
            with_errors(projection_a, projection_b, point, a, b)
        })
        .collect())
}

/// Triangulates raw pixels of a calibrated stereo pair: each pixel is undistorted
/// through its camera model, the pair corrected optimally onto the pair's epipolar
/// geometry (in undistorted pixels) and intersected ([`triangulate_optimal`] with
/// `P_left = K_left [I | 0]`, `P_right = K_right [R | t]` of `right_from_left`). Points
/// are in the left camera frame, in the units of `right_from_left` (metres); errors are
/// through the full camera models (with distortion) against the measured pixels.
///
/// A point is `None` when a pixel has no ray through its camera model, or the point is
/// not in front of both cameras, or not finite.
///
/// Errors: [`GeometryError::MismatchedLengths`], [`GeometryError::NonFinite`],
/// [`GeometryError::Degenerate`] for a zero baseline.
pub fn triangulate_stereo(
    left: &CameraModel,
    right: &CameraModel,
    right_from_left: &Isometry3<f64>,
    pixels_left: &[Point2<f64>],
    pixels_right: &[Point2<f64>],
) -> Result<Vec<Option<TriangulatedPoint>>, GeometryError> {
    check_pairs(pixels_left, pixels_right, 0)?;
    let ideal = |camera: &CameraModel, pixels: &[Point2<f64>]| -> Vec<Option<Point2<f64>>> {
        camera
            .unproject_all(pixels)
            .into_iter()
            .map(|ray| ray.map(|r| camera.intrinsics.pixel_from_normalized(&r.xy())))
            .collect()
    };
    let (ideal_left, ideal_right) = (ideal(left, pixels_left), ideal(right, pixels_right));
    // Pixels without a ray stand in as themselves so the batch keeps its indices; their
    // points are dropped below.
    let fill = |ideal: &[Option<Point2<f64>>], raw: &[Point2<f64>]| -> Vec<Point2<f64>> {
        ideal
            .iter()
            .zip(raw)
            .map(|(i, r)| i.unwrap_or(*r))
            .collect()
    };
    let projection_left = left.intrinsics.matrix() * Matrix3x4::identity();
    let projection_right =
        right.intrinsics.matrix() * right_from_left.to_matrix().fixed_rows::<3>(0);
    let points = triangulate_optimal(
        &projection_left,
        &projection_right,
        &fill(&ideal_left, pixels_left),
        &fill(&ideal_right, pixels_right),
    )?;
    Ok(points
        .into_iter()
        .enumerate()
        .map(|(i, point)| {
            ideal_left[i]?;
            ideal_right[i]?;
            let point = point?.point;
            let in_right = right_from_left * point;
            let error_a_px = (left.project(&point)? - pixels_left[i]).norm();
            let error_b_px = (right.project(&in_right)? - pixels_right[i]).norm();
            Some(TriangulatedPoint {
                point,
                error_a_px,
                error_b_px,
            })
        })
        .collect())
}

/// Triangulates pixels of a rectified stereo pair through its projections `P1`, `P2`
/// ([`triangulate_optimal`]): points are in the rectified left camera frame, errors in
/// rectified pixels. A point is `None` when it is at infinity (zero disparity) or not
/// finite.
///
/// Errors: as [`triangulate_optimal`].
pub fn triangulate_rectified(
    rectification: &StereoRectification,
    pixels_left: &[Point2<f64>],
    pixels_right: &[Point2<f64>],
) -> Result<Vec<Option<TriangulatedPoint>>, GeometryError> {
    triangulate_optimal(
        &rectification.left_projection,
        &rectification.right_projection,
        pixels_left,
        pixels_right,
    )
}

fn check_projections(a: &Matrix3x4<f64>, b: &Matrix3x4<f64>) -> Result<(), GeometryError> {
    if a.iter().chain(b.iter()).all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(GeometryError::NonFinite("the projection matrices"))
    }
}

/// The DLT point of one correspondence, `None` at infinity.
fn linear_point(
    pa: &Matrix3x4<f64>,
    pb: &Matrix3x4<f64>,
    a: &Point2<f64>,
    b: &Point2<f64>,
) -> Option<Point3<f64>> {
    let rows = [
        pa.row(2) * a.x - pa.row(0),
        pa.row(2) * a.y - pa.row(1),
        pb.row(2) * b.x - pb.row(0),
        pb.row(2) * b.y - pb.row(1),
    ];
    let system = Matrix4::from_rows(&rows);
    let svd = system.try_svd(false, true, f64::EPSILON, 1000)?;
    let v_t = svd.v_t?;
    let smallest = svd.singular_values.imin();
    let x: Vector4<f64> = v_t.row(smallest).transpose();
    let point = Point3::from_homogeneous(x)?;
    point.coords.iter().all(|v| v.is_finite()).then_some(point)
}

/// `point` with its reprojection errors through both projections; `None` when it
/// projects to infinity in either image.
fn with_errors(
    pa: &Matrix3x4<f64>,
    pb: &Matrix3x4<f64>,
    point: Point3<f64>,
    a: &Point2<f64>,
    b: &Point2<f64>,
) -> Option<TriangulatedPoint> {
    let error = |p: &Matrix3x4<f64>, measured: &Point2<f64>| {
        let projected = Point2::from_homogeneous(p * point.to_homogeneous())?;
        let error = (projected - measured).norm();
        error.is_finite().then_some(error)
    };
    Some(TriangulatedPoint {
        point,
        error_a_px: error(pa, a)?,
        error_b_px: error(pb, b)?,
    })
}

/// The fundamental matrix of two projections, `F = [e_b]x P_b P_a^+` with `e_b` the
/// image of the first centre in the second; `None` when the centres coincide or the
/// first projection is rank-deficient.
fn fundamental_from_projections(pa: &Matrix3x4<f64>, pb: &Matrix3x4<f64>) -> Option<Matrix3<f64>> {
    let mut padded = Matrix4::zeros();
    padded.fixed_rows_mut::<3>(0).copy_from(pa);
    let svd = padded.try_svd(false, true, f64::EPSILON, 1000)?;
    let centre: Vector4<f64> = svd.v_t?.row(svd.singular_values.imin()).transpose();
    let epipole = pb * centre;
    let pseudo_inverse = pa.transpose() * (pa * pa.transpose()).try_inverse()?;
    let f = epipole.cross_matrix() * pb * pseudo_inverse;
    let norm = f.norm();
    (norm > 1e-12 * (pb.norm() * pseudo_inverse.norm()) && norm.is_finite()).then(|| f / norm)
}

/// Hartley and Sturm's correction of one correspondence (Hartley and Zisserman,
/// algorithm 12.1); `None` when a point is at its epipole or the result is not finite.
fn correct(
    f: &Matrix3<f64>,
    epipole_a: &Vector3<f64>,
    epipole_b: &Vector3<f64>,
    a: &Point2<f64>,
    b: &Point2<f64>,
) -> Option<(Point2<f64>, Point2<f64>)> {
    // Both points to the origin: the epipoles move with them.
    let shift =
        |e: &Vector3<f64>, p: &Point2<f64>| Vector3::new(e.x - e.z * p.x, e.y - e.z * p.y, e.z);
    let (ea, eb) = (shift(epipole_a, a), shift(epipole_b, b));
    // Rotations about the origin taking each epipole onto the x axis, (1, 0, f).
    let rotation = |e: &Vector3<f64>| {
        let s = (e.x * e.x + e.y * e.y).sqrt();
        (s > 0.0).then(|| {
            let (c, n, f) = (e.x / s, e.y / s, e.z / s);
            (Matrix3::new(c, n, 0.0, -n, c, 0.0, 0.0, 0.0, 1.0), f)
        })
    };
    let (ra, fa) = rotation(&ea)?;
    let (rb, fb) = rotation(&eb)?;
    let to_a = Matrix3::new(1.0, 0.0, a.x, 0.0, 1.0, a.y, 0.0, 0.0, 1.0);
    let to_b = Matrix3::new(1.0, 0.0, b.x, 0.0, 1.0, b.y, 0.0, 0.0, 1.0);
    let g = rb * to_b.transpose() * f * to_a * ra.transpose();
    let (ga, gb, gc, gd) = (g[(1, 1)], g[(1, 2)], g[(2, 1)], g[(2, 2)]);
    // t ((a t + b)² + f_b² (c t + d)²)² - (a d - b c) (1 + f_a² t²)² (a t + b) (c t + d)
    let quadratic = [
        gb * gb + fb * fb * gd * gd,
        2.0 * (ga * gb + fb * fb * gc * gd),
        ga * ga + fb * fb * gc * gc,
    ];
    let squared = square(&quadratic);
    let lines = [gb * gd, ga * gd + gb * gc, ga * gc];
    let bend = square(&[1.0, 0.0, fa * fa]);
    let determinant = ga * gd - gb * gc;
    let mut g6 = [0.0; 7];
    for (k, c) in squared.iter().enumerate() {
        g6[k + 1] += c;
    }
    for (i, x) in bend.iter().enumerate() {
        for (j, y) in lines.iter().enumerate() {
            g6[i + j] -= determinant * x * y;
        }
    }
    let cost = |t: f64| {
        let (p, q) = (ga * t + gb, gc * t + gd);
        t * t / (1.0 + fa * fa * t * t) + q * q / (p * p + fb * fb * q * q)
    };
    let at_infinity = 1.0 / (fa * fa) + gc * gc / (ga * ga + fb * fb * gc * gc);
    let best = real_roots(&g6)
        .into_iter()
        .map(|t| (Some(t), cost(t)))
        .filter(|(_, c)| c.is_finite())
        .fold((None, at_infinity), |best, candidate| {
            if candidate.1 < best.1 {
                candidate
            } else {
                best
            }
        })
        .0;
    let (line_a, line_b) = match best {
        Some(t) => (
            Vector3::new(t * fa, 1.0, -t),
            Vector3::new(-fb * (gc * t + gd), ga * t + gb, gc * t + gd),
        ),
        None => (Vector3::new(fa, 0.0, -1.0), Vector3::new(-fb * gc, ga, gc)),
    };
    let foot = |l: &Vector3<f64>| Vector3::new(-l.x * l.z, -l.y * l.z, l.x * l.x + l.y * l.y);
    let corrected_a = Point2::from_homogeneous(to_a * ra.transpose() * foot(&line_a))?;
    let corrected_b = Point2::from_homogeneous(to_b * rb.transpose() * foot(&line_b))?;
    let finite = |p: &Point2<f64>| p.x.is_finite() && p.y.is_finite();
    (finite(&corrected_a) && finite(&corrected_b)).then_some((corrected_a, corrected_b))
}

/// The square of a quadratic, lowest degree first.
fn square(p: &[f64; 3]) -> [f64; 5] {
    let mut out = [0.0; 5];
    for (i, x) in p.iter().enumerate() {
        for (j, y) in p.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}
