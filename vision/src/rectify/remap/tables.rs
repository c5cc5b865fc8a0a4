//! Interpolation weights, computed exactly as OpenCV's `initInterTab2D` computes them so
//! that remap rounds like OpenCV: single-precision 1-D kernels, their outer product,
//! and for 8-bit images the product scaled to 15 fractional bits with the rounding
//! error folded into one tap so the 16 weights sum to exactly `1 << 15`.

use std::sync::OnceLock;

use crate::rectify::map::INTER_TAB_SIZE;

/// Fractional bits of the 8-bit interpolation weights (OpenCV's `INTER_REMAP_COEF_BITS`).
pub(super) const COEF_BITS: u32 = 15;
const COEF_SCALE: i32 = 1 << COEF_BITS;
const TAB_SIZE: usize = INTER_TAB_SIZE as usize;
const TAB_SIZE2: usize = TAB_SIZE * TAB_SIZE;

/// Bicubic weights for each of the 32x32 sub-pixel positions, 4x4 taps row-major.
pub(super) struct CubicTables {
    /// Fixed-point weights with [`COEF_BITS`] fractional bits, summing to `1 << 15`.
    pub(super) fixed: Vec<[i16; 16]>,
    /// Single-precision weights (used for 16-bit images).
    pub(super) float: Vec<[f32; 16]>,
}

/// OpenCV's cubic convolution kernel with `a = -0.75`, in single precision.
fn cubic_kernel(x: f32) -> [f32; 4] {
    const A: f32 = -0.75;
    let c0 = ((A * (x + 1.0) - 5.0 * A) * (x + 1.0) + 8.0 * A) * (x + 1.0) - 4.0 * A;
    let c1 = ((A + 2.0) * x - (A + 3.0)) * x * x + 1.0;
    let c2 = ((A + 2.0) * (1.0 - x) - (A + 3.0)) * (1.0 - x) * (1.0 - x) + 1.0;
    let c3 = 1.0 - c0 - c1 - c2;
    [c0, c1, c2, c3]
}

/// The shared bicubic tables, built on first use.
pub(super) fn cubic() -> &'static CubicTables {
    static TABLES: OnceLock<CubicTables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let scale = 1.0f32 / TAB_SIZE as f32;
        let kernels: Vec<[f32; 4]> = (0..TAB_SIZE)
            .map(|i| cubic_kernel(i as f32 * scale))
            .collect();
        let mut fixed = Vec::with_capacity(TAB_SIZE2);
        let mut float = Vec::with_capacity(TAB_SIZE2);
        for ky in &kernels {
            for kx in &kernels {
                let mut f = [0f32; 16];
                let mut q = [0i16; 16];
                for r in 0..4 {
                    for c in 0..4 {
                        let v = ky[r] * kx[c];
                        f[r * 4 + c] = v;
                        q[r * 4 + c] = (v * COEF_SCALE as f32)
                            .round_ties_even()
                            .clamp(i16::MIN.into(), i16::MAX.into())
                            as i16;
                    }
                }
                fold_rounding_error(&mut q);
                fixed.push(q);
                float.push(f);
            }
        }
        CubicTables { fixed, float }
    })
}

/// Makes the weights sum to `COEF_SCALE` by correcting the smallest (sum too large) or
/// largest (sum too small) of taps (2..4, 2..4), the block OpenCV searches.
fn fold_rounding_error(q: &mut [i16; 16]) {
    let sum: i32 = q.iter().map(|&v| i32::from(v)).sum();
    let diff = sum - COEF_SCALE;
    if diff == 0 {
        return;
    }
    let (mut min_at, mut max_at) = (2 * 4 + 2, 2 * 4 + 2);
    for r in 2..4 {
        for c in 2..4 {
            let i = r * 4 + c;
            if q[i] < q[min_at] {
                min_at = i;
            } else if q[i] > q[max_at] {
                max_at = i;
            }
        }
    }
    let at = if diff < 0 { max_at } else { min_at };
    q[at] = (i32::from(q[at]) - diff) as i16;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_cubic_weights_sum_to_one() {
        let tables = cubic();
        assert_eq!(tables.fixed.len(), TAB_SIZE2);
        for w in &tables.fixed {
            assert_eq!(w.iter().map(|&v| i32::from(v)).sum::<i32>(), COEF_SCALE);
        }
    }

    /// At an integer position the kernel is a delta, but 1.0 saturates to 32767 in
    /// 16 bits; OpenCV puts the missing unit on tap (2, 2).
    #[test]
    fn cubic_at_integer_position_matches_opencv_saturation() {
        let w = &cubic().fixed[0];
        let mut expected = [0i16; 16];
        expected[5] = i16::MAX;
        expected[10] = 1;
        assert_eq!(w, &expected);
    }
}
