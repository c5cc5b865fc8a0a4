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
fn choose_row_body<P: Pick>(
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
        let (min, best, runner_up) = P::pick(costs);
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
    ) = choose_row_body::<Avx2>, choose_row_body::<Portable>;
}

/// The winner and the runner-up among a pixel's aggregated costs.
trait Pick {
    /// `(min, best, runner_up)`: the smallest of `costs` (which is not empty), the first
    /// index holding it, and the smallest of the others but those at `best - 1` and
    /// `best + 1` (`u16::MAX` for none).
    fn pick(costs: &[u16]) -> (u16, usize, u16);
}

/// [`Pick`] in plain loops, for any processor.
struct Portable;

impl Pick for Portable {
    #[inline(always)]
    fn pick(costs: &[u16]) -> (u16, usize, u16) {
        let min = smallest(costs);
        let best = first_position(costs, min);
        let runner_up = smallest(&costs[..best.saturating_sub(1)])
            .min(smallest(costs.get(best + 2..).unwrap_or(&[])));
        (min, best, runner_up)
    }
}

/// [`Pick`] in AVX2 registers, 16 costs at a time, for a multiple of 16 costs. Only ever
/// named inside the AVX2 copy of the kernel (see `simd::dispatched`).
#[cfg(target_arch = "x86_64")]
struct Avx2;

#[cfg(target_arch = "x86_64")]
impl Pick for Avx2 {
    #[inline(always)]
    fn pick(costs: &[u16]) -> (u16, usize, u16) {
        if costs.is_empty() || !costs.len().is_multiple_of(16) {
            return Portable::pick(costs);
        }
        // SAFETY: `Avx2` is used only by the AVX2 copy of the kernel, which runs only on
        // processors that have AVX2.
        unsafe { avx2_pick(costs) }
    }
}

/// The AVX2 pick of a non-empty multiple of 16 costs. Not a `target_feature` function,
/// so that it inlines into the AVX2 kernel (whose feature set its intrinsics need).
///
/// # Safety
/// The processor has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn avx2_pick(costs: &[u16]) -> (u16, usize, u16) {
    use std::arch::x86_64::*;
    const LANES: usize = 16;
    let blocks = costs.len() / LANES;
    // SAFETY (every intrinsic below): the caller guarantees AVX2 (which includes SSE4.1).
    unsafe {
        let load = |k: usize| {
            let chunk = &costs[k * LANES..(k + 1) * LANES];
            // SAFETY: `chunk` holds 16 values, 32 bytes.
            _mm256_loadu_si256(chunk.as_ptr().cast())
        };
        let horizontal_min = |v: __m256i| {
            let half = _mm_min_epu16(_mm256_castsi256_si128(v), _mm256_extracti128_si256::<1>(v));
            _mm_extract_epi16::<0>(_mm_minpos_epu16(half)) as u16
        };
        let mut lowest = load(0);
        for k in 1..blocks {
            lowest = _mm256_min_epu16(lowest, load(k));
        }
        let min = horizontal_min(lowest);
        let target = _mm256_set1_epi16(min as i16);
        let mut best = 0;
        for k in 0..blocks {
            let found = _mm256_movemask_epi8(_mm256_cmpeq_epi16(load(k), target)) as u32;
            if found != 0 {
                best = k * LANES + (found.trailing_zeros() / 2) as usize;
                break;
            }
        }
        // A lane is next to the best when `index - (best - 1)`, read unsigned, is at
        // most 2; those lanes are set to u16::MAX before taking the minimum.
        let lanes = _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        let before_best = _mm256_set1_epi16(best as i16 - 1);
        let two = _mm256_set1_epi16(2);
        let mut others = _mm256_set1_epi16(-1);
        for k in 0..blocks {
            let index = _mm256_add_epi16(lanes, _mm256_set1_epi16((k * LANES) as i16));
            let offset = _mm256_sub_epi16(index, before_best);
            let near = _mm256_cmpeq_epi16(_mm256_min_epu16(offset, two), offset);
            others = _mm256_min_epu16(others, _mm256_or_si256(load(k), near));
        }
        (min, best, horizontal_min(others))
    }
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

    /// The signature of `choose_row`.
    type ChooseRow = fn(&[u16], usize, i32, u32, &mut [f32], &mut [i32], &mut [u16]);

    #[test]
    fn the_dispatched_pick_matches_the_portable_one() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (width, range) = (61, 48);
        for round in 0..50 {
            // Few distinct values, so that ties and minima next to each other are common.
            let levels = if round % 2 == 0 { 5 } else { 4000 };
            let sums: Vec<u16> = (0..width * range)
                .map(|_| rng.random_range(0..levels) * 3)
                .collect();
            let run = |choose: ChooseRow| {
                let mut disparities = vec![0.0; width];
                let mut right_matches = vec![0; width];
                let mut right_costs = vec![0; width];
                choose(
                    &sums,
                    range,
                    -3,
                    5,
                    &mut disparities,
                    &mut right_matches,
                    &mut right_costs,
                );
                let bits: Vec<u32> = disparities.iter().map(|d| d.to_bits()).collect();
                (bits, right_matches, right_costs)
            };
            assert_eq!(
                run(choose_row),
                run(choose_row_body::<Portable>),
                "round {round}"
            );
        }
        for best in 0..32 {
            let mut costs = vec![50u16; 32];
            costs[best] = 1;
            if best > 0 {
                costs[best - 1] = 2;
            }
            if best + 1 < 32 {
                costs[best + 1] = 2;
            }
            costs[(best + 9) % 32] = 7;
            assert_eq!(
                Portable::pick(&costs),
                (1, best, 7),
                "portable, best {best}"
            );
            #[cfg(target_arch = "x86_64")]
            if crate::stereo::simd::has_avx2() {
                // SAFETY: the processor has AVX2.
                assert_eq!(
                    unsafe { avx2_pick(&costs) },
                    (1, best, 7),
                    "avx2, best {best}"
                );
            }
        }
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
