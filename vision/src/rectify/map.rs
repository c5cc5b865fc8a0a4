//! Undistort/rectify maps: for every pixel of the rectified (output) image, the position
//! in the original (distorted) image to sample, with the semantics of OpenCV's
//! `initUndistortRectifyMap` (pinhole models) and `fisheye::initUndistortRectifyMap`
//! (equidistant).
//!
//! Positions are stored in fixed point exactly like OpenCV's `CV_16SC2` + `CV_16UC1`
//! map pair: the integer part of the source position (`x`, `y` as `i16`) and a 10-bit
//! sub-pixel index `(fy << 5) | fx` where `fx`, `fy` are the fractions in 1/32 pixel
//! ([`INTER_TAB_SIZE`] steps). A position is therefore rounded to the nearest 1/32 pixel
//! (half-to-even on exact ties, like OpenCV's `cvRound`): the stored position is within
//! 1/64 pixel of the exact one. Positions farther than 32767 pixels from the origin are
//! clamped to the `i16` range; they lie outside any image and sample the border.

use std::mem::MaybeUninit;

use nalgebra::{Matrix3, Matrix3x4};
use rayon::prelude::*;
use thiserror::Error;

use crate::camera::{CameraModel, Distortion};

mod fisheye;
mod pinhole;

use fisheye::Fisheye;
use pinhole::Pinhole;

/// Bits of sub-pixel precision of a map position (OpenCV's `INTER_BITS`).
pub const INTER_BITS: u32 = 5;
/// Sub-pixel steps per pixel (OpenCV's `INTER_TAB_SIZE`).
pub const INTER_TAB_SIZE: i32 = 1 << INTER_BITS;
/// The sub-pixel bits of a position in 1/32 pixel.
const FRACTION_MASK: i32 = INTER_TAB_SIZE - 1;

/// Why a map could not be built.
#[derive(Debug, Error, PartialEq)]
pub enum MapError {
    /// The output size is zero or too large for 16-bit map coordinates.
    #[error("map size {width}x{height} is invalid: expected 1..=32767 pixels on each side")]
    InvalidSize {
        /// Requested width.
        width: usize,
        /// Requested height.
        height: usize,
    },
    /// `P[:, :3] * R` cannot be inverted, so output pixels have no ray.
    #[error("the new projection times the rectification rotation is singular")]
    SingularProjection,
    /// A matrix or camera parameter is NaN or infinite.
    #[error("{0} contains a non-finite value")]
    NonFinite(&'static str),
    /// The focal lengths are not positive.
    #[error("camera focal lengths must be positive, got fx={fx}, fy={fy}")]
    InvalidFocalLength {
        /// Focal length along x.
        fx: f64,
        /// Focal length along y.
        fy: f64,
    },
}

/// A precomputed remap table: for each output pixel, the source position in fixed
/// point (see the module documentation). Build it once per camera_info and reuse it
/// for every frame with [`remap`](super::remap::remap).
#[derive(Clone, Debug, PartialEq)]
pub struct RectifyMap {
    width: usize,
    height: usize,
    xy: Vec<[i16; 2]>,
    fraction: Vec<u16>,
}

impl RectifyMap {
    /// The undistort/rectify map of `camera` for an output image of `width` x `height`
    /// pixels. `rectified_from_original` is camera_info's `R` (identity to only
    /// undistort) and `projection` camera_info's `P`, of which the left 3x3 block is
    /// the camera matrix of the output image. Rows are computed in parallel on the
    /// current rayon pool.
    pub fn new(
        camera: &CameraModel,
        rectified_from_original: &Matrix3<f64>,
        projection: &Matrix3x4<f64>,
        width: usize,
        height: usize,
    ) -> Result<Self, MapError> {
        let k = camera.intrinsics;
        if ![k.fx, k.fy, k.cx, k.cy].iter().all(|v| v.is_finite())
            || !camera.distortion.coeffs().iter().all(|v| v.is_finite())
        {
            return Err(MapError::NonFinite("camera model"));
        }
        if !(k.fx > 0.0 && k.fy > 0.0) {
            return Err(MapError::InvalidFocalLength { fx: k.fx, fy: k.fy });
        }
        if !rectified_from_original.iter().all(|v| v.is_finite()) {
            return Err(MapError::NonFinite("rectification matrix R"));
        }
        if !projection.iter().all(|v| v.is_finite()) {
            return Err(MapError::NonFinite("projection matrix P"));
        }
        let new_camera = projection.fixed_view::<3, 3>(0, 0).into_owned();
        let original_from_pixel = (new_camera * rectified_from_original)
            .try_inverse()
            .ok_or(MapError::SingularProjection)?;
        let ir: [f64; 9] = original_from_pixel
            .transpose()
            .as_slice()
            .try_into()
            .map_err(|_| MapError::SingularProjection)?;
        // Before the column tables are sized by `width`.
        check_size(width, height)?;
        match camera.distortion {
            Distortion::PlumbBob {
                coeffs: [k1, k2, p1, p2, k3],
            } => {
                let pinhole = Pinhole::new(ir, k, [k1, k2, p1, p2, k3, 0.0, 0.0, 0.0], width);
                Self::from_rows(width, height, |y, xy, fraction| {
                    pinhole.fill_row(y, xy, fraction)
                })
            }
            Distortion::RationalPolynomial { coeffs } => {
                let pinhole = Pinhole::new(ir, k, coeffs, width);
                Self::from_rows(width, height, |y, xy, fraction| {
                    pinhole.fill_row(y, xy, fraction)
                })
            }
            Distortion::Equidistant { coeffs } => {
                let fisheye = Fisheye::new(ir, k, coeffs, width);
                Self::from_rows(width, height, |y, xy, fraction| {
                    fisheye.fill_row(y, xy, fraction)
                })
            }
        }
    }

    /// The map that only undistorts `camera` at its own size and camera matrix (OpenCV's
    /// `undistort` with the same camera matrix): `R` is the identity and `P = [K | 0]`.
    pub fn undistort(camera: &CameraModel) -> Result<Self, MapError> {
        let projection = camera.intrinsics.matrix().insert_column(3, 0.0);
        Self::new(
            camera,
            &Matrix3::identity(),
            &projection,
            camera.width as usize,
            camera.height as usize,
        )
    }

    /// A map from any function giving, for output pixel `(x, y)`, the source position
    /// in pixels (pixel centres at integer coordinates). Non-finite positions sample the
    /// border. Rows are computed in parallel on the current rayon pool.
    pub fn from_fn<F>(width: usize, height: usize, source: F) -> Result<Self, MapError>
    where
        F: Fn(usize, usize) -> (f64, f64) + Sync,
    {
        Self::from_rows(width, height, |y, xy_row, fraction_row| {
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2.
                unsafe { fill_row_avx2(&source, y, xy_row, fraction_row) };
                return;
            }
            fill_row(&source, y, xy_row, fraction_row);
        })
    }

    /// A map whose row `y` is written by `fill_row(y, xy, fraction)`, which must write
    /// every element of both (uninitialized) slices. Rows are filled in parallel on the
    /// current rayon pool.
    fn from_rows<F>(width: usize, height: usize, fill_row: F) -> Result<Self, MapError>
    where
        F: Fn(usize, &mut [MaybeUninit<[i16; 2]>], &mut [MaybeUninit<u16>]) + Sync,
    {
        check_size(width, height)?;
        let len = width * height;
        let mut xy: Vec<[i16; 2]> = Vec::with_capacity(len);
        let mut fraction: Vec<u16> = Vec::with_capacity(len);
        // Every element is written once below, so the tables are not zeroed first.
        xy.spare_capacity_mut()[..len]
            .par_chunks_mut(width)
            .zip(fraction.spare_capacity_mut()[..len].par_chunks_mut(width))
            .enumerate()
            .for_each(|(y, (xy_row, fraction_row))| fill_row(y, xy_row, fraction_row));
        // SAFETY: the capacity is `len`, and `fill_row` has written all `len` elements of
        // both tables, one row of `width` at a time.
        unsafe {
            xy.set_len(len);
            fraction.set_len(len);
        }
        Ok(Self {
            width,
            height,
            xy,
            fraction,
        })
    }

    /// Output width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Output height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Integer parts `[x, y]` of the source positions, row-major (OpenCV's `CV_16SC2`
    /// map).
    pub fn xy(&self) -> &[[i16; 2]] {
        &self.xy
    }

    /// Sub-pixel indices `(fy << 5) | fx`, row-major (OpenCV's `CV_16UC1` map).
    pub fn fraction(&self) -> &[u16] {
        &self.fraction
    }

    /// The stored source position of output pixel `(x, y)` in pixels, or `None` outside
    /// the map.
    pub fn source_position(&self, x: usize, y: usize) -> Option<(f64, f64)> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = y * self.width + x;
        let [ix, iy] = self.xy[i];
        let f = i32::from(self.fraction[i]);
        let step = f64::from(INTER_TAB_SIZE);
        Some((
            f64::from(ix) + f64::from(f & FRACTION_MASK) / step,
            f64::from(iy) + f64::from(f >> INTER_BITS) / step,
        ))
    }
}

/// Refuses a map size that is empty or too large for 16-bit map coordinates.
fn check_size(width: usize, height: usize) -> Result<(), MapError> {
    let max_side = i16::MAX as usize;
    if width == 0 || height == 0 || width > max_side || height > max_side {
        return Err(MapError::InvalidSize { width, height });
    }
    Ok(())
}

/// [`fill_row`] compiled for AVX2: four doubles per instruction instead of two. The
/// arithmetic is the same IEEE operations (no fused multiply-add), so the map is
/// identical.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn fill_row_avx2<F>(
    source: &F,
    y: usize,
    xy_row: &mut [MaybeUninit<[i16; 2]>],
    fraction_row: &mut [MaybeUninit<u16>],
) where
    F: Fn(usize, usize) -> (f64, f64),
{
    fill_row(source, y, xy_row, fraction_row);
}

/// Fills one map row. Positions are computed a chunk at a time into small buffers and
/// converted to fixed point in a second pass, so both loops are free of calls and
/// branches and the compiler can vectorize them.
#[inline(always)]
fn fill_row<F>(
    source: &F,
    y: usize,
    xy_row: &mut [MaybeUninit<[i16; 2]>],
    fraction_row: &mut [MaybeUninit<u16>],
) where
    F: Fn(usize, usize) -> (f64, f64),
{
    const CHUNK: usize = 64;
    let mut u = [0.0f64; CHUNK];
    let mut v = [0.0f64; CHUNK];
    for (chunk, (xy_chunk, fraction_chunk)) in xy_row
        .chunks_mut(CHUNK)
        .zip(fraction_row.chunks_mut(CHUNK))
        .enumerate()
    {
        let x0 = chunk * CHUNK;
        let n = xy_chunk.len();
        for (i, (u, v)) in u[..n].iter_mut().zip(v[..n].iter_mut()).enumerate() {
            (*u, *v) = source(x0 + i, y);
        }
        for (((xy_px, fraction_px), &u), &v) in xy_chunk
            .iter_mut()
            .zip(fraction_chunk.iter_mut())
            .zip(&u)
            .zip(&v)
        {
            let (iu, iv) = (fixed_point(u), fixed_point(v));
            // The clamp in `fixed_point` keeps both integer parts in i16.
            xy_px.write([(iu >> INTER_BITS) as i16, (iv >> INTER_BITS) as i16]);
            fraction_px.write((((iv & FRACTION_MASK) << INTER_BITS) | (iu & FRACTION_MASK)) as u16);
        }
    }
}

/// `ir[0] x`, `ir[3] x` and `ir[6] x` for the columns `x` of a map `width` pixels wide:
/// the terms of the ray `(P[:, :3] R)^-1 (x, y, 1)` that are the same on every row.
fn column_products(ir: &[f64; 9], width: usize) -> [Vec<f64>; 3] {
    [ir[0], ir[3], ir[6]].map(|a| (0..width).map(|x| a * x as f64).collect())
}

/// `round(v * 32)`, half to even like OpenCV's `cvRound`, clamped so that the integer
/// part fits in `i16`; NaN goes far outside any image.
#[inline(always)]
fn fixed_point(v: f64) -> i32 {
    fixed_point_steps(v * f64::from(INTER_TAB_SIZE))
}

/// [`fixed_point`] of a position already in 1/32 pixel.
#[inline(always)]
fn fixed_point_steps(steps: f64) -> i32 {
    // 1.5 * 2^52: adding it to a value of magnitude below 2^51 rounds to an integer (ties
    // to even) held in the low mantissa bits, which read as two's complement.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let lo = f64::from(i32::from(i16::MIN) * INTER_TAB_SIZE);
    let hi = f64::from(i32::from(i16::MAX) * INTER_TAB_SIZE + FRACTION_MASK);
    // `max` maps NaN to `lo`. Clamping before rounding keeps the same result, since the
    // bounds are integers, and keeps the value in the range of the rounding trick.
    let clamped = steps.max(lo).min(hi);
    (clamped + ROUND).to_bits() as u32 as i32
}

#[cfg(test)]
mod tests;
