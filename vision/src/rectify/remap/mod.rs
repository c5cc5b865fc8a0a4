//! Remap: resample an image through a [`RectifyMap`], OpenCV's `remap` with a
//! fixed-point map (`CV_16SC2` + `CV_16UC1`) and a constant border of value 0.
//!
//! 8-bit images interpolate with integer weights of 15 fractional bits (OpenCV's
//! `INTER_REMAP_COEF_BITS`) and give OpenCV's bytes; 16-bit images interpolate in single
//! precision like OpenCV. Rows run in parallel on the current rayon pool unless
//! [`Parallelism::Single`] is asked for; nothing is allocated per pixel. Bilinear 8-bit
//! mono and 3-channel images use AVX2 when the CPU has it.

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
mod scalar;
mod tables;

use rayon::prelude::*;
use thiserror::Error;

use super::map::RectifyMap;
use crate::image::{Image, Samples};
use scalar::{Sample, Source};

/// How a remapped pixel is interpolated from the source (ROS image_proc's
/// `interpolation` parameter: 0 nearest, 1 linear, 2 cubic).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Interpolation {
    /// The nearest source pixel.
    Nearest,
    /// Bilinear over the 2x2 neighbourhood.
    #[default]
    Bilinear,
    /// Bicubic convolution over the 4x4 neighbourhood (Keys kernel, `a = -0.75`, as
    /// OpenCV).
    Bicubic,
}

impl Interpolation {
    /// The interpolation of image_proc's `interpolation` parameter value, if valid.
    pub fn from_ros_parameter(value: i64) -> Option<Self> {
        match value {
            0 => Some(Self::Nearest),
            1 => Some(Self::Bilinear),
            2 => Some(Self::Bicubic),
            _ => None,
        }
    }
}

/// Whether remap spreads rows over threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Parallelism {
    /// Every row on the calling thread.
    Single,
    /// Rows in parallel on the current rayon pool (run inside `ThreadPool::install` to
    /// choose the pool).
    #[default]
    Rayon,
}

/// Options of [`remap`] and [`remap_into`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct RemapOptions {
    /// Interpolation (bilinear by default).
    pub interpolation: Interpolation,
    /// Threading (all threads of the rayon pool by default).
    pub parallelism: Parallelism,
}

/// Why an image could not be remapped.
#[derive(Debug, Error, PartialEq)]
pub enum RemapError {
    /// The source image's samples disagree with its declared size.
    #[error(
        "source image of {width}x{height}x{channels} holds {actual} samples, expected {expected}"
    )]
    SourceSize {
        /// Declared width.
        width: usize,
        /// Declared height.
        height: usize,
        /// Declared channels.
        channels: usize,
        /// Samples held.
        actual: usize,
        /// Samples the size implies.
        expected: usize,
    },
    /// The destination does not have the map's size, the source's channels and sample
    /// type.
    #[error(
        "destination image must be {expected_width}x{expected_height}x{expected_channels} \
         with the source's sample type, got {width}x{height}x{channels}"
    )]
    DestinationShape {
        /// Destination width.
        width: usize,
        /// Destination height.
        height: usize,
        /// Destination channels.
        channels: usize,
        /// The map's width.
        expected_width: usize,
        /// The map's height.
        expected_height: usize,
        /// The source's channels.
        expected_channels: usize,
    },
    /// Only 1 to 4 interleaved channels are supported.
    #[error("remap supports 1 to 4 channels, got {0}")]
    UnsupportedChannels(usize),
}

/// Remaps `src` through `map` into a new image of the map's size with the source's
/// channels and sample type.
pub fn remap(src: &Image, map: &RectifyMap, options: RemapOptions) -> Result<Image, RemapError> {
    let len = map.width() * map.height() * src.channels;
    let samples = match src.samples {
        Samples::U8(_) => Samples::U8(vec![0; len]),
        Samples::U16(_) => Samples::U16(vec![0; len]),
    };
    let mut dst = Image {
        width: map.width(),
        height: map.height(),
        channels: src.channels,
        samples,
    };
    remap_into(src, map, &mut dst, options)?;
    Ok(dst)
}

/// Remaps `src` through `map` into `dst`, which must already have the map's size and
/// the source's channels and sample type (reuse it frame after frame).
pub fn remap_into(
    src: &Image,
    map: &RectifyMap,
    dst: &mut Image,
    options: RemapOptions,
) -> Result<(), RemapError> {
    let channels = src.channels;
    if !(1..=4).contains(&channels) {
        return Err(RemapError::UnsupportedChannels(channels));
    }
    let expected = src.width * src.height * channels;
    let actual = match &src.samples {
        Samples::U8(v) => v.len(),
        Samples::U16(v) => v.len(),
    };
    if actual != expected {
        return Err(RemapError::SourceSize {
            width: src.width,
            height: src.height,
            channels,
            actual,
            expected,
        });
    }
    let shape_error = RemapError::DestinationShape {
        width: dst.width,
        height: dst.height,
        channels: dst.channels,
        expected_width: map.width(),
        expected_height: map.height(),
        expected_channels: channels,
    };
    if dst.width != map.width() || dst.height != map.height() || dst.channels != channels {
        return Err(shape_error);
    }
    let dst_len = map.width() * map.height() * channels;
    match (&src.samples, &mut dst.samples) {
        (Samples::U8(s), Samples::U8(d)) if d.len() == dst_len => {
            remap_samples(s, src.width, src.height, channels, map, d, options);
        }
        (Samples::U16(s), Samples::U16(d)) if d.len() == dst_len => {
            remap_samples(s, src.width, src.height, channels, map, d, options);
        }
        _ => return Err(shape_error),
    }
    Ok(())
}

/// [`remap_into`] for 8-bit samples held in plain slices, so that a caller holding the
/// pixels in another container (an image message) remaps without copying them:
/// `src` holds `width * height * channels` samples row after row, and `dst` receives
/// the map's `width * height * channels`.
pub fn remap_u8_into(
    src: &[u8],
    width: usize,
    height: usize,
    channels: usize,
    map: &RectifyMap,
    dst: &mut [u8],
    options: RemapOptions,
) -> Result<(), RemapError> {
    if !(1..=4).contains(&channels) {
        return Err(RemapError::UnsupportedChannels(channels));
    }
    let expected = width * height * channels;
    if src.len() != expected {
        return Err(RemapError::SourceSize {
            width,
            height,
            channels,
            actual: src.len(),
            expected,
        });
    }
    if dst.len() != map.width() * map.height() * channels {
        return Err(RemapError::DestinationShape {
            width: map.width(),
            height: dst.len() / (map.width() * channels).max(1),
            channels,
            expected_width: map.width(),
            expected_height: map.height(),
            expected_channels: channels,
        });
    }
    remap_samples(src, width, height, channels, map, dst, options);
    Ok(())
}

/// A row kernel: source, the map's row, the output row.
type RowKernel<T> = fn(Source<'_, T>, &[[i16; 2]], &[u16], &mut [T]);

fn remap_samples<T: Sample + RowKernels>(
    samples: &[T],
    width: usize,
    height: usize,
    channels: usize,
    map: &RectifyMap,
    dst: &mut [T],
    options: RemapOptions,
) {
    let src = Source {
        samples,
        width,
        height,
    };
    let kernel = T::kernel(channels, options.interpolation);
    let row_len = map.width() * channels;
    let run_row = |(y, out): (usize, &mut [T])| {
        let start = y * map.width();
        let end = start + map.width();
        kernel(src, &map.xy()[start..end], &map.fraction()[start..end], out);
    };
    match options.parallelism {
        Parallelism::Single => dst.chunks_exact_mut(row_len).enumerate().for_each(run_row),
        Parallelism::Rayon => dst
            .par_chunks_exact_mut(row_len)
            .enumerate()
            .for_each(run_row),
    }
}

/// The row kernel of each channel count and interpolation for a sample type.
trait RowKernels: Sample {
    fn kernel(channels: usize, interpolation: Interpolation) -> RowKernel<Self> {
        generic_kernel(channels, interpolation)
    }
}

fn generic_kernel<T: Sample>(channels: usize, interpolation: Interpolation) -> RowKernel<T> {
    macro_rules! pick {
        ($row:ident) => {
            match channels {
                1 => scalar::$row::<T, 1>,
                2 => scalar::$row::<T, 2>,
                3 => scalar::$row::<T, 3>,
                _ => scalar::$row::<T, 4>,
            }
        };
    }
    match interpolation {
        Interpolation::Nearest => pick!(nearest_row),
        Interpolation::Bilinear => pick!(bilinear_row),
        Interpolation::Bicubic => pick!(bicubic_row),
    }
}

impl RowKernels for u16 {}

impl RowKernels for u8 {
    fn kernel(channels: usize, interpolation: Interpolation) -> RowKernel<u8> {
        #[cfg(target_arch = "x86_64")]
        if interpolation == Interpolation::Bilinear {
            match channels {
                1 => return avx2::bilinear_row_c1,
                3 => return avx2::bilinear_row_c3,
                _ => {}
            }
        }
        generic_kernel(channels, interpolation)
    }
}

#[cfg(test)]
mod tests;
