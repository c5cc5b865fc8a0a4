//! The relative poses and planes a homography between two calibrated views holds
//! (OpenCV's `decomposeHomographyMat`), and the choice among them by the points that
//! must be visible (OpenCV's `filterHomographyDecompByVisibleRefpoints`).

use nalgebra::{Isometry3, Matrix3, Point2, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::fundamental::svd3;
use super::{GeometryError, check_pairs};
use crate::camera::Intrinsics;
use crate::rotation::nearest_rotation;

/// Relative spread of the normalized homography's singular values below which it is
/// taken as a pure rotation (no translation: the plane is not observable).
const PURE_ROTATION: f64 = 1e-9;

/// One relative pose and plane consistent with a homography.
///
/// With `camera_b_from_camera_a = (R, t)`, the plane `n^T X = d` in camera `a`'s frame
/// (`n = normal_in_a`, a unit vector pointing from camera `a` towards the plane, `d > 0`
/// its distance) and `t` in units of `d`, the normalized homography is
/// `K_b^-1 H K_a ~ R + t n^T`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomographyDecomposition {
    /// Maps points in camera `a`'s frame to camera `b`'s; the translation is in units
    /// of the plane's distance from camera `a`.
    pub camera_b_from_camera_a: Isometry3<f64>,
    /// The plane's unit normal in camera `a`'s frame, pointing from camera `a` towards
    /// the plane; zero when the homography is a pure rotation.
    pub normal_in_a: Vector3<f64>,
}

/// The relative poses and planes a homography `image_b_from_image_a` between two
/// calibrated views holds (OpenCV's `decomposeHomographyMat`): four solutions in two
/// pairs (`(R, t, n)` and `(R, -t, -n)`), only two of which put the plane in front of
/// camera `a`; one solution, with zero translation and normal, when the homography is a
/// pure rotation. The homography's scale and sign are removed first: divided by its
/// middle singular value, signed so that its determinant is positive (both cameras on
/// the same side of the plane).
///
/// The decomposition is Faugeras's, through the SVD of the normalized homography (Ma,
/// Soatto, Kosecka and Sastry, section 5.3.3).
///
/// Errors: [`GeometryError::NonFinite`] for a non-finite homography or intrinsics,
/// [`GeometryError::Degenerate`] for a singular homography or intrinsics.
pub fn decompose_homography(
    image_b_from_image_a: &Matrix3<f64>,
    camera_a: &Intrinsics,
    camera_b: &Intrinsics,
) -> Result<Vec<HomographyDecomposition>, GeometryError> {
    let (k_a, k_b) = (camera_a.matrix(), camera_b.matrix());
    if !image_b_from_image_a
        .iter()
        .chain(k_a.iter())
        .chain(k_b.iter())
        .all(|v| v.is_finite())
    {
        return Err(GeometryError::NonFinite("the homography or the intrinsics"));
    }
    let singular = || GeometryError::Degenerate("singular homography or intrinsics".into());
    let h = k_b.try_inverse().ok_or_else(singular)? * image_b_from_image_a * k_a;
    let (_, sigma, _) = svd3(&h).ok_or_else(singular)?;
    if sigma[2] <= 1e-12 * sigma[0] {
        return Err(singular());
    }
    let mut h = h / sigma[1];
    if h.determinant() < 0.0 {
        h = -h;
    }
    let (_, sigma, v_t) = svd3(&h).ok_or_else(singular)?;
    let rotation_of = |m: &Matrix3<f64>| {
        nearest_rotation(m)
            .map(|r| UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)))
    };
    let no_solution = || GeometryError::NoSolution("the decomposition is not finite".into());
    if sigma[0] - sigma[2] <= PURE_ROTATION * sigma[0] {
        return Ok(vec![HomographyDecomposition {
            camera_b_from_camera_a: Isometry3::from_parts(
                Translation3::identity(),
                rotation_of(&h).ok_or_else(no_solution)?,
            ),
            normal_in_a: Vector3::zeros(),
        }]);
    }
    let (s1, s3) = (sigma[0] * sigma[0], sigma[2] * sigma[2]);
    let (v1, v2, v3) = (
        v_t.row(0).transpose(),
        v_t.row(1).transpose(),
        v_t.row(2).transpose(),
    );
    let spread = (s1 - s3).sqrt();
    let (c1, c3) = ((1.0 - s3).max(0.0).sqrt(), (s1 - 1.0).max(0.0).sqrt());
    let mut solutions = Vec::with_capacity(4);
    for sign in [1.0, -1.0] {
        let u = (v1 * c1 + v3 * (sign * c3)) / spread;
        let frame = Matrix3::from_columns(&[v2, u, v2.cross(&u)]);
        let (hv, hu) = (h * v2, h * u);
        let image = Matrix3::from_columns(&[hv, hu, hv.cross(&hu)]);
        let rotation = rotation_of(&(image * frame.transpose())).ok_or_else(no_solution)?;
        let normal = v2.cross(&u).normalize();
        let translation = (h - rotation.to_rotation_matrix().matrix()) * normal;
        for flip in [1.0, -1.0] {
            let solution = HomographyDecomposition {
                camera_b_from_camera_a: Isometry3::from_parts(
                    Translation3::from(translation * flip),
                    rotation,
                ),
                normal_in_a: normal * flip,
            };
            if !solution
                .camera_b_from_camera_a
                .translation
                .vector
                .iter()
                .chain(solution.normal_in_a.iter())
                .all(|v| v.is_finite())
            {
                return Err(no_solution());
            }
            solutions.push(solution);
        }
    }
    Ok(solutions)
}

/// The decompositions that put every correspondence in front of both cameras (OpenCV's
/// `filterHomographyDecompByVisibleRefpoints`, which also checks the second view): the
/// ray of each pixel of image `a` meets the plane at positive depth, and that point has
/// positive depth in camera `b`. A pure rotation (zero normal) is kept. Pixels have
/// their centres at integer coordinates.
///
/// Errors: [`GeometryError::MismatchedLengths`], [`GeometryError::NonFinite`],
/// [`GeometryError::Degenerate`] for singular intrinsics.
pub fn visible_decompositions(
    decompositions: &[HomographyDecomposition],
    camera_a: &Intrinsics,
    points_a: &[Point2<f64>],
    camera_b: &Intrinsics,
    points_b: &[Point2<f64>],
) -> Result<Vec<HomographyDecomposition>, GeometryError> {
    check_pairs(points_a, points_b, 0)?;
    let singular = || GeometryError::Degenerate("singular intrinsics".into());
    let k_a_inverse = camera_a.matrix().try_inverse().ok_or_else(singular)?;
    let k_b_inverse = camera_b.matrix().try_inverse().ok_or_else(singular)?;
    let visible = |d: &HomographyDecomposition| {
        if d.normal_in_a == Vector3::zeros() {
            return true;
        }
        points_a.iter().zip(points_b).all(|(a, b)| {
            let ray_a = k_a_inverse * a.to_homogeneous();
            let facing = d.normal_in_a.dot(&ray_a);
            if facing.is_nan() || facing <= 0.0 {
                return false;
            }
            let in_b = d.camera_b_from_camera_a * nalgebra::Point3::from(ray_a / facing);
            // The measured pixel of b must lie on the same side: its ray meets the
            // plane, seen from camera b, in front.
            let ray_b = k_b_inverse * b.to_homogeneous();
            in_b.z > 0.0 && ray_b.dot(&in_b.coords) > 0.0
        })
    };
    Ok(decompositions
        .iter()
        .filter(|d| visible(d))
        .copied()
        .collect())
}
