//! Advice on a calibration that succeeded but should not be trusted blindly: too few
//! views, a high reprojection error, or a board that never reached parts of the image.
//! Each warning says what to do about it.

use nalgebra::Point2;

use crate::calibration_stage::{CalibrationOutcome, CameraResult};

/// Fewer views than this give intrinsics that vary from one session to the next.
const MIN_TRUSTED_VIEWS: usize = 10;

/// A reprojection RMS above this, in pixels, means blur, motion, a misdetected board or a
/// model that does not fit the lens: sharp views of a flat board reach well below it.
const MAX_TRUSTED_RMS: f64 = 1.0;

/// The image is split into this many columns and rows of regions; every region should
/// hold some corners, or the distortion there is extrapolated.
const REGIONS: usize = 3;

/// Where the used corners of one camera fell: corner counts in a 3x3 grid of image
/// regions, row-major from the top-left.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RegionCoverage {
    /// Corner count per region, `counts[row][col]`.
    pub counts: [[usize; REGIONS]; REGIONS],
}

impl RegionCoverage {
    /// Counts `pixels` (pixel centres at integer coordinates) into the regions of a
    /// `width x height` image; pixels outside the image are not counted.
    pub fn from_pixels<'a>(
        pixels: impl IntoIterator<Item = &'a Point2<f64>>,
        width: u32,
        height: u32,
    ) -> Self {
        let mut coverage = Self::default();
        let (w, h) = (f64::from(width), f64::from(height));
        for p in pixels {
            let (x, y) = (p.x + 0.5, p.y + 0.5);
            if !(0.0..w).contains(&x) || !(0.0..h).contains(&y) {
                continue;
            }
            let col = ((x / w * REGIONS as f64) as usize).min(REGIONS - 1);
            let row = ((y / h * REGIONS as f64) as usize).min(REGIONS - 1);
            coverage.counts[row][col] += 1;
        }
        coverage
    }

    /// Names of the regions no corner fell in (`top-left`, `centre`, ...).
    pub fn empty_regions(&self) -> Vec<&'static str> {
        const NAMES: [[&str; REGIONS]; REGIONS] = [
            ["top-left", "top", "top-right"],
            ["left", "centre", "right"],
            ["bottom-left", "bottom", "bottom-right"],
        ];
        let mut empty = Vec::new();
        for (row, names) in NAMES.iter().enumerate() {
            for (col, name) in names.iter().enumerate() {
                if self.counts[row][col] == 0 {
                    empty.push(*name);
                }
            }
        }
        empty
    }
}

/// The warnings about `outcome`, one sentence each, naming the camera and what to do.
pub fn warnings(outcome: &CalibrationOutcome) -> Vec<String> {
    let mut warnings = Vec::new();
    for camera in &outcome.cameras {
        camera_warnings(camera, &mut warnings);
    }
    if let Some(stereo) = &outcome.stereo {
        let calibration = &stereo.calibration;
        if stereo.used.len() < MIN_TRUSTED_VIEWS {
            warnings.push(format!(
                "stereo: only {} pairs used: right_from_left from fewer than \
                 {MIN_TRUSTED_VIEWS} pairs is unreliable; collect 15 to 25 pairs with the \
                 board seen by both cameras",
                stereo.used.len()
            ));
        }
        if calibration.epipolar_rms > MAX_TRUSTED_RMS {
            warnings.push(format!(
                "stereo: epipolar RMS {:.2} px is high: the cameras' stamps may not be \
                 synchronized, or the rig moved during the session; check the pairs' errors",
                calibration.epipolar_rms
            ));
        }
    }
    warnings
}

fn camera_warnings(camera: &CameraResult, warnings: &mut Vec<String>) {
    let name = &camera.name;
    let used = camera.used.len();
    if used < MIN_TRUSTED_VIEWS {
        warnings.push(format!(
            "camera {name}: only {used} views used: a calibration from fewer than \
             {MIN_TRUSTED_VIEWS} views is unreliable; collect 15 to 25 views at varied \
             positions and tilts"
        ));
    }
    let rms = camera.calibration.rms;
    if rms > MAX_TRUSTED_RMS {
        warnings.push(format!(
            "camera {name}: RMS {rms:.2} px is high: the views may be blurred, the board \
             moving or bent, or the lens needs another --model; check the views' errors"
        ));
    }
    let empty = camera.coverage.empty_regions();
    if !empty.is_empty() {
        warnings.push(format!(
            "camera {name}: no corner in the {} of the image: distortion there is \
             extrapolated; add views with the board in those regions",
            empty.join(", ")
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_count_pixels_and_name_the_empty_ones() {
        let pixels = [
            Point2::new(0.0, 0.0),
            Point2::new(639.0, 479.0),
            Point2::new(320.0, 240.0),
            Point2::new(-1.0, 10.0),
        ];
        let coverage = RegionCoverage::from_pixels(&pixels, 640, 480);
        assert_eq!(coverage.counts, [[1, 0, 0], [0, 1, 0], [0, 0, 1]]);
        assert_eq!(
            coverage.empty_regions(),
            ["top", "top-right", "left", "right", "bottom-left", "bottom"]
        );
    }
}
