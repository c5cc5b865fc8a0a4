//! Viewing rays of a camera at the corners of its pixels, computed once per camera
//! and shared by every frame it renders.

use nalgebra::{Point2, Vector2, Vector3};
use rayon::prelude::*;

use crate::camera::CameraModel;

/// The ray through a pixel position, as a direction in the camera frame with `z = 1`,
/// or `None` where the lens model has no ray (beyond its invertible range).
pub(crate) fn ray_through_pixel(camera: &CameraModel, pixel: &Point2<f64>) -> Option<Vector3<f64>> {
    let distorted: Vector2<f64> = camera.intrinsics.normalized_from_pixel(pixel);
    let undistorted = camera.distortion.undistort(&distorted)?;
    Some(Vector3::new(undistorted.x, undistorted.y, 1.0))
}

/// Rays through the `(width + 1) x (height + 1)` pixel corners of a camera. Pixel
/// `(u, v)` covers `[u - 0.5, u + 0.5] x [v - 0.5, v + 0.5]`, so corner `(cu, cv)` is the
/// image position `(cu - 0.5, cv - 0.5)`. Rays inside a pixel are interpolated
/// bilinearly between its corners: the lens map bends by far less than a pixel's
/// size, so the interpolation error is well below a thousandth of a pixel.
#[derive(Clone, Debug)]
pub(crate) struct RayGrid {
    width: usize,
    height: usize,
    /// Row-major corner rays; NaN where the lens has no ray.
    rays: Vec<Vector3<f64>>,
}

impl RayGrid {
    /// Rays for every pixel corner of `camera`.
    pub(crate) fn new(camera: &CameraModel) -> Self {
        let width = camera.width as usize;
        let height = camera.height as usize;
        let stride = width + 1;
        let mut rays = vec![Vector3::zeros(); stride * (height + 1)];
        rays.par_chunks_mut(stride)
            .enumerate()
            .for_each(|(cv, row)| {
                for (cu, ray) in row.iter_mut().enumerate() {
                    let pixel = Point2::new(cu as f64 - 0.5, cv as f64 - 0.5);
                    *ray = ray_through_pixel(camera, &pixel)
                        .unwrap_or_else(|| Vector3::repeat(f64::NAN));
                }
            });
        Self {
            width,
            height,
            rays,
        }
    }

    /// Image width in pixels.
    pub(crate) fn width(&self) -> usize {
        self.width
    }

    /// Image height in pixels.
    pub(crate) fn height(&self) -> usize {
        self.height
    }

    /// The ray at pixel corner `(cu, cv)`.
    pub(crate) fn corner(&self, cu: usize, cv: usize) -> Vector3<f64> {
        self.rays[cv * (self.width + 1) + cu]
    }
}
