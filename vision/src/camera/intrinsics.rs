use nalgebra::{Matrix3, Point2, Vector2};
use serde::{Deserialize, Serialize};

/// Pinhole intrinsics without skew, in pixels: `u = fx * x + cx`, `v = fy * y + cy`
/// for a normalized coordinate `(x, y)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
}

impl Intrinsics {
    /// Reads the intrinsics from a 3x3 camera matrix `K` (its skew term is ignored).
    pub fn from_matrix(k: &Matrix3<f64>) -> Self {
        Self {
            fx: k[(0, 0)],
            fy: k[(1, 1)],
            cx: k[(0, 2)],
            cy: k[(1, 2)],
        }
    }

    /// The 3x3 camera matrix `K`.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// Pixel of a (distorted) normalized coordinate.
    pub fn pixel_from_normalized(&self, normalized: &Vector2<f64>) -> Point2<f64> {
        Point2::new(
            self.fx * normalized.x + self.cx,
            self.fy * normalized.y + self.cy,
        )
    }

    /// (Distorted) normalized coordinate of a pixel.
    pub fn normalized_from_pixel(&self, pixel: &Point2<f64>) -> Vector2<f64> {
        Vector2::new((pixel.x - self.cx) / self.fx, (pixel.y - self.cy) / self.fy)
    }
}
