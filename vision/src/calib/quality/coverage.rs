//! Sample coverage as ROS camera_calibration judges it (image_pipeline,
//! `camera_calibration/src/camera_calibration/calibrator.py`): each view of the board is
//! described by four parameters in `[0, 1]` (X, Y, size, skew, `Calibrator.get_parameters`);
//! a view is kept when it is farther than 0.2 (sum of absolute differences) from every
//! kept one (`is_good_sample`); progress is the range each parameter has covered over
//! its required range (`compute_goodenough`).

use crate::board::Detection;
use nalgebra::Point2;
use serde::{Deserialize, Serialize};

/// A view is new when its parameters differ from every kept view's by more than this
/// (sum of absolute differences; camera_calibration's `is_good_sample`).
pub const NOVELTY_DISTANCE: f64 = 0.2;

/// With this many samples calibration may start whatever the coverage
/// (camera_calibration's `compute_goodenough`).
pub const ENOUGH_SAMPLES: usize = 40;

/// Range each of X, Y, size and skew must span for full coverage of a mono camera
/// (camera_calibration's `param_ranges`).
pub const MONO_RANGES: [f64; 4] = [0.7, 0.7, 0.4, 0.5];

/// Ranges for the cameras of a horizontal stereo rig: the X range is 0.4, since the
/// board cannot reach the far side of either image while both cameras see it
/// (camera_calibration's `StereoCalibrator`).
pub const STEREO_RANGES: [f64; 4] = [0.4, 0.7, 0.4, 0.5];

/// How one view of the board covers the image, each in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleParams {
    /// Horizontal position of the corners' mean, in an image shrunk on every side by
    /// half the board's size.
    pub x: f64,
    /// Vertical position, likewise.
    pub y: f64,
    /// Square root of the board's area over the image's.
    pub size: f64,
    /// Twice the divergence of the board's top-right corner angle from 90 degrees
    /// (radians), at most 1.
    pub skew: f64,
}

impl SampleParams {
    /// The parameters as `[x, y, size, skew]`.
    pub fn as_array(&self) -> [f64; 4] {
        [self.x, self.y, self.size, self.skew]
    }

    /// Sum of absolute differences between two views' parameters
    /// (camera_calibration's `param_distance`).
    pub fn distance(&self, other: &Self) -> f64 {
        self.as_array()
            .iter()
            .zip(other.as_array())
            .map(|(a, b)| (a - b).abs())
            .sum()
    }
}

/// The parameters of a detection of a `cols x rows` board in a `width x height` image
/// (camera_calibration's `get_parameters`): the outer corners are those of the largest
/// rectangle of detected corners (the board's four outer corners for a complete
/// chessboard, as `_get_outside_corners`; `_get_largest_rectangle_corners` for partial
/// views). `None` when the detection has no such rectangle of positive area or the image
/// is empty.
pub fn sample_params(
    detection: &Detection,
    cols: usize,
    rows: usize,
    width: usize,
    height: usize,
) -> Option<SampleParams> {
    if detection.corners.is_empty() || width == 0 || height == 0 {
        return None;
    }
    let [up_left, up_right, down_right, down_left] = outside_corners(detection, cols, rows)?;
    let area = quadrilateral_area(&up_left, &up_right, &down_right, &down_left);
    if area <= 0.0 {
        return None;
    }
    let skew = skew(&up_left, &up_right, &down_right)?;
    let n = detection.corners.len() as f64;
    let mean_x = detection.corners.iter().map(|p| p.x).sum::<f64>() / n;
    let mean_y = detection.corners.iter().map(|p| p.y).sum::<f64>() / n;
    let (width, height) = (width as f64, height as f64);
    // The image is shrunk all around by about half the board, so that large boards are
    // not penalized for the little X/Y variation they allow.
    let border = area.sqrt();
    Some(SampleParams {
        x: ((mean_x - border / 2.0) / (width - border)).clamp(0.0, 1.0),
        y: ((mean_y - border / 2.0) / (height - border)).clamp(0.0, 1.0),
        size: (area / (width * height)).sqrt(),
        skew,
    })
}

/// The corners (up-left, up-right, down-right, down-left) of the largest rectangle of
/// grid corners whose four corners were all detected.
fn outside_corners(detection: &Detection, cols: usize, rows: usize) -> Option<[Point2<f64>; 4]> {
    let mut grid: Vec<Option<Point2<f64>>> = vec![None; cols * rows];
    for (&id, corner) in detection.ids.iter().zip(&detection.corners) {
        if let Some(slot) = grid.get_mut(id) {
            *slot = Some(*corner);
        }
    }
    let at = |i: usize, j: usize| grid[j * cols + i];
    let mut best: Option<(usize, [Point2<f64>; 4])> = None;
    for x1 in 0..cols {
        for x2 in x1 + 1..cols {
            for y1 in 0..rows {
                for y2 in y1 + 1..rows {
                    let cells = (x2 - x1 + 1) * (y2 - y1 + 1);
                    if best.as_ref().is_some_and(|(b, _)| *b >= cells) {
                        continue;
                    }
                    if let (Some(a), Some(b), Some(c), Some(d)) =
                        (at(x1, y1), at(x2, y1), at(x2, y2), at(x1, y2))
                    {
                        best = Some((cells, [a, b, c, d]));
                    }
                }
            }
        }
    }
    best.map(|(_, corners)| corners)
}

/// Area of a convex quadrilateral as `|p x q| / 2` with its diagonals `p` and `q`
/// (camera_calibration's `_calculate_area`).
fn quadrilateral_area(
    up_left: &Point2<f64>,
    up_right: &Point2<f64>,
    down_right: &Point2<f64>,
    down_left: &Point2<f64>,
) -> f64 {
    let a = up_right - up_left;
    let b = down_right - up_right;
    let c = down_left - down_right;
    let p = b + c;
    let q = a + b;
    (p.x * q.y - p.y * q.x).abs() / 2.0
}

/// `min(1, 2 |pi/2 - angle(up_left, up_right, down_right)|)` (camera_calibration's
/// `_calculate_skew`); `None` for coincident corners.
fn skew(up_left: &Point2<f64>, up_right: &Point2<f64>, down_right: &Point2<f64>) -> Option<f64> {
    let ab = up_left - up_right;
    let cb = down_right - up_right;
    let norms = ab.norm() * cb.norm();
    if norms <= 0.0 {
        return None;
    }
    let angle = (ab.dot(&cb) / norms).clamp(-1.0, 1.0).acos();
    Some((2.0 * (std::f64::consts::FRAC_PI_2 - angle).abs()).min(1.0))
}

/// Whether a view with `params` adds coverage: farther than [`NOVELTY_DISTANCE`] from
/// every kept view (always, when none is kept).
pub fn is_new(params: &SampleParams, kept: &[SampleParams]) -> bool {
    kept.iter()
        .map(|k| params.distance(k))
        .fold(f64::INFINITY, f64::min)
        > NOVELTY_DISTANCE
}

/// Progress of each parameter towards its required range, `[x, y, size, skew]` each in
/// `[0, 1]` (camera_calibration's `compute_goodenough`): the span of X and Y over the
/// kept views, and the largest size and skew (small size or skew is not rewarded),
/// each over its range in `ranges`. All zero without views.
pub fn progress(kept: &[SampleParams], ranges: &[f64; 4]) -> [f64; 4] {
    let Some(first) = kept.first() else {
        return [0.0; 4];
    };
    let mut low = first.as_array();
    let mut high = low;
    for params in &kept[1..] {
        for (k, value) in params.as_array().into_iter().enumerate() {
            low[k] = low[k].min(value);
            high[k] = high[k].max(value);
        }
    }
    low[2] = 0.0;
    low[3] = 0.0;
    let mut out = [0.0; 4];
    for k in 0..4 {
        out[k] = ((high[k] - low[k]) / ranges[k]).min(1.0);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detection(
        cols: usize,
        rows: usize,
        corner: impl Fn(usize, usize) -> (f64, f64),
    ) -> Detection {
        let mut corners = Vec::new();
        for j in 0..rows {
            for i in 0..cols {
                let (x, y) = corner(i, j);
                corners.push(Point2::new(x, y));
            }
        }
        Detection {
            ids: (0..cols * rows).collect(),
            corners,
            square_px: 0.0,
        }
    }

    #[test]
    fn axis_aligned_board_matches_hand_computation() {
        // A 4x3 board with 50 px squares from (100, 200) in a 640x480 image: outer
        // corners (100, 200), (250, 200), (250, 300), (100, 300); area 150 * 100 = 15000;
        // mean corner (175, 250); border sqrt(15000) = 122.474...
        let d = detection(4, 3, |i, j| {
            (100.0 + 50.0 * i as f64, 200.0 + 50.0 * j as f64)
        });
        let p = sample_params(&d, 4, 3, 640, 480).unwrap();
        let border = 15000f64.sqrt();
        assert!((p.x - (175.0 - border / 2.0) / (640.0 - border)).abs() < 1e-12);
        assert!((p.y - (250.0 - border / 2.0) / (480.0 - border)).abs() < 1e-12);
        assert!((p.size - (15000.0f64 / (640.0 * 480.0)).sqrt()).abs() < 1e-12);
        assert!(p.skew.abs() < 1e-12);
        assert!((p.x - 0.219_820_4).abs() < 1e-6, "{}", p.x);
    }

    #[test]
    fn sheared_board_has_camera_calibration_skew_and_area() {
        // Rows shifted right by 20 px per row: corner (i, j) at (100 + 40 i + 20 j, 100 + 40 j)
        // on a 3x3 board. Up-left (100, 100), up-right (180, 100), down-right (220, 180),
        // down-left (140, 180). Angle at up-right between (-80, 0) and (40, 80):
        // acos(-3200 / (80 * 89.4427)) = 2.0344 rad; skew = 2 |pi/2 - 2.0344| = 0.9273.
        // Area of the parallelogram: 80 * 80 = 6400.
        let d = detection(3, 3, |i, j| {
            (
                100.0 + 40.0 * i as f64 + 20.0 * j as f64,
                100.0 + 40.0 * j as f64,
            )
        });
        let p = sample_params(&d, 3, 3, 400, 300).unwrap();
        let angle = (-3200.0 / (80.0 * 8000f64.sqrt())).acos();
        assert!((p.skew - 2.0 * (angle - std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
        assert!((p.skew - 0.927_295).abs() < 1e-6, "{}", p.skew);
        assert!((p.size - (6400.0 / 120_000.0f64).sqrt()).abs() < 1e-12);
        // Strong shear saturates at 1.
        let d = detection(3, 3, |i, j| {
            (
                100.0 + 40.0 * i as f64 + 80.0 * j as f64,
                100.0 + 20.0 * j as f64,
            )
        });
        assert_eq!(sample_params(&d, 3, 3, 400, 300).unwrap().skew, 1.0);
    }

    #[test]
    fn positions_clamp_to_the_unit_range() {
        // A flat 3x2 board along the top of a 640x480 image: area 6000, border 77.46,
        // mean y 5 < border / 2, so Y clamps to 0; along the bottom it clamps to 1.
        let d = detection(3, 2, |i, j| (300.0 * i as f64 + 10.0, 10.0 * j as f64));
        let p = sample_params(&d, 3, 2, 640, 480).unwrap();
        assert_eq!(p.y, 0.0);
        assert!(p.x > 0.0 && p.x < 1.0);
        let d = detection(3, 2, |i, j| {
            (300.0 * i as f64 + 10.0, 469.0 + 10.0 * j as f64)
        });
        assert_eq!(sample_params(&d, 3, 2, 640, 480).unwrap().y, 1.0);
    }

    #[test]
    fn partial_views_use_the_largest_complete_rectangle() {
        // A 4x3 grid missing corner id 0: the largest rectangle with four detected
        // corners spans columns 1..3 and rows 0..2 (3 x 3 cells) rather than 4 x 2.
        let full = detection(4, 3, |i, j| {
            (100.0 + 50.0 * i as f64, 100.0 + 50.0 * j as f64)
        });
        let partial = Detection {
            ids: full.ids[1..].to_vec(),
            corners: full.corners[1..].to_vec(),
            square_px: 0.0,
        };
        let corners = outside_corners(&partial, 4, 3).unwrap();
        assert_eq!(corners[0], Point2::new(150.0, 100.0));
        assert_eq!(corners[2], Point2::new(250.0, 200.0));
        let degenerate = Detection {
            ids: vec![0, 1],
            corners: vec![Point2::new(0.0, 0.0), Point2::new(1.0, 0.0)],
            square_px: 0.0,
        };
        assert_eq!(sample_params(&degenerate, 4, 3, 640, 480), None);
    }

    #[test]
    fn novelty_and_progress_follow_camera_calibration() {
        let a = SampleParams {
            x: 0.1,
            y: 0.2,
            size: 0.3,
            skew: 0.1,
        };
        let near = SampleParams {
            x: 0.2,
            y: 0.25,
            size: 0.3,
            skew: 0.15,
        };
        let far = SampleParams {
            x: 0.8,
            y: 0.9,
            size: 0.5,
            skew: 0.6,
        };
        assert!(is_new(&a, &[]));
        assert!((a.distance(&near) - 0.2).abs() < 1e-12);
        assert!(!is_new(&near, &[a]), "a distance of exactly 0.2 is not new");
        assert!(is_new(&far, &[a]));
        assert_eq!(progress(&[], &MONO_RANGES), [0.0; 4]);
        let p = progress(&[a, far], &MONO_RANGES);
        // x spans 0.7 of 0.7; y 0.7 of 0.7; size 0.5 (not 0.2: small is not rewarded) of
        // 0.4; skew 0.6 of 0.5.
        assert!((p[0] - 1.0).abs() < 1e-12 && (p[1] - 1.0).abs() < 1e-12);
        assert_eq!((p[2], p[3]), (1.0, 1.0));
        let p = progress(&[a], &MONO_RANGES);
        assert_eq!(p[0], 0.0);
        assert!((p[2] - 0.75).abs() < 1e-12 && (p[3] - 0.2).abs() < 1e-12);
        let stereo = progress(&[a, SampleParams { x: 0.3, ..a }], &STEREO_RANGES);
        assert!((stereo[0] - 0.5).abs() < 1e-12);
    }
}
