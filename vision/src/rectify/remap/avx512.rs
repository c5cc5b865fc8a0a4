//! AVX-512 bilinear rows for 8-bit mono and 3-channel images: sixteen (mono) or eight
//! (3-channel) pixels a block, their 2x2 neighbourhoods gathered in two instructions,
//! blended with the arithmetic of the AVX2 kernels (horizontal `u8 x i8` multiply-add,
//! then vertical `i16` multiply-add) and packed to bytes in one instruction. They give
//! exactly the bytes of the portable kernel; blocks that reach outside the source and
//! row tails use the portable kernel.

use std::arch::x86_64::*;

use super::avx2::{Geometry, offsets8};
use super::scalar::{self, PREFETCH_AHEAD, Source, prefetch};
use crate::rectify::map::{INTER_BITS, INTER_TAB_SIZE};

/// Whether the processor has the AVX-512 subsets the kernels use.
pub(super) fn available() -> bool {
    std::is_x86_feature_detected!("avx512f")
        && std::is_x86_feature_detected!("avx512bw")
        && std::is_x86_feature_detected!("avx512vl")
        && std::is_x86_feature_detected!("avx512vbmi")
}

/// Byte offsets of 16 mono positions and whether all of them may take the vector path.
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512bw")]
fn offsets_c1(geometry: Geometry, xy: __m512i) -> (__m512i, bool) {
    let limits = _mm512_set1_epi32(geometry.limits());
    let outside =
        _mm512_cmpgt_epi16_mask(xy, limits) | _mm512_cmplt_epi16_mask(xy, _mm512_setzero_si512());
    let offsets = _mm512_madd_epi16(xy, _mm512_set1_epi32(geometry.row_step()));
    let too_far = _mm512_cmpgt_epi32_mask(offsets, _mm512_set1_epi32(geometry.max_offset()));
    (offsets, outside == 0 && too_far == 0)
}

/// The bilinear mono8 row of the AVX2 kernel, sixteen pixels at a time.
///
/// # Safety
/// The CPU must support AVX2 and the AVX-512 subsets [`available`] checks, and
/// `geometry` must describe `src`.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi")]
pub(super) unsafe fn bilinear_c1(
    src: Source<'_, u8>,
    geometry: Geometry,
    xy: &[[i16; 2]],
    fraction: &[u16],
    dst: &mut [u8],
) {
    const LANES: usize = 16;
    let n = dst.len().min(xy.len()).min(fraction.len());
    let stride = src.width;
    let base = src.samples.as_ptr();
    let one = _mm512_set1_epi32(INTER_TAB_SIZE);
    let mask = _mm512_set1_epi32(INTER_TAB_SIZE - 1);
    let round = _mm512_set1_epi32(1 << (2 * INTER_BITS - 1));
    let mut x = 0;
    while x + LANES <= n {
        // SAFETY: `x + LANES <= n` keeps the 64-byte map load (16 pairs of i16) and the
        // 32-byte fraction load in bounds.
        let (pos, frac) = unsafe {
            (
                _mm512_loadu_si512(xy.as_ptr().add(x).cast()),
                _mm256_loadu_si256(fraction.as_ptr().add(x).cast()),
            )
        };
        prefetch::<u8, 1>(src, xy.get(x + PREFETCH_AHEAD));
        prefetch::<u8, 1>(src, xy.get(x + PREFETCH_AHEAD + LANES / 2));
        let (offsets, inside) = offsets_c1(geometry, pos);
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
        // SAFETY: `0 <= o <= len - stride - 4` for every offset (checked by
        // `offsets_c1`), so each 4-byte read of both rows lies inside the source.
        let (top, bottom) = unsafe {
            (
                _mm512_i32gather_epi32::<1>(offsets, base.cast()),
                _mm512_i32gather_epi32::<1>(offsets, base.add(stride).cast()),
            )
        };
        // Per pixel the bytes [p00 p01 p10 p11]: the top and bottom pairs of the 2x2
        // neighbourhood, blended horizontally by one multiply-add.
        let quads = _mm512_mask_blend_epi16(0xaaaa_aaaa, top, _mm512_slli_epi32::<16>(bottom));
        let f = _mm512_cvtepu16_epi32(frac);
        let fx = _mm512_and_si512(f, mask);
        let fy = _mm512_srli_epi32::<{ INTER_BITS }>(f);
        let wx = _mm512_or_si512(_mm512_sub_epi32(one, fx), _mm512_slli_epi32::<8>(fx));
        let wx = _mm512_or_si512(wx, _mm512_slli_epi32::<16>(wx));
        let pair = _mm512_maddubs_epi16(quads, wx);
        let wy = _mm512_or_si512(_mm512_sub_epi32(one, fy), _mm512_slli_epi32::<16>(fy));
        let sum = _mm512_add_epi32(_mm512_madd_epi16(pair, wy), round);
        let value = _mm512_srli_epi32::<{ 2 * INTER_BITS }>(sum);
        // SAFETY: `x + LANES <= dst.len()`.
        unsafe { _mm_storeu_si128(dst.as_mut_ptr().add(x).cast(), _mm512_cvtepi32_epi8(value)) };
        x += LANES;
    }
    scalar::bilinear_row::<u8, 1>(src, &xy[x..n], &fraction[x..n], &mut dst[x..n]);
}

/// The byte permutation that packs a block of eight 3-channel pixels: after packing to
/// bytes, 128-bit lane k holds [R G B 0 R G B 0] of pixels 2k and 2k+1 in its low 8
/// bytes; output byte j is channel j % 3 of pixel j / 3.
const C3_ORDER: [u8; 64] = {
    let mut order = [0u8; 64];
    let mut j = 0;
    while j < 24 {
        let (pixel, channel) = (j / 3, j % 3);
        order[j] = (16 * (pixel / 2) + 4 * (pixel % 2) + channel) as u8;
        j += 1;
    }
    order
};

/// The bilinear rgb8/bgr8 row of the AVX2 kernel, eight pixels at a time.
///
/// # Safety
/// The CPU must support AVX2 and the AVX-512 subsets [`available`] checks, and
/// `geometry` must describe `src`.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi")]
pub(super) unsafe fn bilinear_c3(
    src: Source<'_, u8>,
    geometry: Geometry,
    xy: &[[i16; 2]],
    fraction: &[u16],
    dst: &mut [u8],
) {
    const LANES: usize = 8;
    let n = (dst.len() / 3).min(xy.len()).min(fraction.len());
    let stride = src.width * 3;
    let base = src.samples.as_ptr();
    let one = _mm512_set1_epi64(i64::from(INTER_TAB_SIZE));
    let mask = _mm512_set1_epi64(i64::from(INTER_TAB_SIZE - 1));
    let round = _mm512_set1_epi32(1 << (2 * INTER_BITS - 1));
    // [R0 G0 B0 R1 G1 B1 . .] -> [R0 R1 G0 G1 B0 B1 0 0] in each 64-bit lane.
    let pairs = _mm512_broadcast_i32x4(_mm_setr_epi8(
        0, 3, 1, 4, 2, 5, -1, -1, 8, 11, 9, 12, 10, 13, -1, -1,
    ));
    // SAFETY: `C3_ORDER` holds 64 bytes.
    let order = unsafe { _mm512_loadu_si512(C3_ORDER.as_ptr().cast()) };
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
        prefetch::<u8, 3>(src, xy.get(x + PREFETCH_AHEAD));
        prefetch::<u8, 3>(src, xy.get(x + PREFETCH_AHEAD + LANES / 2));
        let (offsets, inside) = offsets8::<3>(geometry, pos);
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
        // SAFETY: `0 <= o <= len - stride - 8` for every offset (checked by
        // `offsets8`), so each 8-byte read of both rows lies inside the source.
        let (top, bottom) = unsafe {
            (
                _mm512_i32gather_epi64::<1>(offsets, base.cast()),
                _mm512_i32gather_epi64::<1>(offsets, base.add(stride).cast()),
            )
        };
        let f = _mm512_cvtepu16_epi64(frac);
        let fx = _mm512_and_si512(f, mask);
        let fy = _mm512_srli_epi64::<{ INTER_BITS }>(f);
        let wx = _mm512_or_si512(_mm512_sub_epi64(one, fx), _mm512_slli_epi64::<8>(fx));
        let wx = _mm512_or_si512(
            _mm512_or_si512(wx, _mm512_slli_epi64::<16>(wx)),
            _mm512_slli_epi64::<32>(wx),
        );
        let top = _mm512_maddubs_epi16(_mm512_shuffle_epi8(top, pairs), wx);
        let bottom = _mm512_maddubs_epi16(_mm512_shuffle_epi8(bottom, pairs), wx);
        let wy = _mm512_or_si512(_mm512_sub_epi64(one, fy), _mm512_slli_epi64::<16>(fy));
        // Even pixels sit in the low halves of the 128-bit lanes, odd ones in the high.
        let wy_even = _mm512_shuffle_epi32::<0b00_00_00_00>(wy);
        let wy_odd = _mm512_shuffle_epi32::<0b10_10_10_10>(wy);
        let sum_even = _mm512_madd_epi16(_mm512_unpacklo_epi16(top, bottom), wy_even);
        let sum_odd = _mm512_madd_epi16(_mm512_unpackhi_epi16(top, bottom), wy_odd);
        let even = _mm512_srli_epi32::<{ 2 * INTER_BITS }>(_mm512_add_epi32(sum_even, round));
        let odd = _mm512_srli_epi32::<{ 2 * INTER_BITS }>(_mm512_add_epi32(sum_odd, round));
        let words = _mm512_packus_epi32(even, odd);
        let bytes = _mm512_packus_epi16(words, words);
        let packed = _mm512_permutexvar_epi8(order, bytes);
        // SAFETY: `3 * (x + LANES) <= dst.len()`, and the mask writes only those 24 bytes.
        unsafe {
            _mm256_mask_storeu_epi8(
                dst.as_mut_ptr().add(3 * x).cast(),
                0x00ff_ffff,
                _mm512_castsi512_si256(packed),
            )
        };
        x += LANES;
    }
    scalar::bilinear_row::<u8, 3>(src, &xy[x..n], &fraction[x..n], &mut dst[3 * x..3 * n]);
}
