//! The new camera matrix of an undistorted (and possibly rotated) image, and the region
//! of its valid pixels, with OpenCV's `getOptimalNewCameraMatrix` semantics.

use nalgebra::{Matrix3, Point2, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::{CameraModel, DistortionModel, Intrinsics};

/// A rectangle of whole pixels (OpenCV's `cv::Rect`, ROS's `RegionOfInterest`): columns
/// `x .. x + width`, rows `y .. y + height`. All zero when empty.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Roi {
    /// First column.
    pub x: u32,
    /// First row.
    pub y: u32,
    /// Number of columns.
    pub width: u32,
    /// Number of rows.
    pub height: u32,
}

impl Roi {
    /// The intersection of the integer rectangle `(x, y, width, height)` with the image
    /// `0 .. image_width` x `0 .. image_height` (OpenCV's `Rect & Rect`); all zero when
    /// they do not overlap.
    pub fn clipped(x: i64, y: i64, width: i64, height: i64, image: (u32, u32)) -> Self {
        let x0 = x.max(0);
        let y0 = y.max(0);
        let x1 = (x + width).min(i64::from(image.0));
        let y1 = (y + height).min(i64::from(image.1));
        if x1 <= x0 || y1 <= y0 {
            return Self::default();
        }
        // The bounds above keep every value within 0..=u32::MAX.
        Self {
            x: x0 as u32,
            y: y0 as u32,
            width: (x1 - x0) as u32,
            height: (y1 - y0) as u32,
        }
    }
}

/// Why a new camera matrix could not be computed.
#[derive(Debug, Error, PartialEq)]
pub enum NewCameraMatrixError {
    /// The new image size has no pixels.
    #[error("new image size must be at least 2x2 pixels, got {width}x{height}")]
    EmptyImage {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// The camera's own image size is too small to sample.
    #[error("camera image size must be at least 2x2 pixels, got {width}x{height}")]
    EmptyCamera {
        /// Camera width.
        width: u32,
        /// Camera height.
        height: u32,
    },
    /// `alpha` (or `balance`) is not a finite number.
    #[error("alpha must be a finite number, got {0}")]
    BadAlpha(f64),
    /// The image border has no undistorted preimage (or none in front of the new view).
    #[error("no point of the image border has an undistorted preimage in front of the camera")]
    NoValidBorder,
}

/// A rectangle with real coordinates (OpenCV's `Rect_<double>`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rectangle {
    pub x: f64,
    pub y: f64,
    pub width: f64,
    pub height: f64,
}

impl Rectangle {
    /// OpenCV's conversion to an integer `Rect` (each field rounded to nearest, ties to
    /// even) intersected with the image.
    pub fn rounded_roi(&self, image: (u32, u32)) -> Roi {
        let round = |v: f64| v.round_ties_even() as i64;
        Roi::clipped(
            round(self.x),
            round(self.y),
            round(self.width),
            round(self.height),
            image,
        )
    }
}

/// The grid on which OpenCV samples the image to find the undistorted rectangles.
const GRID: usize = 9;

/// The inscribed (`inner`) and circumscribed (`outer`) rectangles of the image after
/// undistortion, rotation by `rotation` (rectified_from_original) and projection with
/// `new_camera` (normalized coordinates when `None`), found as OpenCV's
/// `getUndistortRectangles` does on a 9x9 grid of pixels spanning the image. Grid
/// points without an undistorted preimage in front of the rotated view are left out.
pub(crate) fn undistorted_rectangles(
    camera: &CameraModel,
    rotation: &Matrix3<f64>,
    new_camera: Option<&Matrix3<f64>>,
) -> Result<(Rectangle, Rectangle), NewCameraMatrixError> {
    if camera.width < 2 || camera.height < 2 {
        return Err(NewCameraMatrixError::EmptyCamera {
            width: camera.width,
            height: camera.height,
        });
    }
    let to_new = new_camera.copied().unwrap_or_else(Matrix3::identity) * rotation;
    let step_x = f64::from(camera.width - 1) / (GRID - 1) as f64;
    let step_y = f64::from(camera.height - 1) / (GRID - 1) as f64;
    let (mut i_x0, mut i_x1, mut i_y0, mut i_y1) = (
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
    );
    let (mut o_x0, mut o_x1, mut o_y0, mut o_y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let mut any = false;
    for y in 0..GRID {
        for x in 0..GRID {
            let pixel = Point2::new(x as f64 * step_x, y as f64 * step_y);
            let Some(ray) = camera.unproject(&pixel) else {
                continue;
            };
            let q: Vector3<f64> = to_new * ray;
            if q.z <= 0.0 {
                continue;
            }
            let p = Vector2::new(q.x / q.z, q.y / q.z);
            any = true;
            o_x0 = o_x0.min(p.x);
            o_x1 = o_x1.max(p.x);
            o_y0 = o_y0.min(p.y);
            o_y1 = o_y1.max(p.y);
            if x == 0 {
                i_x0 = i_x0.max(p.x);
            }
            if x == GRID - 1 {
                i_x1 = i_x1.min(p.x);
            }
            if y == 0 {
                i_y0 = i_y0.max(p.y);
            }
            if y == GRID - 1 {
                i_y1 = i_y1.min(p.y);
            }
        }
    }
    let inner = Rectangle {
        x: i_x0,
        y: i_y0,
        width: i_x1 - i_x0,
        height: i_y1 - i_y0,
    };
    let outer = Rectangle {
        x: o_x0,
        y: o_y0,
        width: o_x1 - o_x0,
        height: o_y1 - o_y0,
    };
    let finite = |r: &Rectangle| r.x.is_finite() && r.y.is_finite() && r.width > 0.0;
    if !any || !finite(&inner) || !finite(&outer) || inner.height <= 0.0 {
        return Err(NewCameraMatrixError::NoValidBorder);
    }
    Ok((inner, outer))
}

/// The camera matrix for an undistorted image of `new_size` pixels and the region of it
/// where every pixel comes from inside the source image.
///
/// Pinhole models (plumb_bob, rational_polynomial) follow OpenCV's
/// `getOptimalNewCameraMatrix` (with `centerPrincipalPoint = false`): `alpha = 0` keeps
/// only valid pixels (the inscribed rectangle of the undistorted image border fills the
/// new image), `alpha = 1` keeps every source pixel (the circumscribed rectangle fills
/// it), values in between interpolate the two matrices. The border is sampled on
/// OpenCV's 9x9 grid, so the ROI is exactly what OpenCV computes from the same grid.
/// Unlike OpenCV, the border pixels are undistorted to convergence (OpenCV uses 5
/// fixed-point iterations, which are off by pixels at strong distortion).
///
/// Equidistant (fisheye) follows OpenCV's
/// `fisheye::estimateNewCameraMatrixForUndistortRectify` with `balance = alpha`
/// (clamped to 0..1) and `fov_scale = 1`: `alpha = 0` uses the largest focal length
/// among the four edge midpoints (no invalid pixels along the edges' middles), `1` the
/// smallest (the whole width and height of the source fit). Its ROI is the inscribed
/// rectangle of the undistorted border under the new matrix, as for pinhole models
/// (OpenCV's fisheye API gives none).
pub fn optimal_new_camera_matrix(
    camera: &CameraModel,
    alpha: f64,
    new_size: (u32, u32),
) -> Result<(Intrinsics, Roi), NewCameraMatrixError> {
    if !alpha.is_finite() {
        return Err(NewCameraMatrixError::BadAlpha(alpha));
    }
    if new_size.0 < 2 || new_size.1 < 2 {
        return Err(NewCameraMatrixError::EmptyImage {
            width: new_size.0,
            height: new_size.1,
        });
    }
    let identity = Matrix3::identity();
    let intrinsics = match camera.distortion.model() {
        DistortionModel::Equidistant => {
            fisheye_new_intrinsics(camera, &identity, alpha, new_size, 1.0)?
        }
        DistortionModel::PlumbBob | DistortionModel::RationalPolynomial => {
            let (inner, outer) = undistorted_rectangles(camera, &identity, None)?;
            let w = f64::from(new_size.0 - 1);
            let h = f64::from(new_size.1 - 1);
            let (fx0, fy0) = (w / inner.width, h / inner.height);
            let (cx0, cy0) = (-fx0 * inner.x, -fy0 * inner.y);
            let (fx1, fy1) = (w / outer.width, h / outer.height);
            let (cx1, cy1) = (-fx1 * outer.x, -fy1 * outer.y);
            Intrinsics {
                fx: fx0 * (1.0 - alpha) + fx1 * alpha,
                fy: fy0 * (1.0 - alpha) + fy1 * alpha,
                cx: cx0 * (1.0 - alpha) + cx1 * alpha,
                cy: cy0 * (1.0 - alpha) + cy1 * alpha,
            }
        }
    };
    let (inner, _) = undistorted_rectangles(camera, &identity, Some(&intrinsics.matrix()))?;
    Ok((intrinsics, inner.rounded_roi(new_size)))
}

/// OpenCV's `fisheye::estimateNewCameraMatrixForUndistortRectify`: the new intrinsics
/// for the view rotated by `rotation` (rectified_from_original), from the four edge
/// midpoints of the image, with `balance` between the largest (0) and smallest (1)
/// focal length and the field of view divided by `fov_scale`.
pub(crate) fn fisheye_new_intrinsics(
    camera: &CameraModel,
    rotation: &Matrix3<f64>,
    balance: f64,
    new_size: (u32, u32),
    fov_scale: f64,
) -> Result<Intrinsics, NewCameraMatrixError> {
    if !balance.is_finite() || !fov_scale.is_finite() {
        return Err(NewCameraMatrixError::BadAlpha(balance));
    }
    let balance = balance.clamp(0.0, 1.0);
    // OpenCV uses integer halves and the full size (not size - 1) here.
    let (w, h) = (camera.width, camera.height);
    let (wf, hf) = (f64::from(w), f64::from(h));
    let edges = [
        (f64::from(w / 2), 0.0),
        (wf, f64::from(h / 2)),
        (f64::from(w / 2), hf),
        (0.0, f64::from(h / 2)),
    ];
    let aspect = camera.intrinsics.fx / camera.intrinsics.fy;
    let mut points = [Vector2::zeros(); 4];
    for (point, (u, v)) in points.iter_mut().zip(edges) {
        let ray = camera
            .unproject(&Point2::new(u, v))
            .ok_or(NewCameraMatrixError::NoValidBorder)?;
        let q = rotation * ray;
        if q.z <= 0.0 {
            return Err(NewCameraMatrixError::NoValidBorder);
        }
        *point = Vector2::new(q.x / q.z, q.y / q.z);
    }
    let mut centre = points.iter().sum::<Vector2<f64>>() / 4.0;
    centre.y *= aspect;
    for p in &mut points {
        p.y *= aspect;
    }
    let min_x = points.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
    let max_x = points.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
    let min_y = points.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let max_y = points.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
    let candidates = [
        wf * 0.5 / (centre.x - min_x),
        wf * 0.5 / (max_x - centre.x),
        hf * 0.5 * aspect / (centre.y - min_y),
        hf * 0.5 * aspect / (max_y - centre.y),
    ];
    let f_min = candidates.iter().copied().fold(f64::INFINITY, f64::min);
    let f_max = candidates.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut f = balance * f_min + (1.0 - balance) * f_max;
    if fov_scale > 0.0 {
        f /= fov_scale;
    }
    let mut fx = f;
    let mut fy = f;
    let mut cx = -centre.x * f + wf * 0.5;
    let mut cy = -centre.y * f + hf * aspect * 0.5;
    fy /= aspect;
    cy /= aspect;
    let rx = f64::from(new_size.0) / wf;
    let ry = f64::from(new_size.1) / hf;
    fx *= rx;
    fy *= ry;
    cx *= rx;
    cy *= ry;
    if !(fx.is_finite() && fy.is_finite() && cx.is_finite() && cy.is_finite()) {
        return Err(NewCameraMatrixError::NoValidBorder);
    }
    Ok(Intrinsics { fx, fy, cx, cy })
}
