//! Camera models: pinhole intrinsics with a lens distortion model, projection of
//! camera-frame points to pixels, and the distortion function on normalized coordinates.
//!
//! Conventions: the camera frame is x right, y down, z forward (optical axis), in metres;
//! pixel centres are at integer coordinates; a normalized coordinate is `(X/Z, Y/Z)`.

mod distortion;
mod intrinsics;
mod new_camera_matrix;
mod projection;
mod undistort;

pub use distortion::{Distortion, DistortionJacobians, DistortionModel};
pub use intrinsics::Intrinsics;
pub use new_camera_matrix::{NewCameraMatrixError, Roi, optimal_new_camera_matrix};
pub(crate) use new_camera_matrix::{Rectangle, fisheye_new_intrinsics, undistorted_rectangles};
pub use projection::{Projection, TargetProjection, retract_pose};
pub use undistort::Undistorter;

use nalgebra::{Point2, Point3, Vector2, Vector3};

/// A calibrated camera: image size, pinhole intrinsics and lens distortion.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraModel {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal lengths and principal point.
    pub intrinsics: Intrinsics,
    /// Lens distortion.
    pub distortion: Distortion,
}

impl CameraModel {
    /// Projects a point in the camera frame to a pixel, or `None` when the point is
    /// not in front of the camera (`z <= 0`).
    pub fn project(&self, point_in_camera: &Point3<f64>) -> Option<Point2<f64>> {
        if point_in_camera.z <= 0.0 {
            return None;
        }
        let normalized = Vector2::new(
            point_in_camera.x / point_in_camera.z,
            point_in_camera.y / point_in_camera.z,
        );
        Some(
            self.intrinsics
                .pixel_from_normalized(&self.distortion.distort(&normalized)),
        )
    }

    /// The ray through a pixel, as the undistorted normalized point `(x, y, 1)` in the
    /// camera frame; `None` when the pixel has no preimage in the distortion model (see
    /// [`Distortion::undistort`]).
    pub fn unproject(&self, pixel: &Point2<f64>) -> Option<Vector3<f64>> {
        let distorted = self.intrinsics.normalized_from_pixel(pixel);
        let undistorted = self.distortion.undistort(&distorted)?;
        Some(Vector3::new(undistorted.x, undistorted.y, 1.0))
    }

    /// [`CameraModel::unproject`] of many pixels, the distortion model's invertible
    /// range found once for all of them.
    pub fn unproject_all(&self, pixels: &[Point2<f64>]) -> Vec<Option<Vector3<f64>>> {
        let undistorter = self.distortion.undistorter();
        pixels
            .iter()
            .map(|pixel| {
                let distorted = self.intrinsics.normalized_from_pixel(pixel);
                let undistorted = undistorter.undistort(&distorted)?;
                Some(Vector3::new(undistorted.x, undistorted.y, 1.0))
            })
            .collect()
    }

    /// Where the ideal, distortion-free pinhole camera with the same intrinsics sees
    /// what this camera images at `pixel`; `None` as for [`CameraModel::unproject`].
    pub fn undistort_pixel(&self, pixel: &Point2<f64>) -> Option<Point2<f64>> {
        let ray = self.unproject(pixel)?;
        Some(self.intrinsics.pixel_from_normalized(&ray.xy()))
    }
}
