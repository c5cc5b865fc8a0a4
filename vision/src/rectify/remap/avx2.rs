//! AVX2 bilinear rows for 8-bit mono and 3-channel images. Each block of pixels whose
//! whole 2x2 neighbourhood lies inside the source is loaded with scalar loads (faster
//! than AVX2 gathers on the machines measured) and blended in fixed point (horizontal
//! `u8 x i8` multiply-add, then vertical `i16` multiply-add), which gives exactly the
//! bytes of the portable kernel; other blocks and row tails use the portable kernel.

use std::arch::x86_64::*;

use super::avx512;
use super::scalar::{self, PREFETCH_AHEAD, Source, prefetch};
use crate::rectify::map::{INTER_BITS, INTER_TAB_SIZE};

/// Bilinear mono8 row: AVX2 when the CPU has it, the portable kernel otherwise.
pub(super) fn bilinear_row_c1(
    src: Source<'_, u8>,
    xy: &[[i16; 2]],
    fraction: &[u16],
    dst: &mut [u8],
) {
    match Geometry::new::<1>(&src) {
        // SAFETY: AVX2 (checked by `Geometry::new`) and AVX-512 are present.
        Some(geometry) if avx512::available() => unsafe {
            avx512::bilinear_c1(src, geometry, xy, fraction, dst)
        },
        // SAFETY: AVX2 is present (checked by `Geometry::new`).
        Some(geometry) => unsafe { bilinear_c1(src, geometry, xy, fraction, dst) },
        None => scalar::bilinear_row::<u8, 1>(src, xy, fraction, dst),
    }
}

/// Bilinear rgb8/bgr8 row: AVX2 when the CPU has it, the portable kernel otherwise.
pub(super) fn bilinear_row_c3(
    src: Source<'_, u8>,
    xy: &[[i16; 2]],
    fraction: &[u16],
    dst: &mut [u8],
) {
    match Geometry::new::<3>(&src) {
        // SAFETY: AVX2 (checked by `Geometry::new`) and AVX-512 are present.
        Some(geometry) if avx512::available() => unsafe {
            avx512::bilinear_c3(src, geometry, xy, fraction, dst)
        },
        // SAFETY: AVX2 is present (checked by `Geometry::new`).
        Some(geometry) => unsafe { bilinear_c3(src, geometry, xy, fraction, dst) },
        None => scalar::bilinear_row::<u8, 3>(src, xy, fraction, dst),
    }
}

/// Limits for the vector path: integer positions must satisfy `0 <= x <= max_x`,
/// `0 <= y <= max_y` and their byte offset `(y * width + x) * CN` must not exceed
/// `max_offset`, so that every byte a vector block reads lies inside the source.
#[derive(Clone, Copy)]
pub(super) struct Geometry {
    width: i32,
    max_x: i16,
    max_y: i16,
    max_offset: i32,
}

impl Geometry {
    /// `None` when AVX2 is missing or the image is too small or too large for the
    /// 16- and 32-bit offset arithmetic.
    fn new<const CN: usize>(src: &Source<'_, u8>) -> Option<Self> {
        if !std::is_x86_feature_detected!("avx2") {
            return None;
        }
        let width = i16::try_from(src.width).ok()?;
        let height = i16::try_from(src.height).ok()?;
        let stride = src.width * CN;
        // Each vector block reads up to 4 (mono) or 8 (3-channel) bytes from the
        // top-left sample of both rows of the neighbourhood.
        let read = if CN == 1 { 4 } else { 8 };
        let max_offset = i32::try_from(src.samples.len().checked_sub(stride + read)?).ok()?;
        if width < 2 || height < 2 {
            return None;
        }
        Some(Self {
            width: i32::from(width),
            max_x: width - 2,
            max_y: height - 2,
            max_offset,
        })
    }
}

impl Geometry {
    /// `[max_x, max_y]` as a pair of i16, the layout of a map entry.
    pub(super) fn limits(self) -> i32 {
        (i32::from(self.max_y) << 16) | i32::from(self.max_x)
    }

    /// `[1, width]` as a pair of i16: multiply-adding a map entry gives `x + y * width`.
    pub(super) fn row_step(self) -> i32 {
        (self.width << 16) | 1
    }

    /// The largest byte offset of a neighbourhood's top-left sample.
    pub(super) fn max_offset(self) -> i32 {
        self.max_offset
    }
}

/// Byte offsets of 8 positions of a `CN`-channel image and whether all of them may
/// take the vector path.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn offsets8<const CN: usize>(geometry: Geometry, xy: __m256i) -> (__m256i, bool) {
    let limits = _mm256_set1_epi32(geometry.limits());
    let outside = _mm256_or_si256(
        _mm256_cmpgt_epi16(xy, limits),
        _mm256_cmpgt_epi16(_mm256_setzero_si256(), xy),
    );
    let pixels = _mm256_madd_epi16(xy, _mm256_set1_epi32(geometry.row_step()));
    let mut offsets = pixels;
    for _ in 1..CN {
        offsets = _mm256_add_epi32(offsets, pixels);
    }
    let too_far = _mm256_cmpgt_epi32(offsets, _mm256_set1_epi32(geometry.max_offset));
    let bad = _mm256_or_si256(outside, too_far);
    (offsets, _mm256_testz_si256(bad, bad) == 1)
}

/// Byte offsets of 4 three-channel positions and whether all of them may take the
/// vector path.
#[inline]
#[target_feature(enable = "avx2")]
fn offsets_c3(geometry: Geometry, xy: __m128i) -> (__m128i, bool) {
    let limits = _mm_set1_epi32(geometry.limits());
    let outside = _mm_or_si128(
        _mm_cmpgt_epi16(xy, limits),
        _mm_cmpgt_epi16(_mm_setzero_si128(), xy),
    );
    let pixels = _mm_madd_epi16(xy, _mm_set1_epi32(geometry.row_step()));
    let offsets = _mm_add_epi32(pixels, _mm_add_epi32(pixels, pixels));
    let too_far = _mm_cmpgt_epi32(offsets, _mm_set1_epi32(geometry.max_offset));
    let bad = _mm_or_si128(outside, too_far);
    (offsets, _mm_testz_si128(bad, bad) == 1)
}

/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
unsafe fn bilinear_c1(
    src: Source<'_, u8>,
    geometry: Geometry,
    xy: &[[i16; 2]],
    fraction: &[u16],
    dst: &mut [u8],
) {
    const LANES: usize = 8;
    let n = dst.len().min(xy.len()).min(fraction.len());
    let stride = src.width;
    let base = src.samples.as_ptr();
    let one = _mm256_set1_epi32(INTER_TAB_SIZE);
    let mask = _mm256_set1_epi32(INTER_TAB_SIZE - 1);
    let round = _mm256_set1_epi32(1 << (2 * INTER_BITS - 1));
    let mut x = 0;
    while x + LANES <= n {
        // SAFETY: `x + LANES <= n` keeps the 32-byte map load (8 pairs of i16) and the
        // 16-byte fraction load in bounds.
        let (pos, frac) = unsafe {
            (
                _mm256_loadu_si256(xy.as_ptr().add(x).cast()),
                _mm_loadu_si128(fraction.as_ptr().add(x).cast()),
            )
        };
        prefetch::<u8, 1>(src, xy.get(x + PREFETCH_AHEAD));
        let (offsets, inside) = offsets8::<1>(geometry, pos);
        if !inside {
            scalar::bilinear_row::<u8, 1>(
                src,
                &xy[x..x + LANES],
                &fraction[x..x + LANES],
                &mut dst[x..x + LANES],
            );
            x += LANES;
            continue;
        }
        let mut offs = [0i32; LANES];
        // SAFETY: `offs` holds 32 bytes.
        unsafe { _mm256_storeu_si256(offs.as_mut_ptr().cast(), offsets) };
        // Per pixel the bytes [p00 p01 p10 p11]: the top and bottom pairs of the 2x2
        // neighbourhood, blended horizontally by one multiply-add.
        let mut quads = [0i32; LANES];
        for (q, &o) in quads.iter_mut().zip(&offs) {
            let o = o as usize;
            // SAFETY: `0 <= o <= len - stride - 4` (checked by `offsets8`), so both
            // 2-byte reads lie inside the source.
            let (top, bottom) = unsafe {
                (
                    base.add(o).cast::<u16>().read_unaligned(),
                    base.add(o + stride).cast::<u16>().read_unaligned(),
                )
            };
            *q = (u32::from(top) | (u32::from(bottom) << 16)) as i32;
        }
        // SAFETY: `quads` holds 32 bytes.
        let quads = unsafe { _mm256_loadu_si256(quads.as_ptr().cast()) };
        let f = _mm256_cvtepu16_epi32(frac);
        let fx = _mm256_and_si256(f, mask);
        let fy = _mm256_srli_epi32::<{ INTER_BITS as i32 }>(f);
        let wx = _mm256_or_si256(_mm256_sub_epi32(one, fx), _mm256_slli_epi32::<8>(fx));
        let wx = _mm256_or_si256(wx, _mm256_slli_epi32::<16>(wx));
        let pair = _mm256_maddubs_epi16(quads, wx);
        let wy = _mm256_or_si256(_mm256_sub_epi32(one, fy), _mm256_slli_epi32::<16>(fy));
        let sum = _mm256_add_epi32(_mm256_madd_epi16(pair, wy), round);
        let value = _mm256_srli_epi32::<{ 2 * INTER_BITS as i32 }>(sum);
        let words = _mm256_packus_epi32(value, value);
        let bytes = _mm256_packus_epi16(words, words);
        let lo = _mm_cvtsi128_si32(_mm256_castsi256_si128(bytes)) as u32;
        let hi = _mm_cvtsi128_si32(_mm256_extracti128_si256::<1>(bytes)) as u32;
        let packed = u64::from(lo) | (u64::from(hi) << 32);
        dst[x..x + LANES].copy_from_slice(&packed.to_le_bytes());
        x += LANES;
    }
    scalar::bilinear_row::<u8, 1>(src, &xy[x..n], &fraction[x..n], &mut dst[x..n]);
}

/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
unsafe fn bilinear_c3(
    src: Source<'_, u8>,
    geometry: Geometry,
    xy: &[[i16; 2]],
    fraction: &[u16],
    dst: &mut [u8],
) {
    const LANES: usize = 4;
    let n = (dst.len() / 3).min(xy.len()).min(fraction.len());
    let stride = src.width * 3;
    let base = src.samples.as_ptr();
    let one = _mm256_set1_epi64x(i64::from(INTER_TAB_SIZE));
    let mask = _mm256_set1_epi64x(i64::from(INTER_TAB_SIZE - 1));
    let round = _mm256_set1_epi32(1 << (2 * INTER_BITS - 1));
    // [R0 G0 B0 R1 G1 B1 . .] -> [R0 R1 G0 G1 B0 B1 0 0] in each 64-bit lane.
    let pairs = _mm256_setr_epi8(
        0, 3, 1, 4, 2, 5, -1, -1, 8, 11, 9, 12, 10, 13, -1, -1, //
        0, 3, 1, 4, 2, 5, -1, -1, 8, 11, 9, 12, 10, 13, -1, -1,
    );
    // [R G B 0 R G B 0 | R G B 0 R G B 0] -> 12 packed bytes.
    let compact = _mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1);
    let mut x = 0;
    while x + LANES <= n {
        // SAFETY: `x + LANES <= n` keeps the 16-byte map load (4 pairs of i16) and the
        // 8-byte fraction load in bounds.
        let (pos, frac) = unsafe {
            (
                _mm_loadu_si128(xy.as_ptr().add(x).cast()),
                _mm_loadl_epi64(fraction.as_ptr().add(x).cast()),
            )
        };
        prefetch::<u8, 3>(src, xy.get(x + PREFETCH_AHEAD));
        let (byte_offsets, inside) = offsets_c3(geometry, pos);
        if !inside {
            scalar::bilinear_row::<u8, 3>(
                src,
                &xy[x..x + LANES],
                &fraction[x..x + LANES],
                &mut dst[3 * x..3 * (x + LANES)],
            );
            x += LANES;
            continue;
        }
        let mut offs = [0i32; LANES];
        // SAFETY: `offs` holds 16 bytes.
        unsafe { _mm_storeu_si128(offs.as_mut_ptr().cast(), byte_offsets) };
        // SAFETY: `0 <= o <= len - stride - 8` (checked by `offsets_c3`) and `row` is 0
        // or `stride`, so each 8-byte read lies inside the source.
        let load =
            |o: i32, row: usize| unsafe { _mm_loadl_epi64(base.add(o as usize + row).cast()) };
        let top01 = _mm_unpacklo_epi64(load(offs[0], 0), load(offs[1], 0));
        let top23 = _mm_unpacklo_epi64(load(offs[2], 0), load(offs[3], 0));
        let bot01 = _mm_unpacklo_epi64(load(offs[0], stride), load(offs[1], stride));
        let bot23 = _mm_unpacklo_epi64(load(offs[2], stride), load(offs[3], stride));
        let top = _mm256_inserti128_si256::<1>(_mm256_castsi128_si256(top01), top23);
        let bottom = _mm256_inserti128_si256::<1>(_mm256_castsi128_si256(bot01), bot23);
        let f = _mm256_cvtepu16_epi64(frac);
        let fx = _mm256_and_si256(f, mask);
        let fy = _mm256_srli_epi64::<{ INTER_BITS as i32 }>(f);
        let wx = _mm256_or_si256(_mm256_sub_epi64(one, fx), _mm256_slli_epi64::<8>(fx));
        let wx = _mm256_or_si256(
            _mm256_or_si256(wx, _mm256_slli_epi64::<16>(wx)),
            _mm256_slli_epi64::<32>(wx),
        );
        let top = _mm256_maddubs_epi16(_mm256_shuffle_epi8(top, pairs), wx);
        let bottom = _mm256_maddubs_epi16(_mm256_shuffle_epi8(bottom, pairs), wx);
        let wy = _mm256_or_si256(_mm256_sub_epi64(one, fy), _mm256_slli_epi64::<16>(fy));
        // Pixels 0 and 2 sit in the low halves of the 128-bit lanes, 1 and 3 in the high.
        let wy02 = _mm256_shuffle_epi32::<0b00_00_00_00>(wy);
        let wy13 = _mm256_shuffle_epi32::<0b10_10_10_10>(wy);
        let sum02 = _mm256_madd_epi16(_mm256_unpacklo_epi16(top, bottom), wy02);
        let sum13 = _mm256_madd_epi16(_mm256_unpackhi_epi16(top, bottom), wy13);
        let v02 = _mm256_srli_epi32::<{ 2 * INTER_BITS as i32 }>(_mm256_add_epi32(sum02, round));
        let v13 = _mm256_srli_epi32::<{ 2 * INTER_BITS as i32 }>(_mm256_add_epi32(sum13, round));
        let words = _mm256_packus_epi32(v02, v13);
        let bytes = _mm256_packus_epi16(words, words);
        let ordered = _mm256_permute4x64_epi64::<0b11_01_10_00>(bytes);
        let packed = _mm_shuffle_epi8(_mm256_castsi256_si128(ordered), compact);
        let mut out = [0u8; 16];
        // SAFETY: `out` has 16 bytes.
        unsafe { _mm_storeu_si128(out.as_mut_ptr().cast(), packed) };
        dst[3 * x..3 * (x + LANES)].copy_from_slice(&out[..12]);
        x += LANES;
    }
    scalar::bilinear_row::<u8, 3>(src, &xy[x..n], &fraction[x..n], &mut dst[3 * x..3 * n]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random positions covering the inside, the edges and the outside of the source.
    fn random_row(n: usize, width: usize, height: usize, seed: u64) -> (Vec<[i16; 2]>, Vec<u16>) {
        let mut state = seed;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let xy = (0..n)
            .map(|_| {
                let r = next();
                [
                    ((r % (width as u64 + 6)) as i16) - 3,
                    (((r >> 20) % (height as u64 + 6)) as i16) - 3,
                ]
            })
            .collect();
        let fraction = (0..n).map(|_| (next() % 1024) as u16).collect();
        (xy, fraction)
    }

    fn check<const CN: usize>(row: super::super::RowKernel<u8>) {
        for (width, height) in [(64, 48), (5, 3), (2, 2)] {
            let samples: Vec<u8> = (0..width * height * CN)
                .map(|i| (i * 37 % 251) as u8)
                .collect();
            let src = Source {
                samples: &samples,
                width,
                height,
            };
            for seed in 1..40u64 {
                let n = 37 + seed as usize;
                let (xy, fraction) =
                    random_row(n, width, height, seed.wrapping_mul(0x9e37_79b9_7f4a_7c15));
                let mut fast = vec![0u8; n * CN];
                let mut portable = vec![0u8; n * CN];
                row(src, &xy, &fraction, &mut fast);
                scalar::bilinear_row::<u8, CN>(src, &xy, &fraction, &mut portable);
                assert_eq!(fast, portable, "{width}x{height}, seed {seed}");
            }
            // A row entirely inside, so the vector path runs on every block.
            let n = 40;
            let xy: Vec<[i16; 2]> = (0..n)
                .map(|i| [(i % (width - 1)) as i16, (i % (height - 1)) as i16])
                .collect();
            let fraction: Vec<u16> = (0..n).map(|i| (i * 97 % 1024) as u16).collect();
            let mut fast = vec![0u8; n * CN];
            let mut portable = vec![0u8; n * CN];
            row(src, &xy, &fraction, &mut fast);
            scalar::bilinear_row::<u8, CN>(src, &xy, &fraction, &mut portable);
            assert_eq!(fast, portable, "{width}x{height}, all inside");
        }
    }

    /// The AVX2 kernel of `CN` channels alone, where the CPU also has AVX-512.
    fn avx2_row<const CN: usize>(
        src: Source<'_, u8>,
        xy: &[[i16; 2]],
        fraction: &[u16],
        dst: &mut [u8],
    ) {
        match Geometry::new::<CN>(&src) {
            // SAFETY: AVX2 is present (checked by `Geometry::new`).
            Some(geometry) if CN == 1 => unsafe { bilinear_c1(src, geometry, xy, fraction, dst) },
            // SAFETY: as above.
            Some(geometry) => unsafe { bilinear_c3(src, geometry, xy, fraction, dst) },
            None => scalar::bilinear_row::<u8, CN>(src, xy, fraction, dst),
        }
    }

    /// The AVX-512 kernel of `CN` channels alone, where the CPU has it.
    fn avx512_row<const CN: usize>(
        src: Source<'_, u8>,
        xy: &[[i16; 2]],
        fraction: &[u16],
        dst: &mut [u8],
    ) {
        match Geometry::new::<CN>(&src) {
            // SAFETY: AVX2 (checked by `Geometry::new`) and AVX-512 are present.
            Some(geometry) if avx512::available() && CN == 1 => unsafe {
                avx512::bilinear_c1(src, geometry, xy, fraction, dst)
            },
            // SAFETY: as above.
            Some(geometry) if avx512::available() => unsafe {
                avx512::bilinear_c3(src, geometry, xy, fraction, dst)
            },
            _ => scalar::bilinear_row::<u8, CN>(src, xy, fraction, dst),
        }
    }

    #[test]
    fn mono_matches_the_portable_kernel() {
        check::<1>(avx2_row::<1>);
        check::<1>(avx512_row::<1>);
        check::<1>(bilinear_row_c1);
    }

    #[test]
    fn three_channels_match_the_portable_kernel() {
        check::<3>(avx2_row::<3>);
        check::<3>(avx512_row::<3>);
        check::<3>(bilinear_row_c3);
    }
}
