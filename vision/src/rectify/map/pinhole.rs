//! The map rows of the pinhole models (plumb_bob, rational_polynomial): OpenCV's
//! `initUndistortRectifyMap` formulas, written so that a row costs as little as the
//! formulas allow while every position stays the same IEEE result.
//!
//! For output pixel `(x, y)` the ray is `(P[:, :3] R)^-1 (x, y, 1)`, divided by its `z`
//! whatever its sign (as OpenCV does), distorted and projected with `K`. Each step is
//! evaluated in the same order with the same operations as the direct per-pixel
//! formula, without fused multiply-adds; only steps that are exact are rewritten:
//! - the products `ir[0] x`, `ir[3] x`, `ir[6] x` of every column are computed once
//!   per map, not once per row;
//! - a plumb_bob (or rational with `k4 = k5 = k6 = 0`) radial factor is not divided by
//!   its denominator: that denominator is exactly 1 for every finite `r^2`, and NaN
//!   (`0 * inf`) for an infinite one, which `num + 0 * r2` reproduces;
//! - the scaling to 1/32 pixel is folded into `K` (`32 fx`, `32 cx`): multiplying by a
//!   power of two commutes with rounding, except where an intermediate is subnormal or
//!   overflows, and there both forms round to the same fixed-point value (0 near the
//!   origin, the clamp far from it) as long as `K`'s entries are far from overflowing
//!   ([`FOLD_LIMIT`]); a camera beyond that is scaled after projecting, one pixel at a
//!   time.

use std::mem::MaybeUninit;

use super::{FRACTION_MASK, INTER_BITS, INTER_TAB_SIZE, column_products, fixed_point_steps};
use crate::camera::Intrinsics;

/// Largest magnitude of `fx, fy, cx, cy` for which the 1/32 pixel scaling is folded into
/// them: `32 fx x + 32 cx` can then overflow only where `fx x + cx` is beyond the clamp
/// too, on the same side.
const FOLD_LIMIT: f64 = 1e300;

/// Everything a row of a pinhole map needs, computed once per map.
pub(super) struct Pinhole {
    /// `(P[:, :3] R)^-1`, row-major.
    ir: [f64; 9],
    /// `ir[0] x`, `ir[3] x` and `ir[6] x` for every column `x` of the map.
    columns: [Vec<f64>; 3],
    /// `k1 k2 p1 p2 k3 k4 k5 k6`.
    d: [f64; 8],
    /// `fx, fy, cx, cy`, each times [`INTER_TAB_SIZE`] when `scale` is 1.
    k_steps: [f64; 4],
    /// What a projected position is multiplied by to be in 1/32 pixel: 1 when the
    /// scaling is folded into `k_steps`, else [`INTER_TAB_SIZE`].
    scale: f64,
    /// Whether the radial factor has a denominator other than 1 (`k4..k6` not all 0).
    rational: bool,
}

/// The per-row terms `ir[1] y`, `ir[4] y`, `ir[7] y` of the ray.
#[derive(Clone, Copy)]
struct RowTerms([f64; 3]);

impl Pinhole {
    /// The rows, `width` pixels long, of the map with ray matrix `ir` (row-major
    /// `(P[:, :3] R)^-1`), camera `k` and rational_polynomial coefficients `d`
    /// (plumb_bob: `k4..k6 = 0`).
    pub(super) fn new(ir: [f64; 9], k: Intrinsics, d: [f64; 8], width: usize) -> Self {
        let steps = f64::from(INTER_TAB_SIZE);
        let k = [k.fx, k.fy, k.cx, k.cy];
        let fold = k.iter().all(|v| v.abs() <= FOLD_LIMIT);
        Self {
            ir,
            columns: column_products(&ir, width),
            d,
            k_steps: if fold { k.map(|v| v * steps) } else { k },
            scale: if fold { 1.0 } else { steps },
            rational: d[5..].iter().any(|&k| k != 0.0),
        }
    }

    /// Writes row `y` of the map: every element of `xy` and `fraction` (both one row
    /// long).
    pub(super) fn fill_row(
        &self,
        y: usize,
        xy: &mut [MaybeUninit<[i16; 2]>],
        fraction: &mut [MaybeUninit<u16>],
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.scale == 1.0 && std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2.
            unsafe {
                if self.rational {
                    self.fill_row_avx2::<true>(y, xy, fraction);
                } else {
                    self.fill_row_avx2::<false>(y, xy, fraction);
                }
            }
            return;
        }
        if self.rational {
            self.fill_pixels::<true>(y, 0, xy, fraction);
        } else {
            self.fill_pixels::<false>(y, 0, xy, fraction);
        }
    }

    fn row_terms(&self, y: usize) -> RowTerms {
        let y = y as f64;
        RowTerms([self.ir[1] * y, self.ir[4] * y, self.ir[7] * y])
    }

    /// The source position of pixel `(x, y)`, not yet rounded, in 1/32 pixel once
    /// multiplied by `scale`.
    #[inline(always)]
    fn position<const RATIONAL: bool>(&self, x: usize, row: RowTerms) -> (f64, f64) {
        let ir = &self.ir;
        let [k1, k2, p1, p2, k3, k4, k5, k6] = self.d;
        let [fx, fy, cx, cy] = self.k_steps;
        let [ax, ay, aw] = &self.columns;
        let rx = ax[x] + row.0[0] + ir[2];
        let ry = ay[x] + row.0[1] + ir[5];
        let rw = aw[x] + row.0[2] + ir[8];
        let w = 1.0 / rw;
        let (x, y) = (rx * w, ry * w);
        let (x2, y2) = (x * x, y * y);
        let r2 = x2 + y2;
        let xy2 = 2.0 * x * y;
        let num = 1.0 + ((k3 * r2 + k2) * r2 + k1) * r2;
        let kr = if RATIONAL {
            num / (1.0 + ((k6 * r2 + k5) * r2 + k4) * r2)
        } else {
            num + r2 * 0.0
        };
        let xd = x * kr + p1 * xy2 + p2 * (r2 + 2.0 * x2);
        let yd = y * kr + p1 * (r2 + 2.0 * y2) + p2 * xy2;
        (fx * xd + cx, fy * yd + cy)
    }

    /// Writes pixels `x0..` of row `y` one at a time.
    #[inline(always)]
    fn fill_pixels<const RATIONAL: bool>(
        &self,
        y: usize,
        x0: usize,
        xy: &mut [MaybeUninit<[i16; 2]>],
        fraction: &mut [MaybeUninit<u16>],
    ) {
        let row = self.row_terms(y);
        for (i, (xy, fraction)) in xy.iter_mut().zip(fraction.iter_mut()).enumerate() {
            let (u, v) = self.position::<RATIONAL>(x0 + i, row);
            let (iu, iv) = (
                fixed_point_steps(u * self.scale),
                fixed_point_steps(v * self.scale),
            );
            // The clamp in `fixed_point_steps` keeps both integer parts in i16.
            xy.write([(iu >> INTER_BITS) as i16, (iv >> INTER_BITS) as i16]);
            fraction.write((((iv & FRACTION_MASK) << INTER_BITS) | (iu & FRACTION_MASK)) as u16);
        }
    }

    /// [`Pinhole::fill_pixels`] eight pixels at a time, four doubles per instruction:
    /// the same IEEE operations in the same order. Only for a `scale` of 1.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn fill_row_avx2<const RATIONAL: bool>(
        &self,
        y: usize,
        xy: &mut [MaybeUninit<[i16; 2]>],
        fraction: &mut [MaybeUninit<u16>],
    ) {
        use std::arch::x86_64::*;

        let n = xy.len();
        let fraction = &mut fraction[..n];
        let [ax, ay, aw] = &self.columns;
        let (ax, ay, aw) = (&ax[..n], &ay[..n], &aw[..n]);
        let row = self.row_terms(y);
        let ir = self.ir.map(|v| _mm256_set1_pd(v));
        let [rx_row, ry_row, rw_row] = row.0.map(|v| _mm256_set1_pd(v));
        let [k1, k2, p1, p2, k3, k4, k5, k6] = self.d.map(|v| _mm256_set1_pd(v));
        let [fx, fy, cx, cy] = self.k_steps.map(|v| _mm256_set1_pd(v));
        let one = _mm256_set1_pd(1.0);
        let lo = _mm256_set1_epi32(i32::from(i16::MIN) * INTER_TAB_SIZE);
        let hi = _mm256_set1_pd(f64::from(
            i32::from(i16::MAX) * INTER_TAB_SIZE + FRACTION_MASK,
        ));
        let fraction_mask = _mm256_set1_epi32(FRACTION_MASK);
        let low_half = _mm256_set1_epi32(0xffff);
        // Positions of pixels `i..i + 4` in 1/32 pixel, rounded half to even (the
        // default rounding mode, like OpenCV's cvRound) and clamped at the top; the
        // caller clamps at the bottom in integers, where NaN and anything below -2^31
        // have become i32::MIN (the same as `fixed_point_steps`, since the bounds are
        // integers). `min` returns its second operand, the position, when that is NaN.
        let fixed = |i: usize| -> (__m128i, __m128i) {
            // SAFETY: the caller keeps `i + 4 <= n`, the length of the column slices.
            let (ax, ay, aw) = unsafe {
                (
                    _mm256_loadu_pd(ax.as_ptr().add(i)),
                    _mm256_loadu_pd(ay.as_ptr().add(i)),
                    _mm256_loadu_pd(aw.as_ptr().add(i)),
                )
            };
            let rx = _mm256_add_pd(_mm256_add_pd(ax, rx_row), ir[2]);
            let ry = _mm256_add_pd(_mm256_add_pd(ay, ry_row), ir[5]);
            let rw = _mm256_add_pd(_mm256_add_pd(aw, rw_row), ir[8]);
            let w = _mm256_div_pd(one, rw);
            let (x, y) = (_mm256_mul_pd(rx, w), _mm256_mul_pd(ry, w));
            let (x2, y2) = (_mm256_mul_pd(x, x), _mm256_mul_pd(y, y));
            let r2 = _mm256_add_pd(x2, y2);
            let xy2 = _mm256_mul_pd(_mm256_add_pd(x, x), y);
            let poly = |c3: __m256d, c2: __m256d, c1: __m256d| {
                let p = _mm256_add_pd(_mm256_mul_pd(c3, r2), c2);
                let p = _mm256_add_pd(_mm256_mul_pd(p, r2), c1);
                _mm256_add_pd(one, _mm256_mul_pd(p, r2))
            };
            let num = poly(k3, k2, k1);
            let kr = if RATIONAL {
                _mm256_div_pd(num, poly(k6, k5, k4))
            } else {
                _mm256_add_pd(num, _mm256_mul_pd(r2, _mm256_setzero_pd()))
            };
            let xd = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(x, kr), _mm256_mul_pd(p1, xy2)),
                _mm256_mul_pd(p2, _mm256_add_pd(r2, _mm256_add_pd(x2, x2))),
            );
            let yd = _mm256_add_pd(
                _mm256_add_pd(
                    _mm256_mul_pd(y, kr),
                    _mm256_mul_pd(p1, _mm256_add_pd(r2, _mm256_add_pd(y2, y2))),
                ),
                _mm256_mul_pd(p2, xy2),
            );
            let u = _mm256_add_pd(_mm256_mul_pd(fx, xd), cx);
            let v = _mm256_add_pd(_mm256_mul_pd(fy, yd), cy);
            let round = |s: __m256d| _mm256_cvtpd_epi32(_mm256_min_pd(hi, s));
            (round(u), round(v))
        };
        let mut i = 0;
        while i + 8 <= n {
            let (u0, v0) = fixed(i);
            let (u1, v1) = fixed(i + 4);
            let iu = _mm256_max_epi32(_mm256_set_m128i(u1, u0), lo);
            let iv = _mm256_max_epi32(_mm256_set_m128i(v1, v0), lo);
            // `[x, y]` as two i16 in one 32-bit word, `x` in the low half.
            let integer = _mm256_or_si256(
                _mm256_and_si256(_mm256_srai_epi32::<{ INTER_BITS as i32 }>(iu), low_half),
                _mm256_slli_epi32::<16>(_mm256_srai_epi32::<{ INTER_BITS as i32 }>(iv)),
            );
            let sub = _mm256_or_si256(
                _mm256_slli_epi32::<{ INTER_BITS as i32 }>(_mm256_and_si256(iv, fraction_mask)),
                _mm256_and_si256(iu, fraction_mask),
            );
            let sub = _mm_packus_epi32(
                _mm256_castsi256_si128(sub),
                _mm256_extracti128_si256::<1>(sub),
            );
            // SAFETY: `i + 8 <= n` elements of 4 bytes (`xy`) and 2 bytes (`fraction`)
            // are in bounds; unaligned stores.
            unsafe {
                _mm256_storeu_si256(xy.as_mut_ptr().add(i).cast(), integer);
                _mm_storeu_si128(fraction.as_mut_ptr().add(i).cast(), sub);
            }
            i += 8;
        }
        self.fill_pixels::<RATIONAL>(y, i, &mut xy[i..], &mut fraction[i..]);
    }
}
