//! From aggregated costs to disparities: the winner takes all, a uniqueness check, a
//! parabola through the costs around the winner for sub-pixel precision, and the
//! left-right consistency check.

use super::simd::dispatched;

/// Marks a right pixel that no unique left match points to.
pub(crate) const NO_MATCH: i32 = i32::MIN;

/// Chooses the disparity of each pixel of a row from its aggregated costs `sums`
/// (`range` per pixel): writes the sub-pixel disparity into `disparities` (NaN where the
/// best disparity is not unique by `uniqueness_ratio` percent), and for each right
/// pixel the integer disparity of the cheapest unique left match that lands on it into
/// `right_matches` (`NO_MATCH` where none does), with its cost in `right_costs`.
#[inline(always)]
fn choose_row_body(
    sums: &[u16],
    range: usize,
    min_disparity: i32,
    uniqueness_ratio: u32,
    disparities: &mut [f32],
    right_matches: &mut [i32],
    right_costs: &mut [u16],
) {
    right_matches.fill(NO_MATCH);
    right_costs.fill(u16::MAX);
    let width = disparities.len() as i64;
    for (x, (costs, disparity)) in sums
        .chunks_exact(range)
        .zip(disparities.iter_mut())
        .enumerate()
    {
        let min = smallest(costs);
        let best = first_position(costs, min);
        let runner_up = smallest(&costs[..best.saturating_sub(1)])
            .min(smallest(costs.get(best + 2..).unwrap_or(&[])));
        if u32::from(runner_up) * (100 - uniqueness_ratio) < u32::from(min) * 100 {
            *disparity = f32::NAN;
            continue;
        }
        let d = best as i32 + min_disparity;
        let xr = x as i64 - i64::from(d);
        if (0..width).contains(&xr) && right_costs[xr as usize] > min {
            right_costs[xr as usize] = min;
            right_matches[xr as usize] = d;
        }
        *disparity = d as f32 + parabola_offset(costs, best);
    }
}

dispatched! {
    /// Chooses the disparities of one row (see `choose_row_body`).
    fn choose_row(
        sums: &[u16],
        range: usize,
        min_disparity: i32,
        uniqueness_ratio: u32,
        disparities: &mut [f32],
        right_matches: &mut [i32],
        right_costs: &mut [u16],
    ) = choose_row_body;
}

/// The smallest of `costs` (`u16::MAX` for none), in a form that vectorizes.
#[inline(always)]
fn smallest(costs: &[u16]) -> u16 {
    costs.iter().fold(u16::MAX, |a, &b| a.min(b))
}

/// Index of the first of `costs` equal to `value` (which is one of them): found a block
/// of 16 at a time, so that the search vectorizes.
#[inline(always)]
fn first_position(costs: &[u16], value: u16) -> usize {
    let mut blocks = costs.chunks_exact(16);
    let block = blocks
        .position(|b| b.iter().fold(false, |found, &c| found | (c == value)))
        .map_or(costs.len() - blocks.remainder().len(), |k| k * 16);
    costs[block..]
        .iter()
        .position(|&c| c == value)
        .map_or(0, |i| block + i)
}

/// Offset of the vertex of the parabola through the costs at `best - 1`, `best` and
/// `best + 1` from `best`, in `[-0.5, 0.5]`; 0 at either end of the range.
#[inline(always)]
fn parabola_offset(costs: &[u16], best: usize) -> f32 {
    if best == 0 || best + 1 >= costs.len() {
        return 0.0;
    }
    let (before, at, after) = (
        f32::from(costs[best - 1]),
        f32::from(costs[best]),
        f32::from(costs[best + 1]),
    );
    let curvature = (before + after - 2.0 * at).max(1.0);
    ((before - after) / (2.0 * curvature)).clamp(-0.5, 0.5)
}

/// Invalidates the pixels of a row whose match is not confirmed from the right image:
/// the right pixel the disparity points to (rounded either way) has a match that
/// differs by more than `max_diff` pixels, as OpenCV's SGBM checks.
pub(crate) fn check_left_right(disparities: &mut [f32], right_matches: &[i32], max_diff: u32) {
    let width = disparities.len() as i64;
    let agrees = |x: usize, d: i64| {
        let xr = x as i64 - d;
        if !(0..width).contains(&xr) {
            return false;
        }
        let right = right_matches[xr as usize];
        right == NO_MATCH || (i64::from(right) - d).unsigned_abs() <= u64::from(max_diff)
    };
    for (x, disparity) in disparities.iter_mut().enumerate() {
        if disparity.is_nan() {
            continue;
        }
        let (low, high) = (disparity.floor() as i64, disparity.ceil() as i64);
        if !agrees(x, low) && !agrees(x, high) {
            *disparity = f32::NAN;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cheapest_unique_disparity_wins_with_its_sub_pixel_offset() {
        let range = 16;
        let mut sums = vec![100u16; 3 * range];
        // Pixel 0: a clear minimum at 5, with 6 cheaper than 4 (the vertex lies right).
        sums[5] = 10;
        sums[4] = 40;
        sums[6] = 30;
        // Pixel 1: two minima far apart: not unique.
        sums[range + 3] = 10;
        sums[range + 12] = 10;
        // Pixel 2: a clear minimum at 1.
        sums[2 * range + 1] = 20;
        let mut disparities = vec![0.0; 3];
        let mut right_matches = vec![0; 3];
        let mut right_costs = vec![0; 3];
        choose_row(
            &sums,
            range,
            -2,
            10,
            &mut disparities,
            &mut right_matches,
            &mut right_costs,
        );
        // 3 + (40 - 30) / (2 * (40 + 30 - 20)) = 3.1
        assert!((disparities[0] - 3.1).abs() < 1e-6, "{}", disparities[0]);
        assert!(disparities[1].is_nan());
        // 1 - 2 = -1, the parabola through 100, 20, 100 has its vertex at the minimum.
        assert_eq!(disparities[2], -1.0);
        // Pixel 2 with disparity -1 lands on right pixel 3: outside. Pixel 0 with
        // disparity 3 lands on -3: outside too.
        assert_eq!(right_matches, vec![NO_MATCH; 3]);
    }

    #[test]
    fn a_match_the_right_image_contradicts_is_invalidated() {
        let mut disparities = vec![f32::NAN, 1.0, 1.4, 2.0];
        // Right pixel 0 is matched with disparity 1, right pixel 2 with 0.
        let right_matches = [1, NO_MATCH, 0, NO_MATCH];
        check_left_right(&mut disparities, &right_matches, 0);
        // Pixel 1 -> right 0 (1 agrees); pixel 2 -> right 1 or 0: no match at 1, so it
        // stands; pixel 3 -> right 1: no match, stands.
        assert_eq!(disparities[1], 1.0);
        assert_eq!(disparities[2], 1.4);
        let mut disparities = vec![0.0, 0.0, 2.0, 2.0];
        // Pixel 2 -> right 0, matched with 1: off by 1, too far at max_diff 0.
        check_left_right(&mut disparities, &right_matches, 0);
        assert!(disparities[2].is_nan());
        let mut disparities = vec![0.0, 0.0, 2.0, 2.0];
        check_left_right(&mut disparities, &right_matches, 1);
        assert_eq!(disparities[2], 2.0);
    }
}
