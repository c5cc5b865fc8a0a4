//! Dense stereo matching of rectified pairs: semi-global matching on census costs with
//! sub-pixel refinement on the images, block matching for the cheapest hardware, and
//! what a disparity map gives (depth, points).
//!
//! Conventions: a pair is rectified (epipolar lines are image rows); the disparity of a
//! left pixel `x` is `x - x_right`, in pixels, with pixel centres at integer
//! coordinates; an invalid disparity is NaN.

mod aggregate;
mod aligned;
mod bm;
mod census;
mod cost;
mod params;
mod refine;
mod reproject;
mod select;
mod sgm;
mod simd;
mod speckle;

pub use bm::{BlockMatcher, BmParams};
pub use census::{BITS as CENSUS_BITS, Sample, census_transform};
pub use params::{MAX_P2, MAX_REFINE_RADIUS, Paths, SgmParams};
pub use reproject::{Reprojection, ReprojectionError};
pub use sgm::{MAX_COST_CELLS, SemiGlobalMatcher};

use thiserror::Error;

use crate::image::{Image, Samples};

/// A disparity map of the left image of a rectified pair.
#[derive(Clone, Debug, PartialEq)]
pub struct DisparityMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Smallest disparity that was searched.
    pub min_disparity: i32,
    /// Number of disparities that were searched.
    pub disparity_range: usize,
    /// Disparity per pixel, row after row; NaN where there is no reliable match.
    pub data: Vec<f32>,
}

impl DisparityMap {
    fn empty() -> Self {
        Self {
            width: 0,
            height: 0,
            min_disparity: 0,
            disparity_range: 0,
            data: Vec::new(),
        }
    }

    fn reset(&mut self, width: usize, height: usize, min_disparity: i32, range: usize) {
        self.width = width;
        self.height = height;
        self.min_disparity = min_disparity;
        self.disparity_range = range;
        self.data.resize(width * height, f32::NAN);
    }

    /// The disparity at `(x, y)`, if valid.
    pub fn at(&self, x: usize, y: usize) -> Option<f32> {
        if x >= self.width {
            return None;
        }
        self.data
            .get(y * self.width + x)
            .copied()
            .filter(|d| !d.is_nan())
    }

    /// Fraction of pixels with a valid disparity.
    pub fn density(&self) -> f64 {
        if self.data.is_empty() {
            return 0.0;
        }
        self.data.iter().filter(|d| !d.is_nan()).count() as f64 / self.data.len() as f64
    }
}

/// Why a pair could not be matched.
#[derive(Debug, Error, PartialEq)]
pub enum StereoError {
    /// The two images differ in size.
    #[error(
        "the left image is {left_width}x{left_height} but the right is {right_width}x{right_height}"
    )]
    SizeMismatch {
        /// Left width.
        left_width: usize,
        /// Left height.
        left_height: usize,
        /// Right width.
        right_width: usize,
        /// Right height.
        right_height: usize,
    },
    /// The two images differ in sample type.
    #[error("the left and right images must have the same encoding (both 8-bit or both 16-bit)")]
    EncodingMismatch,
    /// An image has more than one channel.
    #[error("stereo matching takes single-channel images, got {channels} channels")]
    NotMono {
        /// Channels of the image.
        channels: usize,
    },
    /// The image is too small to match.
    #[error("the images are {width}x{height}; matching needs at least 16x8 pixels")]
    TooSmall {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// The pair is too large to match: its matching costs (pixels times disparities)
    /// would exceed the limit.
    #[error(
        "a {width}x{height} pair with {range} disparities has more matching costs than the limit of {limit}: use smaller images or fewer disparities"
    )]
    TooLarge {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Disparities searched.
        range: usize,
        /// Largest number of costs.
        limit: usize,
    },
    /// The disparity range cannot be used.
    #[error("disparity range {range}: {reason}")]
    DisparityRange {
        /// The range asked for.
        range: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// Another parameter cannot be used.
    #[error("{0}")]
    Parameter(String),
}

/// Checks that `left` and `right` can be matched: single channel, same size and
/// encoding, not tiny.
fn check_pair(left: &Image, right: &Image) -> Result<(), StereoError> {
    for image in [left, right] {
        if image.channels != 1 {
            return Err(StereoError::NotMono {
                channels: image.channels,
            });
        }
    }
    if (left.width, left.height) != (right.width, right.height) {
        return Err(StereoError::SizeMismatch {
            left_width: left.width,
            left_height: left.height,
            right_width: right.width,
            right_height: right.height,
        });
    }
    if left.width < 16 || left.height < 8 {
        return Err(StereoError::TooSmall {
            width: left.width,
            height: left.height,
        });
    }
    match (&left.samples, &right.samples) {
        (Samples::U8(_), Samples::U8(_)) | (Samples::U16(_), Samples::U16(_)) => Ok(()),
        _ => Err(StereoError::EncodingMismatch),
    }
}
