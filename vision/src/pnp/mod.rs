//! Perspective-n-point: the pose `camera_from_target` of a known target from the
//! pixels of its points.
//!
//! One file per solver. The solvers work on *normalized* image points: undistorted
//! coordinates `(X/Z, Y/Z)` on the camera's `z = 1` plane, which [`Correspondences`]
//! computes from pixels through any [`CameraModel`] (all three distortion models, or a
//! rectified camera through its projection matrix P as a distortion-free model).
//! [`refine()`] polishes a pose by Levenberg-Marquardt on the pixel reprojection error.
//!
//! Frames: a target point `X_t` maps to the camera frame as `camera_from_target * X_t`;
//! the camera frame is x right, y down, z forward.

pub mod epnp;
mod error;
mod estimate;
pub mod ippe;
pub mod p3p;
pub mod ransac;
pub mod refine;
pub mod sqpnp;

pub use error::PnpError;
pub use estimate::{PlanarAmbiguity, PoseEstimate, PoseOptions, Solver, estimate_pose};
pub use refine::{Refined, refine};

use nalgebra::{Point2, Point3};

use crate::camera::CameraModel;

/// Target points paired with their pixels, and the normalized image points the solvers
/// work on, checked once: same lengths, all finite, every pixel unprojectable.
#[derive(Clone, Debug, PartialEq)]
pub struct Correspondences {
    /// Points in the target frame, metres.
    pub target_points: Vec<Point3<f64>>,
    /// Their pixels, pixel centres at integer coordinates.
    pub pixels: Vec<Point2<f64>>,
    /// Their undistorted normalized image points `(X/Z, Y/Z)`.
    pub normalized: Vec<Point2<f64>>,
}

impl Correspondences {
    /// Pairs `target_points` with `pixels` seen by `camera`; an error names the first
    /// thing wrong (mismatched lengths, non-finite values, an unusable camera, a pixel
    /// with no ray).
    pub fn new(
        camera: &CameraModel,
        target_points: &[Point3<f64>],
        pixels: &[Point2<f64>],
    ) -> Result<Self, PnpError> {
        check_solver_input(target_points, pixels, 0)?;
        check_camera(camera)?;
        let normalized = camera
            .unproject_all(pixels)
            .into_iter()
            .zip(pixels)
            .enumerate()
            .map(|(index, (ray, pixel))| {
                ray.filter(|ray| ray.iter().all(|v| v.is_finite()))
                    .map(|ray| Point2::new(ray.x, ray.y))
                    .ok_or(PnpError::Unprojectable {
                        index,
                        x: pixel.x,
                        y: pixel.y,
                    })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            target_points: target_points.to_vec(),
            pixels: pixels.to_vec(),
            normalized,
        })
    }

    /// Number of correspondences.
    pub fn len(&self) -> usize {
        self.target_points.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.target_points.is_empty()
    }
}

/// Refuses solver input no pose can be computed from, before any arithmetic:
/// mismatched lengths, fewer than `needed` points, non-finite values.
pub(crate) fn check_solver_input(
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
    needed: usize,
) -> Result<(), PnpError> {
    if target_points.len() != normalized.len() {
        return Err(PnpError::MismatchedLengths {
            target_points: target_points.len(),
            image_points: normalized.len(),
        });
    }
    if target_points.len() < needed {
        return Err(PnpError::TooFewPoints {
            needed,
            got: target_points.len(),
        });
    }
    if !target_points
        .iter()
        .all(|p| p.coords.iter().all(|v| v.is_finite()))
    {
        return Err(PnpError::NonFinite("target points"));
    }
    if !normalized
        .iter()
        .all(|p| p.coords.iter().all(|v| v.is_finite()))
    {
        return Err(PnpError::NonFinite("image points"));
    }
    Ok(())
}

/// Refuses a camera model no pose can be computed through.
fn check_camera(camera: &CameraModel) -> Result<(), PnpError> {
    let k = &camera.intrinsics;
    if ![k.fx, k.fy, k.cx, k.cy].iter().all(|v| v.is_finite())
        || !camera.distortion.coeffs().iter().all(|v| v.is_finite())
    {
        return Err(PnpError::InvalidCamera(
            "non-finite intrinsics or distortion coefficients".into(),
        ));
    }
    if k.fx <= 0.0 || k.fy <= 0.0 {
        return Err(PnpError::InvalidCamera(format!(
            "focal lengths must be positive (fx {}, fy {}): is the camera calibrated?",
            k.fx, k.fy
        )));
    }
    Ok(())
}

/// The distorted plumb-bob camera the solvers' tests see their problems through.
#[cfg(test)]
pub(crate) fn test_camera() -> CameraModel {
    crate::synth::corner_session_camera()
}
