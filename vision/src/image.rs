//! Owned, tightly packed images of 8- or 16-bit samples, the unit that remap and the
//! renderer work on. Conversion from and to ROS messages lives in the node runtime.

use thiserror::Error;

/// Sample storage of an [`Image`]: one element per channel per pixel, rows packed
/// without padding.
#[derive(Clone, Debug, PartialEq)]
pub enum Samples {
    /// 8-bit samples (mono8, rgb8, bgr8, ...).
    U8(Vec<u8>),
    /// 16-bit samples in native byte order (mono16, ...).
    U16(Vec<u16>),
}

/// An image with `channels` interleaved samples per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Interleaved channels per pixel (1 for mono, 3 for rgb/bgr).
    pub channels: usize,
    /// `width * height * channels` samples, row after row.
    pub samples: Samples,
}

/// Why an [`Image`] could not be built.
#[derive(Debug, Error, PartialEq)]
pub enum ImageError {
    /// The sample count does not match the declared size.
    #[error("image of {width}x{height}x{channels} needs {expected} samples, got {actual}")]
    SizeMismatch {
        /// Declared width.
        width: usize,
        /// Declared height.
        height: usize,
        /// Declared channels.
        channels: usize,
        /// Samples the size implies.
        expected: usize,
        /// Samples given.
        actual: usize,
    },
}

impl Image {
    /// Builds an image, checking that `samples` holds exactly `width * height * channels`.
    pub fn new(
        width: usize,
        height: usize,
        channels: usize,
        samples: Samples,
    ) -> Result<Self, ImageError> {
        let expected = width * height * channels;
        let actual = match &samples {
            Samples::U8(v) => v.len(),
            Samples::U16(v) => v.len(),
        };
        if expected != actual {
            return Err(ImageError::SizeMismatch {
                width,
                height,
                channels,
                expected,
                actual,
            });
        }
        Ok(Self {
            width,
            height,
            channels,
            samples,
        })
    }

    /// A black 8-bit image.
    pub fn zeros_u8(width: usize, height: usize, channels: usize) -> Self {
        Self {
            width,
            height,
            channels,
            samples: Samples::U8(vec![0; width * height * channels]),
        }
    }

    /// Samples per row.
    pub fn row_len(&self) -> usize {
        self.width * self.channels
    }
}
