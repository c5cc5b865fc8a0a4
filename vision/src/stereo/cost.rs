//! Matching costs of a rectified pair: the Hamming distance between the census
//! descriptor of a left pixel and that of the right pixel each disparity points to.

use super::census::BITS;
use super::simd::dispatched;

/// The cost of a disparity that points outside the right image.
pub(crate) const OUTSIDE: u8 = BITS as u8;

/// Costs of one row: `costs[x * range + i]` for the disparity `min_disparity + i` of
/// the left pixel `x`, from the census descriptors of the row in both images.
#[inline(always)]
fn cost_row_body(left: &[u64], right: &[u64], min_disparity: i32, range: usize, costs: &mut [u8]) {
    let width = left.len() as i64;
    for (x, (pixel_costs, &descriptor)) in costs.chunks_exact_mut(range).zip(left).enumerate() {
        // Disparities with `0 <= x - d < width`: `d` in `(x - width, x]`.
        let x = x as i64;
        let first = (x - width + 1 - i64::from(min_disparity)).clamp(0, range as i64) as usize;
        let last = (x + 1 - i64::from(min_disparity)).clamp(0, range as i64) as usize;
        pixel_costs[..first].fill(OUTSIDE);
        if first < last {
            // The right pixels of disparities `first..last`, in decreasing x.
            let right_end = (x - i64::from(min_disparity) - first as i64) as usize + 1;
            let right_start = right_end - (last - first);
            let candidates = &right[right_start..right_end];
            for (cost, candidate) in pixel_costs[first..last]
                .iter_mut()
                .zip(candidates.iter().rev())
            {
                *cost = (descriptor ^ candidate).count_ones() as u8;
            }
        }
        pixel_costs[last..].fill(OUTSIDE);
    }
}

dispatched! {
    /// Fills one row of matching costs (see `cost_row_body`).
    fn cost_row(left: &[u64], right: &[u64], min_disparity: i32, range: usize, costs: &mut [u8]) = cost_row_body; avx512
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn costs_are_hamming_distances_and_outside_disparities_cost_the_most() {
        let left = [0b1011u64, 0b0000, 0b1111, 0b0001];
        let right = [0b0011u64, 0b1111, 0b0111, 0b0000];
        let mut costs = [0u8; 4 * 3];
        cost_row(&left, &right, -1, 3, &mut costs);
        // x = 0: d = -1 -> right 1, d = 0 -> right 0, d = 1 -> outside.
        assert_eq!(&costs[0..3], &[1, 1, OUTSIDE]);
        // x = 3: d = -1 -> outside, d = 0 -> right 3, d = 1 -> right 2.
        assert_eq!(&costs[9..12], &[OUTSIDE, 1, 2]);
        // x = 2: d = -1 -> right 3, d = 0 -> right 2, d = 1 -> right 1.
        assert_eq!(&costs[6..9], &[4, 1, 0]);
    }

    #[test]
    fn the_dispatched_copy_matches_the_portable_body() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut descriptor = || rng.random_range(0..1u64 << super::BITS);
        let width = 203;
        let left: Vec<u64> = (0..width).map(|_| descriptor()).collect();
        let right: Vec<u64> = (0..width).map(|_| descriptor()).collect();
        for (min_disparity, range) in [(0, 64), (-5, 48), (17, 16)] {
            let mut fast = vec![0u8; width * range];
            let mut portable = vec![0u8; width * range];
            cost_row(&left, &right, min_disparity, range, &mut fast);
            cost_row_body(&left, &right, min_disparity, range, &mut portable);
            assert_eq!(fast, portable, "min {min_disparity}, range {range}");
        }
    }
}
