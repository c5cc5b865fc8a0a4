//! Row alignment of rectified stereo pairs, measured on their pixels: the check that
//! rectification did its job. Each chessboard corner is located in the rectified left
//! and right images (a saddle-point fit started where the calibration predicts it) and
//! the two positions are compared across the baseline: same row for a horizontal rig,
//! same column for a vertical one.

use std::collections::BTreeMap;

use nalgebra::{Point2, Vector3};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs;
use stereocal_vision::image::Image;
use stereocal_vision::synth::{FrameKind, GroundTruth, SaddleFit, ViewRecord, saddle_point};

use crate::convert::{CalibratedCamera, image_from_msg};

/// Rectified images of one camera by stamp.
pub type RectifiedByStamp = BTreeMap<Time, sensor_msgs::Image>;

/// The rectified pixel of a raw pixel: undistorted, rotated by `R` and projected by the
/// left 3x3 block of `P` (what the rectify maps invert). `None` when the pixel has no
/// preimage through the lens model.
pub fn rectified_from_raw_pixel(
    camera: &CalibratedCamera,
    raw: &Point2<f64>,
) -> Option<Point2<f64>> {
    let ray: Vector3<f64> = camera.model.unproject(raw)?;
    let projected =
        camera.projection.fixed_view::<3, 3>(0, 0) * (camera.rectified_from_camera * ray);
    (projected.z > 0.0).then(|| Point2::new(projected.x / projected.z, projected.y / projected.z))
}

/// Whether the pair's baseline is vertical (`P2[1,3] != 0`), so that corners must share
/// columns rather than rows.
pub fn is_vertical_rig(right: &CalibratedCamera) -> bool {
    right.projection[(1, 3)].abs() > right.projection[(0, 3)].abs()
}

/// Alignment figures over a set of corners.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RowAlignment {
    /// Corners measured in both images.
    pub corners: usize,
    /// Corners predicted in both images that the fit could not locate in one of them.
    pub missed: usize,
    /// Sum of |dy| (|dx| for a vertical rig) between left and right, pixels.
    sum_abs_offset: f64,
    /// Largest |dy| (|dx| for a vertical rig), pixels.
    pub max_abs_offset: f64,
}

impl RowAlignment {
    /// Mean |dy| between the left and right positions of a corner (|dx| for a vertical
    /// rig), pixels; NaN when no corner was measured.
    pub fn mean_abs_offset(&self) -> f64 {
        self.sum_abs_offset / self.corners as f64
    }

    /// Adds the figures of another set of corners.
    pub fn merge(&mut self, other: &RowAlignment) {
        self.corners += other.corners;
        self.missed += other.missed;
        self.sum_abs_offset += other.sum_abs_offset;
        self.max_abs_offset = self.max_abs_offset.max(other.max_abs_offset);
    }
}

/// Measures the row alignment of one rectified pair. `left_raw` and `right_raw` hold,
/// per corner id, the corner's pixel in the raw (unrectified) images, `None` where it is
/// not visible; corners seen in both are located in the rectified images near their
/// predicted positions and compared.
pub fn measure_pair(
    left_rect: &Image,
    right_rect: &Image,
    left: &CalibratedCamera,
    right: &CalibratedCamera,
    left_raw: &[Option<Point2<f64>>],
    right_raw: &[Option<Point2<f64>>],
) -> RowAlignment {
    let vertical = is_vertical_rig(right);
    let fit = SaddleFit::default();
    // Keep clear of the border: the fit needs a full window around the corner.
    let margin = 3.0 * (fit.smoothing_sigma + fit.window_sigma);
    let inside = |image: &Image, p: &Point2<f64>| {
        p.x >= margin
            && p.y >= margin
            && p.x <= image.width as f64 - 1.0 - margin
            && p.y <= image.height as f64 - 1.0 - margin
    };
    let mut alignment = RowAlignment::default();
    for (l, r) in left_raw.iter().zip(right_raw) {
        let (Some(l), Some(r)) = (l, r) else { continue };
        let (Some(l), Some(r)) = (
            rectified_from_raw_pixel(left, l),
            rectified_from_raw_pixel(right, r),
        ) else {
            continue;
        };
        if !inside(left_rect, &l) || !inside(right_rect, &r) {
            continue;
        }
        match (
            saddle_point(left_rect, &l, &fit),
            saddle_point(right_rect, &r, &fit),
        ) {
            (Some(l), Some(r)) => {
                let offset = if vertical { l.x - r.x } else { l.y - r.y }.abs();
                alignment.corners += 1;
                alignment.sum_abs_offset += offset;
                alignment.max_abs_offset = alignment.max_abs_offset.max(offset);
            }
            _ => alignment.missed += 1,
        }
    }
    alignment
}

/// Row alignment over the clean frames of a synthetic stereo scene: for every frame of
/// `truth` that is clean and has rectified images from both cameras, the ground-truth
/// corners are measured in the rectified pair. Returns the figures and the number of
/// frames measured.
pub fn measure_stereo_scene(
    truth: &GroundTruth,
    left: &CalibratedCamera,
    right: &CalibratedCamera,
    left_rect: &RectifiedByStamp,
    right_rect: &RectifiedByStamp,
) -> (RowAlignment, usize) {
    let mut total = RowAlignment::default();
    let mut frames = 0;
    for frame in truth.frames.iter().filter(|f| f.kind == FrameKind::Clean) {
        let stamp = Time {
            sec: frame.stamp.sec,
            nanosec: frame.stamp.nanosec,
        };
        let (Some(l_msg), Some(r_msg), [l_view, r_view, ..]) = (
            left_rect.get(&stamp),
            right_rect.get(&stamp),
            frame.views.as_slice(),
        ) else {
            continue;
        };
        let (Ok((_, l_img)), Ok((_, r_img))) = (image_from_msg(l_msg), image_from_msg(r_msg))
        else {
            continue;
        };
        total.merge(&measure_pair(
            &l_img,
            &r_img,
            left,
            right,
            &visible_corners(l_view),
            &visible_corners(r_view),
        ));
        frames += 1;
    }
    (total, frames)
}

/// Per corner id, the raw pixel of a visible corner.
fn visible_corners(view: &ViewRecord) -> Vec<Option<Point2<f64>>> {
    let mut corners = Vec::new();
    for corner in &view.corners {
        if corners.len() <= corner.id {
            corners.resize(corner.id + 1, None);
        }
        corners[corner.id] = corner
            .pixel
            .filter(|_| corner.visible)
            .map(|[x, y]| Point2::new(x, y));
    }
    corners
}
