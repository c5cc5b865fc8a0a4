//! The map rows of the equidistant (fisheye) model: OpenCV's
//! `fisheye::initUndistortRectifyMap` formulas, a block of pixels at a time in three
//! passes so that all but the arc tangent run on vectors: the rays, their normalized
//! points and radii; the arc tangents, one call per pixel; the distortion, projection
//! and rounding. Each pass evaluates the per-pixel formula's operations in its order
//! (branches become selects of values computed either way), so every position is the
//! same IEEE result.

use std::mem::MaybeUninit;

use super::{FRACTION_MASK, INTER_BITS, column_products, fixed_point};
use crate::camera::Intrinsics;

/// Pixels per block: the passes' buffers stay in the L1 cache.
const BLOCK: usize = 64;

/// Everything a row of an equidistant map needs, computed once per map.
pub(super) struct Fisheye {
    /// `(P[:, :3] R)^-1`, row-major.
    ir: [f64; 9],
    /// `ir[0] x`, `ir[3] x` and `ir[6] x` for every column `x` of the map.
    columns: [Vec<f64>; 3],
    /// `k1 k2 k3 k4`.
    d: [f64; 4],
    k: Intrinsics,
}

impl Fisheye {
    /// The rows, `width` pixels long, of the map with ray matrix `ir` (row-major
    /// `(P[:, :3] R)^-1`), camera `k` and equidistant coefficients `d`.
    pub(super) fn new(ir: [f64; 9], k: Intrinsics, d: [f64; 4], width: usize) -> Self {
        Self {
            ir,
            columns: column_products(&ir, width),
            d,
            k,
        }
    }

    /// Writes row `y` of the map: every element of `xy` and `fraction` (both one row
    /// long). Rays at or behind the image plane go to infinity (the border).
    pub(super) fn fill_row(
        &self,
        y: usize,
        xy: &mut [MaybeUninit<[i16; 2]>],
        fraction: &mut [MaybeUninit<u16>],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2.
            unsafe { self.fill_row_avx2(y, xy, fraction) };
            return;
        }
        self.fill_blocks(y, xy, fraction);
    }

    /// [`Fisheye::fill_blocks`] compiled for AVX2: four doubles per instruction, the same
    /// IEEE operations (no fused multiply-add).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn fill_row_avx2(
        &self,
        y: usize,
        xy: &mut [MaybeUninit<[i16; 2]>],
        fraction: &mut [MaybeUninit<u16>],
    ) {
        self.fill_blocks(y, xy, fraction);
    }

    #[inline(always)]
    fn fill_blocks(
        &self,
        y: usize,
        xy: &mut [MaybeUninit<[i16; 2]>],
        fraction: &mut [MaybeUninit<u16>],
    ) {
        let ir = &self.ir;
        let [k1, k2, k3, k4] = self.d;
        let k = self.k;
        let y = y as f64;
        let row = [ir[1] * y, ir[4] * y, ir[7] * y];
        let fraction = &mut fraction[..xy.len()];
        let mut ray = [[0.0f64; BLOCK]; 3];
        let mut point = [[0.0f64; BLOCK]; 2];
        let mut radius = [0.0f64; BLOCK];
        let mut theta = [0.0f64; BLOCK];
        for (block, (xy, fraction)) in xy
            .chunks_mut(BLOCK)
            .zip(fraction.chunks_mut(BLOCK))
            .enumerate()
        {
            let x0 = block * BLOCK;
            let n = xy.len();
            let [ax, ay, aw] = self.columns.each_ref().map(|c| &c[x0..x0 + n]);
            let [rx, ry, rw] = &mut ray;
            let [px, py] = &mut point;
            for i in 0..n {
                rx[i] = ax[i] + row[0] + ir[2];
                ry[i] = ay[i] + row[1] + ir[5];
                rw[i] = aw[i] + row[2] + ir[8];
                let (x, y) = (rx[i] / rw[i], ry[i] / rw[i]);
                px[i] = x;
                py[i] = y;
                radius[i] = (x * x + y * y).sqrt();
            }
            for (theta, r) in theta[..n].iter_mut().zip(&radius) {
                *theta = r.atan();
            }
            for (i, (xy, fraction)) in xy.iter_mut().zip(fraction.iter_mut()).enumerate() {
                let theta = theta[i];
                let theta2 = theta * theta;
                let theta4 = theta2 * theta2;
                let theta6 = theta4 * theta2;
                let theta8 = theta4 * theta4;
                let theta_d = theta * (1.0 + k1 * theta2 + k2 * theta4 + k3 * theta6 + k4 * theta8);
                let r = radius[i];
                let scale = if r == 0.0 { 1.0 } else { theta_d / r };
                let behind = rw[i] <= 0.0;
                let away = |ray: f64| {
                    if ray > 0.0 {
                        f64::NEG_INFINITY
                    } else {
                        f64::INFINITY
                    }
                };
                let u = if behind {
                    away(rx[i])
                } else {
                    k.fx * px[i] * scale + k.cx
                };
                let v = if behind {
                    away(ry[i])
                } else {
                    k.fy * py[i] * scale + k.cy
                };
                let (iu, iv) = (fixed_point(u), fixed_point(v));
                // The clamp in `fixed_point` keeps both integer parts in i16.
                xy.write([(iu >> INTER_BITS) as i16, (iv >> INTER_BITS) as i16]);
                fraction
                    .write((((iv & FRACTION_MASK) << INTER_BITS) | (iu & FRACTION_MASK)) as u16);
            }
        }
    }
}
