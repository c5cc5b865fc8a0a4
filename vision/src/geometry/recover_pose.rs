//! The relative pose held by an essential matrix: of its four decompositions, the one
//! that puts the scene in front of both cameras (OpenCV's `recoverPose`).

use nalgebra::{Isometry3, Matrix3, Point2};

use super::essential::{decompose_essential, normalize};
use super::{GeometryError, check_pairs};
use crate::camera::CameraModel;

/// OpenCV's default distance threshold of `recoverPose`, in units of the baseline.
pub const DEFAULT_MAX_DISTANCE: f64 = 50.0;

/// The pose [`recover_pose`] chose and the correspondences that support it.
#[derive(Clone, Debug, PartialEq)]
pub struct RecoveredPose {
    /// Maps points in camera `a`'s frame to camera `b`'s, with a unit translation (the
    /// scale of the baseline is not observable from two views).
    pub camera_b_from_camera_a: Isometry3<f64>,
    /// Per correspondence, whether it was considered (in the input mask) and its
    /// triangulated point lies in front of both cameras within the distance threshold.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
}

/// Chooses among the four poses of `essential` ([`decompose_essential`]) the one that
/// puts the most correspondences in front of both cameras (OpenCV's `recoverPose`):
/// each correspondence of `mask` (all when `None`), undistorted through its camera
/// model, is triangulated for each pose (the midpoint of the common perpendicular of
/// its two rays) and counts when its depth in both cameras is positive and below `max_distance` (in units of the baseline, which
/// the pose makes 1; [`DEFAULT_MAX_DISTANCE`] is OpenCV's 50), which drops points
/// triangulated near infinity, whose side is down to noise.
///
/// `essential` follows `b^T E a = 0` on normalized points (as from
/// [`find_essential`](super::find_essential)); pixels have their centres at integer
/// coordinates.
///
/// Errors: [`GeometryError::MismatchedLengths`] (also for a mask of another length),
/// [`GeometryError::NonFinite`], [`GeometryError::Unprojectable`],
/// [`GeometryError::InvalidOption`] for a `max_distance` that is not positive,
/// [`GeometryError::NoSolution`] when `essential` does not decompose,
/// [`GeometryError::NoConsensus`] when no pose puts any correspondence in front of both
/// cameras.
pub fn recover_pose(
    essential: &Matrix3<f64>,
    camera_a: &CameraModel,
    pixels_a: &[Point2<f64>],
    camera_b: &CameraModel,
    pixels_b: &[Point2<f64>],
    mask: Option<&[bool]>,
    max_distance: f64,
) -> Result<RecoveredPose, GeometryError> {
    check_pairs(pixels_a, pixels_b, 1)?;
    if let Some(mask) = mask
        && mask.len() != pixels_a.len()
    {
        return Err(GeometryError::MismatchedLengths {
            a: pixels_a.len(),
            b: mask.len(),
        });
    }
    if max_distance.is_nan() || max_distance <= 0.0 {
        return Err(GeometryError::InvalidOption(format!(
            "max_distance must be positive, got {max_distance}"
        )));
    }
    if !essential.iter().all(|v| v.is_finite()) {
        return Err(GeometryError::NonFinite("the essential matrix"));
    }
    let normalized_a = normalize(camera_a, pixels_a, "first")?;
    let normalized_b = normalize(camera_b, pixels_b, "second")?;
    let considered = |i: usize| mask.is_none_or(|m| m[i]);
    let poses = decompose_essential(essential).ok_or_else(|| {
        GeometryError::NoSolution("the essential matrix does not decompose".into())
    })?;
    let mut best: Option<(Isometry3<f64>, Vec<bool>, usize)> = None;
    for pose in poses {
        let in_front: Vec<bool> = normalized_a
            .iter()
            .zip(&normalized_b)
            .enumerate()
            .map(|(i, (a, b))| {
                considered(i)
                    && depths(&pose, a, b).is_some_and(|(depth_a, depth_b)| {
                        depth_a > 0.0
                            && depth_a < max_distance
                            && depth_b > 0.0
                            && depth_b < max_distance
                    })
            })
            .collect();
        let count = in_front.iter().filter(|&&v| v).count();
        if best.as_ref().is_none_or(|b| count > b.2) {
            best = Some((pose, in_front, count));
        }
    }
    match best {
        Some((pose, inliers, count)) if count > 0 => Ok(RecoveredPose {
            camera_b_from_camera_a: pose,
            inliers,
            inlier_count: count,
        }),
        _ => Err(GeometryError::NoConsensus {
            best: 0,
            needed: 1,
            total: (0..pixels_a.len()).filter(|&i| considered(i)).count(),
        }),
    }
}

/// The depths in cameras `a` and `b` of the midpoint of the common perpendicular of the
/// rays through normalized points `a` and `b`, for `camera_b_from_camera_a = pose`;
/// `None` for parallel rays (a point at infinity).
fn depths(pose: &Isometry3<f64>, a: &Point2<f64>, b: &Point2<f64>) -> Option<(f64, f64)> {
    // In camera b's frame: the ray of a is t + s u, that of b is r v; s and r minimize
    // |s u - r v + t|^2.
    let u = pose.rotation * a.to_homogeneous();
    let v = b.to_homogeneous();
    let t = pose.translation.vector;
    let (uu, uv, vv) = (u.dot(&u), u.dot(&v), v.dot(&v));
    let determinant = uu * vv - uv * uv;
    if determinant <= 1e-12 * uu * vv {
        return None;
    }
    let (ut, vt) = (u.dot(&t), v.dot(&t));
    let s = (uv * vt - vv * ut) / determinant;
    let r = (uu * vt - uv * ut) / determinant;
    let midpoint = (t + u * s + v * r) * 0.5;
    let in_a = pose.rotation.inverse() * (midpoint - t);
    (in_a.z.is_finite() && midpoint.z.is_finite()).then_some((in_a.z, midpoint.z))
}
