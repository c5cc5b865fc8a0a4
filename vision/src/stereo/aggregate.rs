//! Semi-global aggregation: the cost of each disparity summed along straight paths
//! through the image, with a penalty `P1` where the disparity changes by one pixel
//! between neighbours of a path and `P2` where it jumps (Hirschmüller 2008).
//!
//! A path's costs at a pixel are kept in a slot of `range + 2 * PAD` values: the costs
//! of the disparities between paddings so far above every cost that they never win a
//! minimum, so that the portable step reads the neighbours `d - 1` and `d + 1` of every
//! disparity without a bounds check. The AVX2 step reads only the costs and shifts
//! neighbours in registers. `PAD` keeps the costs of every slot 32-byte aligned in an
//! aligned buffer: a step reads the costs the step before has just stored, and the
//! processor forwards a store to a load only when neither splits a cache line.

use super::simd::dispatched;

/// The padding on either side of a slot.
const FAR: u16 = u16::MAX / 4;

/// Padding values on either side of a slot's costs: 32 bytes.
const PAD: usize = 16;

/// Values per slot of `range` disparities.
pub(crate) fn slot_len(range: usize) -> usize {
    range + 2 * PAD
}

/// Makes `slots` (whole slots) the start of a path: zero costs between the paddings.
pub(crate) fn reset_slots(slots: &mut [u16], range: usize) {
    for slot in slots.chunks_exact_mut(slot_len(range)) {
        slot.fill(FAR);
        slot[PAD..PAD + range].fill(0);
    }
}

/// One step along a path into the pixel whose disparity costs are `costs`:
/// `L(d) = C(d) + min(L'(d), L'(d - 1) + P1, L'(d + 1) + P1, min L' + P2) - min L'`,
/// where `L'` (`previous`, a slot, with its minimum `previous_min`) is the path's cost
/// at the pixel before. Writes `L` into the slot `current` and into `sums` as `into`
/// says; returns the minimum of `L`.
pub(crate) trait PathStep {
    #[allow(clippy::too_many_arguments)]
    fn step(
        costs: &[u8],
        previous: &[u16],
        previous_min: u16,
        p1: u16,
        p2: u16,
        current: &mut [u16],
        into: Into<'_>,
        sums: &mut [u16],
    ) -> u16;
}

/// How a path step writes its costs into the sums.
#[derive(Clone, Copy)]
pub(crate) enum Into<'a> {
    /// `sums += L`.
    Add,
    /// `sums = base + L`, `base` being other paths' sums of the same pixel.
    Over(&'a [u16]),
}

/// The step as a plain loop, for any processor.
pub(crate) struct Portable;

impl PathStep for Portable {
    #[inline(always)]
    fn step(
        costs: &[u8],
        previous: &[u16],
        previous_min: u16,
        p1: u16,
        p2: u16,
        current: &mut [u16],
        into: Into<'_>,
        sums: &mut [u16],
    ) -> u16 {
        let range = costs.len();
        if let Into::Over(base) = into {
            sums[..range].copy_from_slice(&base[..range]);
        }
        let (below, same, above) = (
            &previous[PAD - 1..PAD - 1 + range],
            &previous[PAD..PAD + range],
            &previous[PAD + 1..PAD + 1 + range],
        );
        let current = &mut current[PAD..PAD + range];
        let sums = &mut sums[..range];
        let jump = previous_min.saturating_add(p2);
        let mut min = u16::MAX;
        for (((((l, s), &c), &b), &m), &a) in current
            .iter_mut()
            .zip(sums.iter_mut())
            .zip(costs)
            .zip(below)
            .zip(same)
            .zip(above)
        {
            let best = m.min(b.min(a).saturating_add(p1)).min(jump);
            // `best` is never below `previous_min`, so the difference cannot wrap.
            let value = u16::from(c) + best.wrapping_sub(previous_min);
            *l = value;
            *s = s.wrapping_add(value);
            min = min.min(value);
        }
        min
    }
}

/// The step in AVX2 registers, 16 disparities at a time; `range` is a multiple of 16.
/// Only ever named inside the AVX2 copies of the kernels (see `simd::dispatched`).
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx2;

#[cfg(target_arch = "x86_64")]
impl PathStep for Avx2 {
    #[inline(always)]
    fn step(
        costs: &[u8],
        previous: &[u16],
        previous_min: u16,
        p1: u16,
        p2: u16,
        current: &mut [u16],
        into: Into<'_>,
        sums: &mut [u16],
    ) -> u16 {
        // SAFETY: `Avx2` is used only by the AVX2 copies of the kernels, which run only
        // on processors that have AVX2.
        unsafe { avx2_step(costs, previous, previous_min, p1, p2, current, into, sums) }
    }
}

/// The AVX2 step. Not a `target_feature` function, so that it inlines into the AVX2
/// kernels (whose feature set its intrinsics need).
///
/// # Safety
/// The processor has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn avx2_step(
    costs: &[u8],
    previous: &[u16],
    previous_min: u16,
    p1: u16,
    p2: u16,
    current: &mut [u16],
    into: Into<'_>,
    sums: &mut [u16],
) -> u16 {
    use std::arch::x86_64::*;
    let range = costs.len() - costs.len() % 16;
    let previous = &previous[PAD..PAD + range];
    let current = &mut current[PAD..PAD + range];
    let sums = &mut sums[..range];
    let base = match into {
        Into::Add => None,
        Into::Over(base) => Some(&base[..range]),
    };
    // SAFETY (every intrinsic below): the caller guarantees AVX2.
    unsafe {
        let p1 = _mm256_set1_epi16(p1 as i16);
        let jump = _mm256_set1_epi16(previous_min.saturating_add(p2) as i16);
        let start = _mm256_set1_epi16(previous_min as i16);
        let far = _mm256_set1_epi16(FAR as i16);
        let load = |values: &[u16], at: usize| {
            let chunk = &values[at..at + 16];
            // SAFETY: `chunk` holds 16 values, 32 bytes.
            _mm256_loadu_si256(chunk.as_ptr().cast())
        };
        let mut before = far;
        let mut here = if range > 0 { load(previous, 0) } else { far };
        let mut min = _mm256_set1_epi16(-1);
        for at in (0..range).step_by(16) {
            let after = if at + 16 < range {
                load(previous, at + 16)
            } else {
                far
            };
            // Neighbours d - 1 and d + 1: this block shifted by one lane, the lane that
            // comes in taken from the block before or after.
            let below =
                _mm256_alignr_epi8::<14>(here, _mm256_permute2x128_si256::<0x21>(before, here));
            let above =
                _mm256_alignr_epi8::<2>(_mm256_permute2x128_si256::<0x21>(here, after), here);
            let near = _mm256_adds_epu16(_mm256_min_epu16(below, above), p1);
            let best = _mm256_min_epu16(_mm256_min_epu16(here, near), jump);
            let block = &costs[at..at + 16];
            // `block` holds 16 bytes.
            let cost = _mm256_cvtepu8_epi16(_mm_loadu_si128(block.as_ptr().cast()));
            let value = _mm256_add_epi16(cost, _mm256_sub_epi16(best, start));
            let out = &mut current[at..at + 16];
            // `out` and every chunk below hold 16 values.
            _mm256_storeu_si256(out.as_mut_ptr().cast(), value);
            let other = match base {
                Some(base) => load(base, at),
                None => load(sums, at),
            };
            let sum = &mut sums[at..at + 16];
            _mm256_storeu_si256(sum.as_mut_ptr().cast(), _mm256_add_epi16(other, value));
            min = _mm256_min_epu16(min, value);
            before = here;
            here = after;
        }
        let halves = _mm_min_epu16(
            _mm256_castsi256_si128(min),
            _mm256_extracti128_si256::<1>(min),
        );
        _mm_extract_epi16::<0>(_mm_minpos_epu16(halves)) as u16
    }
}

/// Aggregates one row (`costs` of `range` per pixel) along the left-to-right path,
/// the right-to-left path, or both, writing their sum plus `base` (other paths' sums
/// of the row) into `sums`. `scratch` holds two slots.
#[inline(always)]
fn horizontal_row_body<S: PathStep>(
    costs: &[u8],
    range: usize,
    penalties: Penalties,
    directions: Horizontal,
    base: &[u16],
    sums: &mut [u16],
    scratch: &mut [u16],
) {
    let slot = slot_len(range);
    let (p1, p2) = (penalties.p1, penalties.p2);
    let (previous, current) = scratch[..2 * slot].split_at_mut(slot);
    let (mut previous, mut current) = (previous, current);
    fn pixels<'a>(
        costs: &'a [u8],
        base: &'a [u16],
        sums: &'a mut [u16],
        range: usize,
    ) -> impl DoubleEndedIterator<Item = ((&'a [u8], &'a [u16]), &'a mut [u16])> {
        costs
            .chunks_exact(range)
            .zip(base.chunks_exact(range))
            .zip(sums.chunks_exact_mut(range))
    }
    warm_up(costs, base);
    // The first path writes over `base`; a second adds.
    reset_slots(previous, range);
    let mut min = 0;
    if directions == Horizontal::RightToLeft {
        for ((c, b), s) in pixels(costs, base, sums, range).rev() {
            min = S::step(c, previous, min, p1, p2, current, Into::Over(b), s);
            std::mem::swap(&mut previous, &mut current);
        }
        return;
    }
    for ((c, b), s) in pixels(costs, base, sums, range) {
        min = S::step(c, previous, min, p1, p2, current, Into::Over(b), s);
        std::mem::swap(&mut previous, &mut current);
    }
    if directions == Horizontal::Both {
        reset_slots(previous, range);
        let mut min = 0;
        for ((c, _), s) in pixels(costs, base, sums, range).rev() {
            min = S::step(c, previous, min, p1, p2, current, Into::Add, s);
            std::mem::swap(&mut previous, &mut current);
        }
    }
}

/// Reads one value per cache line of `costs` and `base` so that they are in the cache
/// before a horizontal path runs over them: the path's steps depend on each other, so
/// the processor cannot overlap their cache misses as it does those of independent
/// reads.
#[inline(always)]
fn warm_up(costs: &[u8], base: &[u16]) {
    let bytes = costs.iter().step_by(64).fold(0u8, |a, &b| a ^ b);
    let values = base.iter().step_by(32).fold(0u16, |a, &b| a ^ b);
    std::hint::black_box((bytes, values));
}

/// Which horizontal paths [`horizontal_row`] aggregates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Horizontal {
    LeftToRight,
    RightToLeft,
    Both,
}

dispatched! {
    /// Aggregates one row along its horizontal paths (see `horizontal_row_body`).
    fn horizontal_row(costs: &[u8], range: usize, penalties: Penalties, directions: Horizontal, base: &[u16], sums: &mut [u16], scratch: &mut [u16])
        = horizontal_row_body::<Avx2>, horizontal_row_body::<Portable>;
}

/// Paths kept per pixel by a vertical sweep: straight, then the diagonal from the
/// pixel before (`x - 1` in the row before), then the diagonal from the pixel after.
pub(crate) const SWEEP_PATHS: usize = 3;

/// The penalties of a change of disparity along a path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Penalties {
    /// Change by one pixel.
    pub(crate) p1: u16,
    /// Larger change.
    pub(crate) p2: u16,
}

/// The paths of the row before in a vertical sweep: their slots (`SWEEP_PATHS` per
/// pixel) and minima, and the slot of a path that begins at this row.
#[derive(Clone, Copy)]
pub(crate) struct RowBefore<'a> {
    pub(crate) slots: &'a [u16],
    pub(crate) mins: &'a [u16],
    pub(crate) start: &'a [u16],
}

/// The pixels `x0..x0 + n` of the row a vertical sweep is at: their costs, the other
/// paths' sums `base` to add, and where their sums, path slots and minima go.
pub(crate) struct SweepPiece<'a> {
    pub(crate) x0: usize,
    pub(crate) costs: &'a [u8],
    pub(crate) base: &'a [u16],
    pub(crate) sums: &'a mut [u16],
    pub(crate) slots: &'a mut [u16],
    pub(crate) mins: &'a mut [u16],
}

/// Aggregates a piece of one row along the paths that come from the row before (the
/// row above in a downward sweep, below in an upward one): the straight path, and
/// with `diagonals` the two diagonals.
#[inline(always)]
fn sweep_piece_body<S: PathStep>(
    piece: SweepPiece<'_>,
    before: RowBefore<'_>,
    range: usize,
    penalties: Penalties,
    diagonals: bool,
) {
    let slot = slot_len(range);
    let width = before.mins.len() / SWEEP_PATHS;
    let (p1, p2) = (penalties.p1, penalties.p2);
    let from = |x: Option<usize>, path: usize| -> (&[u16], u16) {
        match x {
            Some(x) if x < width => {
                let at = x * SWEEP_PATHS + path;
                (&before.slots[at * slot..(at + 1) * slot], before.mins[at])
            }
            _ => (before.start, 0),
        }
    };
    for (i, ((((c, b), s), slots), mins)) in piece
        .costs
        .chunks_exact(range)
        .zip(piece.base.chunks_exact(range))
        .zip(piece.sums.chunks_exact_mut(range))
        .zip(piece.slots.chunks_exact_mut(SWEEP_PATHS * slot))
        .zip(piece.mins.chunks_exact_mut(SWEEP_PATHS))
        .enumerate()
    {
        let x = piece.x0 + i;
        let (straight, diagonal) = slots.split_at_mut(slot);
        let (previous, min) = from(Some(x), 0);
        mins[0] = S::step(c, previous, min, p1, p2, straight, Into::Over(b), s);
        if diagonals {
            let (falling, rising) = diagonal.split_at_mut(slot);
            let (previous, min) = from(x.checked_sub(1), 1);
            mins[1] = S::step(c, previous, min, p1, p2, falling, Into::Add, s);
            let (previous, min) = from(Some(x + 1), 2);
            mins[2] = S::step(c, previous, min, p1, p2, rising, Into::Add, s);
        }
    }
}

dispatched! {
    /// Aggregates a piece of a row in a vertical sweep (see `sweep_piece_body`).
    fn sweep_piece(piece: SweepPiece<'_>, before: RowBefore<'_>, range: usize, penalties: Penalties, diagonals: bool)
        = sweep_piece_body::<Avx2>, sweep_piece_body::<Portable>;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The recurrence written out with plain integers.
    fn reference_step(costs: &[u8], previous: &[u32], p1: u32, p2: u32) -> Vec<u32> {
        let min = previous.iter().copied().min().unwrap_or(0);
        (0..costs.len())
            .map(|d| {
                let mut best = previous[d].min(min + p2);
                if d > 0 {
                    best = best.min(previous[d - 1] + p1);
                }
                if d + 1 < costs.len() {
                    best = best.min(previous[d + 1] + p1);
                }
                u32::from(costs[d]) + best - min
            })
            .collect()
    }

    fn pseudo_costs(n: usize) -> Vec<u8> {
        (0..n).map(|i| ((i * 37 + i / 5 * 11) % 62) as u8).collect()
    }

    #[test]
    fn horizontal_paths_follow_the_recurrence() {
        let (width, range) = (7, 32);
        let costs = pseudo_costs(width * range);
        let mut sums = vec![0u16; width * range];
        let mut scratch = vec![0u16; 2 * slot_len(range)];
        let base = vec![0u16; width * range];
        horizontal_row(
            &costs,
            range,
            Penalties { p1: 7, p2: 50 },
            Horizontal::Both,
            &base,
            &mut sums,
            &mut scratch,
        );

        let pixel = |x: usize| &costs[x * range..(x + 1) * range];
        let mut forward = vec![vec![0u32; range]; width];
        let mut backward = vec![vec![0u32; range]; width];
        forward[0] = pixel(0).iter().map(|&c| u32::from(c)).collect();
        for x in 1..width {
            forward[x] = reference_step(pixel(x), &forward[x - 1], 7, 50);
        }
        backward[width - 1] = pixel(width - 1).iter().map(|&c| u32::from(c)).collect();
        for x in (0..width - 1).rev() {
            backward[x] = reference_step(pixel(x), &backward[x + 1], 7, 50);
        }
        for x in 0..width {
            for d in 0..range {
                assert_eq!(
                    u32::from(sums[x * range + d]),
                    forward[x][d] + backward[x][d],
                    "x {x} d {d}"
                );
            }
        }
        // The portable step and the AVX2 one agree.
        let mut portable = vec![0u16; width * range];
        horizontal_row_body::<Portable>(
            &costs,
            range,
            Penalties { p1: 7, p2: 50 },
            Horizontal::Both,
            &base,
            &mut portable,
            &mut scratch,
        );
        assert_eq!(portable, sums);
    }

    #[test]
    fn a_vertical_sweep_follows_the_recurrence_on_all_three_paths() {
        let (width, height, range) = (40, 5, 16);
        let costs = pseudo_costs(width * height * range);
        let slot = slot_len(range);
        let mut previous = vec![0u16; width * SWEEP_PATHS * slot];
        let mut current = previous.clone();
        reset_slots(&mut previous, range);
        let mut start = vec![0u16; slot];
        reset_slots(&mut start, range);
        let mut previous_min = vec![0u16; width * SWEEP_PATHS];
        let mut current_min = previous_min.clone();
        let mut sums = vec![0u16; costs.len()];
        let base = vec![1u16; width * range];
        let row_len = width * range;
        for (y, row) in sums.chunks_exact_mut(row_len).enumerate() {
            // Two pieces, as threads would take them.
            let (c, s) = (&costs[y * row_len..(y + 1) * row_len], row);
            let (s0, s1) = s.split_at_mut(25 * range);
            let (k0, k1) = current.split_at_mut(25 * SWEEP_PATHS * slot);
            let (m0, m1) = current_min.split_at_mut(25 * SWEEP_PATHS);
            let before = RowBefore {
                slots: &previous,
                mins: &previous_min,
                start: &start,
            };
            let penalties = Penalties { p1: 5, p2: 40 };
            let first = SweepPiece {
                x0: 0,
                costs: &c[..25 * range],
                base: &base[..25 * range],
                sums: s0,
                slots: k0,
                mins: m0,
            };
            sweep_piece(first, before, range, penalties, true);
            let second = SweepPiece {
                x0: 25,
                costs: &c[25 * range..],
                base: &base[25 * range..],
                sums: s1,
                slots: k1,
                mins: m1,
            };
            sweep_piece(second, before, range, penalties, true);
            std::mem::swap(&mut previous, &mut current);
            std::mem::swap(&mut previous_min, &mut current_min);
        }

        let at = |x: usize, y: usize| &costs[(y * width + x) * range..(y * width + x + 1) * range];
        let start = |x: usize, y: usize| at(x, y).iter().map(|&c| u32::from(c)).collect();
        let mut expected = vec![vec![1u32; range]; width * height];
        for dx in [0i64, -1, 1] {
            let mut path: Vec<Vec<u32>> = (0..width).map(|x| start(x, 0)).collect();
            for x in 0..width {
                for d in 0..range {
                    expected[x][d] += path[x][d];
                }
            }
            for y in 1..height {
                let next: Vec<Vec<u32>> = (0..width)
                    .map(|x| {
                        let from = x as i64 + dx;
                        if from < 0 || from >= width as i64 {
                            start(x, y)
                        } else {
                            reference_step(at(x, y), &path[from as usize], 5, 40)
                        }
                    })
                    .collect();
                for x in 0..width {
                    for d in 0..range {
                        expected[y * width + x][d] += next[x][d];
                    }
                }
                path = next;
            }
        }
        for (i, e) in expected.iter().enumerate() {
            for d in 0..range {
                assert_eq!(u32::from(sums[i * range + d]), e[d], "pixel {i} d {d}");
            }
        }
    }
}
