//! What a semi-global matcher is asked to do: the disparities it searches, the paths it
//! aggregates along, its smoothness penalties and the checks that reject a match.

use serde::{Deserialize, Serialize};

use super::StereoError;
use super::census;

/// Directions along which matching costs are aggregated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Paths {
    /// Left to right, right to left, top to bottom and bottom to top.
    Four,
    /// The five directions that come from the row above or from either side (left,
    /// right, top-left, top, top-right): one sweep over the image, as OpenCV's default
    /// SGBM mode.
    Five,
    /// All eight directions: the full semi-global matching of Hirschmüller.
    Eight,
}

/// Parameters of [`super::SemiGlobalMatcher`]. Costs are Hamming distances of 9x7
/// census descriptors (0 to 62), so the penalties are in the same units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SgmParams {
    /// Smallest disparity searched, pixels (may be negative).
    pub min_disparity: i32,
    /// Number of disparities searched, a positive multiple of 16 below the image width.
    pub disparity_range: usize,
    /// Aggregation directions.
    pub paths: Paths,
    /// Penalty for a change of disparity by one pixel between neighbours.
    pub p1: u16,
    /// Penalty for a larger change of disparity between neighbours, at least `p1`.
    pub p2: u16,
    /// A match is kept only when every disparity more than one pixel away from it costs
    /// at least this many percent more (0 turns the check off).
    pub uniqueness_ratio: u32,
    /// Largest difference, pixels, between the left-to-right and the right-to-left match
    /// of a pixel; `None` turns the left-right consistency check off.
    pub disp12_max_diff: Option<u32>,
    /// Connected regions of similar disparity with at most this many pixels are taken
    /// for noise and invalidated (0 turns the speckle filter off).
    pub speckle_size: usize,
    /// Largest disparity difference, pixels, between neighbours of one speckle region.
    pub speckle_range: f32,
    /// Half-size of the window of the sub-pixel refinement on the images (the window
    /// is `2 * refine_radius + 1` pixels square); 0 keeps the parabola through the
    /// aggregated costs.
    pub refine_radius: usize,
}

impl Default for SgmParams {
    fn default() -> Self {
        Self {
            min_disparity: 0,
            disparity_range: 128,
            paths: Paths::Eight,
            p1: 10,
            p2: 120,
            uniqueness_ratio: 5,
            disp12_max_diff: Some(1),
            speckle_size: 100,
            speckle_range: 2.0,
            refine_radius: 4,
        }
    }
}

/// Largest `refine_radius`: a 31-pixel window.
pub const MAX_REFINE_RADIUS: usize = 15;

/// Largest `p2`: eight paths of at most `BITS + p2` each stay inside a `u16` sum.
pub const MAX_P2: u16 = 8000 - census::BITS as u16;

impl SgmParams {
    /// Checks the parameters against an image `width` pixels wide.
    pub fn validate(&self, width: usize) -> Result<(), StereoError> {
        validate_search(self.min_disparity, self.disparity_range, width)?;
        if self.p1 == 0 || self.p2 < self.p1 || self.p2 > MAX_P2 {
            return Err(StereoError::Parameter(format!(
                "the penalties must satisfy 0 < P1 <= P2 <= {MAX_P2}, got P1 {} and P2 {}",
                self.p1, self.p2
            )));
        }
        if self.refine_radius > MAX_REFINE_RADIUS {
            return Err(StereoError::Parameter(format!(
                "refine_radius must be at most {MAX_REFINE_RADIUS}, got {}",
                self.refine_radius
            )));
        }
        validate_filters(self.uniqueness_ratio, self.speckle_range)
    }
}

/// Checks a disparity search of `range` disparities from `min_disparity` against an
/// image `width` pixels wide: what both matchers require.
pub(crate) fn validate_search(
    min_disparity: i32,
    range: usize,
    width: usize,
) -> Result<(), StereoError> {
    if range == 0 || !range.is_multiple_of(16) {
        return Err(StereoError::DisparityRange {
            range,
            reason: "it must be a positive multiple of 16".into(),
        });
    }
    if range >= width {
        return Err(StereoError::DisparityRange {
            range,
            reason: format!("it must be below the image width of {width} pixels"),
        });
    }
    if min_disparity.unsigned_abs() as usize >= width {
        return Err(StereoError::Parameter(format!(
            "min_disparity {min_disparity} must be within the image width of {width} pixels"
        )));
    }
    Ok(())
}

/// Checks the uniqueness ratio (a percentage below 100) and the speckle filter's range
/// (non-negative pixels) that both matchers take.
pub(crate) fn validate_filters(
    uniqueness_ratio: u32,
    speckle_range: f32,
) -> Result<(), StereoError> {
    if uniqueness_ratio >= 100 {
        return Err(StereoError::Parameter(format!(
            "uniqueness_ratio is a percentage below 100, got {uniqueness_ratio}"
        )));
    }
    if !(speckle_range.is_finite() && speckle_range >= 0.0) {
        return Err(StereoError::Parameter(format!(
            "speckle_range must be a non-negative number of pixels, got {speckle_range}"
        )));
    }
    Ok(())
}
