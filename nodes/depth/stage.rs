//! The depth stage: a rectified pair (`left/image_rect`, `right/image_rect`) with its
//! two camera_infos in, the disparity of the left image and the geometry that turns it
//! into depth out, or the reason there is none. Every reason is a frame-level verdict:
//! the stage stays usable for the next pair.

use nalgebra::Matrix3x4;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg, PointCloud2, RegionOfInterest};
use stereocal_msgs::std_msgs::Header;
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::stereo::{
    BlockMatcher, BmParams, DisparityMap, Reprojection, ReprojectionError, SemiGlobalMatcher,
    SgmParams, StereoError,
};
use thiserror::Error;

use super::cloud::{CloudError, CloudLayout, cloud};
use crate::convert::{Encoding, ImageMsgError, decode_image_into};

/// Smallest disparity increment a [`DisparityImage`] from this stage declares: the
/// disparities are floats refined on the images, finer than OpenCV's sixteenths.
pub const DELTA_D: f32 = 1.0 / 256.0;

/// Why a pair has no disparity.
#[derive(Debug, Error, PartialEq)]
pub enum DepthRejection {
    /// An image message is malformed or has an unsupported encoding.
    #[error("{side} image: {error}")]
    Image {
        /// `left` or `right`.
        side: &'static str,
        /// What is wrong.
        error: ImageMsgError,
    },
    /// The two images differ in size or encoding.
    #[error(
        "the left image is {left} but the right is {right}: a pair has one size and one encoding"
    )]
    PairMismatch {
        /// Left size and encoding.
        left: String,
        /// Right size and encoding.
        right: String,
    },
    /// An image and its camera_info disagree on the size.
    #[error(
        "{side} image is {image_width}x{image_height} but its camera_info is {info_width}x{info_height}"
    )]
    InfoSize {
        /// `left` or `right`.
        side: &'static str,
        /// Image width.
        image_width: usize,
        /// Image height.
        image_height: usize,
        /// camera_info width.
        info_width: u32,
        /// camera_info height.
        info_height: u32,
    },
    /// The camera_infos do not describe a rectified horizontal pair.
    #[error("camera_info: {0}")]
    Geometry(#[from] ReprojectionError),
    /// The matcher refused the pair or its parameters.
    #[error(transparent)]
    Matching(#[from] StereoError),
}

/// The disparity of a pair and the geometry of its cameras.
#[derive(Debug, Clone)]
pub struct DisparityFrame {
    /// Disparity of each left pixel (NaN invalid), `x_right = x - d`.
    pub map: DisparityMap,
    /// Rectified geometry from the camera_infos' P.
    pub reprojection: Reprojection,
}

/// Which matcher a [`DepthStage`] runs, with its parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum MatcherParams {
    /// Semi-global matching on census costs (`stereo_algorithm: 1`).
    Sgm(SgmParams),
    /// Block matching (`stereo_algorithm: 0`).
    Bm(BmParams),
}

impl From<SgmParams> for MatcherParams {
    fn from(params: SgmParams) -> Self {
        Self::Sgm(params)
    }
}

impl From<BmParams> for MatcherParams {
    fn from(params: BmParams) -> Self {
        Self::Bm(params)
    }
}

impl MatcherParams {
    /// Checks the parameters against an image `width` pixels wide.
    pub fn validate(&self, width: usize) -> Result<(), StereoError> {
        match self {
            Self::Sgm(params) => params.validate(width),
            Self::Bm(params) => params.validate(width),
        }
    }
}

/// A matcher of either kind.
enum Matcher {
    Sgm(Box<SemiGlobalMatcher>),
    Bm(BlockMatcher),
}

/// Matches rectified pairs, keeping the matcher's buffers and the decoded images
/// between pairs.
pub struct DepthStage {
    matcher: Matcher,
    left: Image,
    right: Image,
}

impl DepthStage {
    /// A stage matching with `params` (semi-global or block-matching parameters).
    pub fn new(params: impl Into<MatcherParams>) -> Self {
        Self {
            matcher: match params.into() {
                MatcherParams::Sgm(params) => {
                    Matcher::Sgm(Box::new(SemiGlobalMatcher::new(params)))
                }
                MatcherParams::Bm(params) => Matcher::Bm(BlockMatcher::new(params)),
            },
            left: Image::zeros_u8(0, 0, 1),
            right: Image::zeros_u8(0, 0, 1),
        }
    }

    /// The disparity of the pair `left`/`right` (rectified: mono8, mono16, or 8-bit
    /// colour taken as grey) seen through `left_info`/`right_info`.
    pub fn disparity(
        &mut self,
        left: &ImageMsg,
        left_info: &CameraInfo,
        right: &ImageMsg,
        right_info: &CameraInfo,
    ) -> Result<DisparityFrame, DepthRejection> {
        let reprojection =
            Reprojection::from_projections(&projection(left_info), &projection(right_info))?;
        let left_encoding = grey_from_msg(left, "left", &mut self.left)?;
        let right_encoding = grey_from_msg(right, "right", &mut self.right)?;
        let (left_image, right_image) = (&self.left, &self.right);
        let describe = |image: &Image, encoding: Encoding| {
            format!("{}x{} {}", image.width, image.height, encoding.ros_name())
        };
        if (left_image.width, left_image.height) != (right_image.width, right_image.height)
            || std::mem::discriminant(&left_image.samples)
                != std::mem::discriminant(&right_image.samples)
        {
            return Err(DepthRejection::PairMismatch {
                left: describe(left_image, left_encoding),
                right: describe(right_image, right_encoding),
            });
        }
        for (side, image, info) in [
            ("left", left_image, left_info),
            ("right", right_image, right_info),
        ] {
            if (image.width as u32, image.height as u32) != (info.width, info.height) {
                return Err(DepthRejection::InfoSize {
                    side,
                    image_width: image.width,
                    image_height: image.height,
                    info_width: info.width,
                    info_height: info.height,
                });
            }
        }
        let map = match &mut self.matcher {
            Matcher::Sgm(matcher) => matcher.compute(left_image, right_image)?,
            Matcher::Bm(matcher) => matcher.compute(left_image, right_image)?,
        };
        Ok(DisparityFrame { map, reprojection })
    }
}

/// `P` of a camera_info as a matrix.
fn projection(info: &CameraInfo) -> Matrix3x4<f64> {
    Matrix3x4::from_row_slice(&info.p)
}

/// A single-channel image from an image message into `out` (its buffer reused): grey
/// images as they are, 8-bit colour by the luma of ITU-R BT.601 (as OpenCV's
/// `COLOR_RGB2GRAY`). Returns the message's encoding.
fn grey_from_msg(
    msg: &ImageMsg,
    side: &'static str,
    out: &mut Image,
) -> Result<Encoding, DepthRejection> {
    let encoding =
        decode_image_into(msg, out).map_err(|error| DepthRejection::Image { side, error })?;
    let channels = encoding.channels();
    if channels == 1 {
        return Ok(encoding);
    }
    let Samples::U8(samples) = &out.samples else {
        return Ok(encoding);
    };
    // Weights of red, green and blue in the order of the encoding's first three
    // channels, in 1/2^14 (OpenCV's fixed-point luma).
    let weights: [u32; 3] = match encoding {
        Encoding::Rgb8 | Encoding::Rgba8 => [4899, 9617, 1868],
        _ => [1868, 9617, 4899],
    };
    let grey = samples
        .chunks_exact(channels)
        .map(|p| {
            let sum: u32 = p.iter().zip(weights).map(|(&s, w)| u32::from(s) * w).sum();
            ((sum + (1 << 13)) >> 14) as u8
        })
        .collect();
    out.channels = 1;
    out.samples = Samples::U8(grey);
    Ok(encoding)
}

/// The [`DisparityImage`] of `frame`, as stereo_image_proc publishes it: `32FC1`
/// disparities shifted by the principal points' offset (`d - (cx_left - cx_right)`, so
/// that `Z = f * T / d`), `min_disparity` and `max_disparity` the searched range
/// (unshifted), invalid pixels at `min_disparity - 1 - (cx_left - cx_right)`: below
/// every valid one. The `valid_window` holds the columns some searched disparity can
/// match (`x - d` inside the image); it is computed without wrapping around.
pub fn disparity_msg(frame: &DisparityFrame, header: Header) -> DisparityImage {
    let map = &frame.map;
    let r = &frame.reprojection;
    let offset = (r.cx_left - r.cx_right) as f32;
    let min_disparity = map.min_disparity as f32;
    let max_disparity = min_disparity + map.disparity_range as f32 - 1.0;
    let invalid = min_disparity - 1.0 - offset;
    let values: Vec<f32> = map
        .data
        .iter()
        .map(|&d| if d.is_nan() { invalid } else { d - offset })
        .collect();
    let image = disparity_image(&values, map.width, map.height, header.clone());
    // Columns x with x - d in [0, width) for some d in [min, max]: x >= min and
    // x <= width - 1 + max.
    let width = map.width as i64;
    let (min, max) = (
        i64::from(map.min_disparity),
        i64::from(map.min_disparity) + map.disparity_range as i64 - 1,
    );
    let first = min.max(0);
    let last = (width - 1 + max.min(0)).min(width - 1);
    let valid_width = (last - first + 1).max(0);
    DisparityImage {
        header,
        image,
        f: r.fx as f32,
        t: r.baseline as f32,
        valid_window: RegionOfInterest {
            x_offset: if valid_width > 0 { first as u32 } else { 0 },
            y_offset: 0,
            height: if valid_width > 0 {
                map.height as u32
            } else {
                0
            },
            width: valid_width as u32,
            do_rectify: false,
        },
        min_disparity,
        max_disparity,
        delta_d: DELTA_D,
    }
}

/// A little-endian `32FC1` image message of `values` (rows of `width`).
fn disparity_image(values: &[f32], width: usize, height: usize, header: Header) -> ImageMsg {
    ImageMsg {
        header,
        height: height as u32,
        width: width as u32,
        encoding: "32FC1".to_owned(),
        is_bigendian: 0,
        step: (width * 4) as u32,
        data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

/// The organized [`PointCloud2`] of `frame` in the left camera's rectified optical
/// frame: one point per pixel, row after row, fields `x`, `y`, `z` (float32, metres,
/// 12 bytes a point, no padding), NaN where a pixel has no disparity.
pub fn points_msg(frame: &DisparityFrame, header: Header) -> Result<PointCloud2, CloudError> {
    let layout = CloudLayout {
        color: false,
        avoid_padding: true,
    };
    cloud(
        &frame.map.data,
        frame.map.width,
        &frame.reprojection,
        None,
        layout,
        header,
    )
}
