//! The census transform: each pixel described by which of its neighbours are darker
//! than it, so that matching costs do not depend on gain, offset or any monotonic change
//! of brightness between the two cameras.

use rayon::prelude::*;

use super::simd::dispatched;

/// Width of the census window, pixels.
pub const WINDOW_WIDTH: usize = 9;
/// Height of the census window, pixels.
pub const WINDOW_HEIGHT: usize = 7;
/// Bits of a census descriptor: every pixel of the window but the centre. This is also
/// the largest matching cost (the Hamming distance of two descriptors).
pub const BITS: u32 = (WINDOW_WIDTH * WINDOW_HEIGHT - 1) as u32;

/// Census descriptors of a single-channel image of `width` x `height` samples, row after
/// row, into `out` (one `u64` per pixel). Bit `k` is set when the `k`-th neighbour (in
/// row-major order over the 9x7 window, the centre skipped) is darker than the centre.
/// Neighbours outside the image repeat the border pixel.
pub fn census_transform<T: Sample>(samples: &[T], width: usize, height: usize, out: &mut [u64]) {
    let (rx, ry) = (WINDOW_WIDTH / 2, WINDOW_HEIGHT / 2);
    let padded = width + 2 * rx;
    out.par_chunks_mut(width).enumerate().for_each_init(
        || vec![T::default(); padded * WINDOW_HEIGHT],
        |window_rows, (y, descriptors)| {
            // The window's rows with their borders repeated, so the inner loop never
            // needs clamping.
            for (k, padded_row) in window_rows.chunks_mut(padded).enumerate() {
                let sy = (y + k).saturating_sub(ry).min(height - 1);
                let row = &samples[sy * width..(sy + 1) * width];
                padded_row[rx..rx + width].copy_from_slice(row);
                padded_row[..rx].fill(row[0]);
                padded_row[rx + width..].fill(row[width - 1]);
            }
            T::census_row(window_rows, descriptors);
        },
    );
}

/// A sample type the census transform takes: 8- or 16-bit grey levels.
pub trait Sample: Copy + Default + PartialOrd + Send + Sync {
    /// Descriptors of one row from the window's padded rows.
    #[doc(hidden)]
    fn census_row(window_rows: &[Self], descriptors: &mut [u64]);
}

/// Descriptors of one row from the `WINDOW_HEIGHT` rows around it, each padded by
/// `WINDOW_WIDTH / 2` repeated border pixels on both sides.
#[inline(always)]
fn census_row_body<T: Copy + PartialOrd>(window_rows: &[T], descriptors: &mut [u64]) {
    let width = descriptors.len();
    let padded = window_rows.len() / WINDOW_HEIGHT;
    let (rx, ry) = (WINDOW_WIDTH / 2, WINDOW_HEIGHT / 2);
    let centre_row = &window_rows[ry * padded + rx..ry * padded + rx + width];
    descriptors.fill(0);
    for dy in 0..WINDOW_HEIGHT {
        let row = &window_rows[dy * padded..(dy + 1) * padded];
        for dx in 0..WINDOW_WIDTH {
            if dy == ry && dx == rx {
                continue;
            }
            let neighbours = &row[dx..dx + width];
            for ((descriptor, centre), neighbour) in
                descriptors.iter_mut().zip(centre_row).zip(neighbours)
            {
                *descriptor = (*descriptor << 1) | u64::from(*neighbour < *centre);
            }
        }
    }
}

dispatched! {
    /// Census descriptors of a row of 8-bit samples.
    fn census_row_u8(window_rows: &[u8], descriptors: &mut [u64]) = census_row_body::<u8>; avx512
}

dispatched! {
    /// Census descriptors of a row of 16-bit samples.
    fn census_row_u16(window_rows: &[u16], descriptors: &mut [u64]) = census_row_body::<u16>; avx512
}

impl Sample for u8 {
    fn census_row(window_rows: &[Self], descriptors: &mut [u64]) {
        census_row_u8(window_rows, descriptors);
    }
}

impl Sample for u16 {
    fn census_row(window_rows: &[Self], descriptors: &mut [u64]) {
        census_row_u16(window_rows, descriptors);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_image_has_empty_descriptors_and_a_dark_pixel_sets_one_bit() {
        let (width, height) = (20, 15);
        let mut samples = vec![100u8; width * height];
        let mut out = vec![u64::MAX; width * height];
        census_transform(&samples, width, height, &mut out);
        assert!(out.iter().all(|&d| d == 0));

        samples[7 * width + 10] = 10;
        census_transform(&samples, width, height, &mut out);
        // The dark pixel is the neighbour at (dx, dy) = (+1, 0) of the pixel (9, 7):
        // index 3 * 9 + 5 = 32 in the window, 31 once the centre is skipped, so the bit
        // at 61 - 31 = 30 from the least significant end.
        assert_eq!(out[7 * width + 9], 1 << 30);
        assert_eq!(out[7 * width + 10], 0);
        let set: u32 = out.iter().map(|d| d.count_ones()).sum();
        assert_eq!(set, BITS);
    }

    #[test]
    fn the_dispatched_copies_match_the_portable_body() {
        let width = 77;
        let padded = width + WINDOW_WIDTH - 1;
        let rows: Vec<u16> = (0..padded * WINDOW_HEIGHT)
            .map(|i| ((i * 7919) % 1009) as u16)
            .collect();
        let mut fast = vec![0; width];
        let mut portable = vec![0; width];
        census_row_u16(&rows, &mut fast);
        census_row_body(&rows, &mut portable);
        assert_eq!(fast, portable);
        let rows: Vec<u8> = rows.iter().map(|&v| (v % 251) as u8).collect();
        census_row_u8(&rows, &mut fast);
        census_row_body(&rows, &mut portable);
        assert_eq!(fast, portable);
    }

    #[test]
    fn descriptors_ignore_gain_and_offset() {
        let (width, height) = (32, 24);
        let samples: Vec<u16> = (0..width * height)
            .map(|i| ((i * 7919) % 1009) as u16)
            .collect();
        let brighter: Vec<u16> = samples.iter().map(|&v| 3 * v + 500).collect();
        let mut a = vec![0; width * height];
        let mut b = vec![0; width * height];
        census_transform(&samples, width, height, &mut a);
        census_transform(&brighter, width, height, &mut b);
        assert_eq!(a, b);
    }
}
