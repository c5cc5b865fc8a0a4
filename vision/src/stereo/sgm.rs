//! Semi-global matching of a rectified pair, with every buffer kept between frames.

use rayon::prelude::*;

use super::aggregate::{
    Horizontal, Penalties, RowBefore, SWEEP_PATHS, SweepPiece, horizontal_row, reset_slots,
    slot_len, sweep_piece,
};
use super::aligned::AlignedBuffer;
use super::census::census_transform;
use super::cost::cost_row;
use super::params::{Paths, SgmParams};
use super::refine::Refiner;
use super::select::{check_left_right, choose_row};
use super::speckle::SpeckleFilter;
use super::{DisparityMap, StereoError};
use crate::image::{Image, Samples};

/// A semi-global matcher (Hirschmüller 2008) on census costs. Census was chosen over
/// Birchfield-Tomasi because it does not care how differently the two cameras expose
/// (gain, offset, any monotonic response): it is the cost that ranks best on real pairs
/// in Hirschmüller and Scharstein's evaluation of matching costs.
///
/// The image is swept down (and, with four or eight paths, back up) one row at a time.
/// While one thread aggregates a row along its horizontal path, the others aggregate
/// the row before along the vertical paths and choose the disparities of the row before
/// that, so the aggregated costs of the whole image are stored at most once (two
/// sweeps) or not at all (five paths). The result does not depend on the number of
/// threads.
///
/// The matcher keeps its buffers between calls: matching a stream of pairs of one size
/// allocates only for the first.
pub struct SemiGlobalMatcher {
    params: SgmParams,
    census_left: Vec<u64>,
    census_right: Vec<u64>,
    costs: Vec<u8>,
    /// Sums of the downward sweep's paths, per pixel (two-sweep modes only).
    sums: AlignedBuffer,
    /// Horizontal paths of the row being swept and of the row before.
    horizontal: [AlignedBuffer; 2],
    /// Complete sums of the two rows waiting for their disparities to be chosen.
    finished: [AlignedBuffer; 2],
    sweep: SweepState,
    horizontal_scratch: AlignedBuffer,
    /// A row of zero sums, the base of the first paths.
    zeros: AlignedBuffer,
    right_matches: Vec<i32>,
    right_costs: Vec<u16>,
    speckles: SpeckleFilter,
    refiner: Refiner,
}

/// Gauss-Newton steps of the sub-pixel refinement: the first lands within a few
/// hundredths of a pixel, the second settles it.
const REFINE_ITERATIONS: usize = 2;

/// Path slots and minima of the row before and the row being swept, along the paths
/// that cross rows.
#[derive(Default)]
struct SweepState {
    previous: AlignedBuffer,
    previous_min: Vec<u16>,
    current: AlignedBuffer,
    current_min: Vec<u16>,
    start: AlignedBuffer,
}

impl SweepState {
    fn reset(&mut self, width: usize, range: usize) {
        let slots = width * SWEEP_PATHS * slot_len(range);
        for buffer in [&mut self.previous, &mut self.current] {
            buffer.resize(slots);
            reset_slots(buffer.as_mut_slice(), range);
        }
        for mins in [&mut self.previous_min, &mut self.current_min] {
            mins.clear();
            mins.resize(width * SWEEP_PATHS, 0);
        }
        self.start.resize(slot_len(range));
        reset_slots(self.start.as_mut_slice(), range);
    }

    /// Aggregates one row along the vertical paths into `sums`, adding `base`.
    fn row(
        &mut self,
        costs: &[u8],
        base: &[u16],
        sums: &mut [u16],
        range: usize,
        penalties: Penalties,
        diagonals: bool,
    ) {
        let width = costs.len() / range;
        let slot = slot_len(range);
        // Enough pieces per row to keep every thread busy while one runs a horizontal
        // path, few enough that a piece is much more work than handing it over.
        let piece = width.div_ceil(2 * rayon::current_num_threads()).max(16);
        let before = RowBefore {
            slots: self.previous.as_slice(),
            mins: &self.previous_min,
            start: self.start.as_slice(),
        };
        costs
            .par_chunks(piece * range)
            .zip(base.par_chunks(piece * range))
            .zip(sums.par_chunks_mut(piece * range))
            .zip(
                self.current
                    .as_mut_slice()
                    .par_chunks_mut(piece * SWEEP_PATHS * slot),
            )
            .zip(self.current_min.par_chunks_mut(piece * SWEEP_PATHS))
            .enumerate()
            .for_each(|(k, ((((costs, base), sums), slots), mins))| {
                let x0 = k * piece;
                let piece = SweepPiece {
                    x0,
                    costs,
                    base,
                    sums,
                    slots,
                    mins,
                };
                sweep_piece(piece, before, range, penalties, diagonals);
            });
        std::mem::swap(&mut self.previous, &mut self.current);
        std::mem::swap(&mut self.previous_min, &mut self.current_min);
    }
}

/// What a sweep does at each row.
struct SweepPlan {
    horizontal: Horizontal,
    diagonals: bool,
    /// Whether the sums are complete at the end of this sweep.
    last: bool,
}

impl SemiGlobalMatcher {
    /// A matcher with `params`, checked when a pair arrives (they depend on its width).
    pub fn new(params: SgmParams) -> Self {
        Self {
            params,
            census_left: Vec::new(),
            census_right: Vec::new(),
            costs: Vec::new(),
            sums: AlignedBuffer::default(),
            horizontal: Default::default(),
            finished: Default::default(),
            sweep: SweepState::default(),
            horizontal_scratch: AlignedBuffer::default(),
            zeros: AlignedBuffer::default(),
            right_matches: Vec::new(),
            right_costs: Vec::new(),
            speckles: SpeckleFilter::default(),
            refiner: Refiner::default(),
        }
    }

    /// The parameters in use.
    pub fn params(&self) -> &SgmParams {
        &self.params
    }

    /// Disparities of the left image of a rectified pair (mono8 or mono16, both of the
    /// same size and encoding): for each left pixel `x`, its match in the right image
    /// is at `x - disparity` on the same row.
    pub fn compute(&mut self, left: &Image, right: &Image) -> Result<DisparityMap, StereoError> {
        let mut out = DisparityMap::empty();
        self.compute_into(left, right, &mut out)?;
        Ok(out)
    }

    /// [`Self::compute`] into `out`, reusing its storage.
    pub fn compute_into(
        &mut self,
        left: &Image,
        right: &Image,
        out: &mut DisparityMap,
    ) -> Result<(), StereoError> {
        // On a thread of the pool, so that the joins of every row hand work to the
        // other threads without waking the calling one.
        rayon::scope(|_| self.match_pair(left, right, out))
    }

    fn match_pair(
        &mut self,
        left: &Image,
        right: &Image,
        out: &mut DisparityMap,
    ) -> Result<(), StereoError> {
        super::check_pair(left, right)?;
        let (width, height) = (left.width, left.height);
        self.params.validate(width)?;
        let range = self.params.disparity_range;
        let pixels = width * height;

        self.census_left.resize(pixels, 0);
        self.census_right.resize(pixels, 0);
        match (&left.samples, &right.samples) {
            (Samples::U8(l), Samples::U8(r)) => {
                census_transform(l, width, height, &mut self.census_left);
                census_transform(r, width, height, &mut self.census_right);
            }
            (Samples::U16(l), Samples::U16(r)) => {
                census_transform(l, width, height, &mut self.census_left);
                census_transform(r, width, height, &mut self.census_right);
            }
            _ => return Err(StereoError::EncodingMismatch),
        }

        let min_disparity = self.params.min_disparity;
        self.costs.resize(pixels * range, 0);
        self.costs
            .par_chunks_mut(width * range)
            .zip(self.census_left.par_chunks(width))
            .zip(self.census_right.par_chunks(width))
            .for_each(|((costs, l), r)| cost_row(l, r, min_disparity, range, costs));

        let row_len = width * range;
        for buffer in self.horizontal.iter_mut().chain(self.finished.iter_mut()) {
            buffer.resize(row_len);
        }
        self.horizontal_scratch.resize(2 * slot_len(range));
        self.zeros.resize(row_len);
        self.zeros.as_mut_slice().fill(0);
        self.right_matches.resize(width, 0);
        self.right_costs.resize(width, 0);
        out.reset(width, height, min_disparity, range);

        let plans: &[SweepPlan] = match self.params.paths {
            Paths::Five => &[SweepPlan {
                horizontal: Horizontal::Both,
                diagonals: true,
                last: true,
            }],
            Paths::Four | Paths::Eight => {
                let diagonals = self.params.paths == Paths::Eight;
                &[
                    SweepPlan {
                        horizontal: Horizontal::LeftToRight,
                        diagonals,
                        last: false,
                    },
                    SweepPlan {
                        horizontal: Horizontal::RightToLeft,
                        diagonals,
                        last: true,
                    },
                ]
            }
        };
        if plans.len() > 1 {
            self.sums.resize(pixels * range);
        }
        for (k, plan) in plans.iter().enumerate() {
            self.sweep_rows(plan, k == 1, width, height, &mut out.data);
        }
        self.refiner.refine(
            &mut out.data,
            left,
            right,
            self.params.refine_radius,
            REFINE_ITERATIONS,
        );
        self.speckles.apply(
            &mut out.data,
            width,
            self.params.speckle_size,
            self.params.speckle_range,
        );
        Ok(())
    }

    /// One sweep over the rows (down, or up when `upward`), as a pipeline: at step `i`
    /// the horizontal paths of row `i`, the vertical paths of row `i - 1` and, in the
    /// last sweep, the disparities of row `i - 2`, each on its own thread.
    fn sweep_rows(
        &mut self,
        plan: &SweepPlan,
        upward: bool,
        width: usize,
        height: usize,
        disparities: &mut [f32],
    ) {
        let params = &self.params;
        let range = params.disparity_range;
        let penalties = Penalties {
            p1: params.p1,
            p2: params.p2,
        };
        let row_len = width * range;
        let row_of = |step: usize| if upward { height - 1 - step } else { step };
        self.sweep.reset(width, range);
        for step in 0..height + 2 {
            let horizontal_y = (step < height).then(|| row_of(step));
            let vertical_y = (1..=height).contains(&step).then(|| row_of(step - 1));
            let choose_y = (plan.last && step >= 2).then(|| row_of(step - 2));

            let [h0, h1] = &mut self.horizontal;
            let (horizontal, horizontal_before) = if step % 2 == 0 {
                (h0, &*h1)
            } else {
                (h1, &*h0)
            };
            let (horizontal, horizontal_before) =
                (horizontal.as_mut_slice(), horizontal_before.as_slice());
            let [f0, f1] = &mut self.finished;
            let (finishing, finished) = if step % 2 == 0 {
                (f1, &*f0)
            } else {
                (f0, &*f1)
            };
            let (finishing, finished) = (finishing.as_mut_slice(), finished.as_slice());
            // The upward sweep's horizontal paths start from the downward sums; a
            // downward sweep that is not the last writes them.
            let (horizontal_base, vertical_out): (Option<&[u16]>, &mut [u16]) = if upward {
                let base =
                    horizontal_y.map(|y| &self.sums.as_slice()[y * row_len..(y + 1) * row_len]);
                (base, finishing)
            } else if plan.last {
                (None, finishing)
            } else {
                let y = vertical_y.unwrap_or(0);
                (
                    None,
                    &mut self.sums.as_mut_slice()[y * row_len..(y + 1) * row_len],
                )
            };
            let zeros = self.zeros.as_slice();
            let costs = &self.costs;
            let row_costs = |y: usize| &costs[y * row_len..(y + 1) * row_len];
            let sweep = &mut self.sweep;
            let scratch = self.horizontal_scratch.as_mut_slice();
            let (right_matches, right_costs) = (&mut self.right_matches, &mut self.right_costs);

            let aggregate_horizontal = || {
                if let Some(y) = horizontal_y {
                    let base = horizontal_base.unwrap_or(zeros);
                    horizontal_row(
                        row_costs(y),
                        range,
                        penalties,
                        plan.horizontal,
                        base,
                        horizontal,
                        scratch,
                    );
                }
            };
            let aggregate_vertical = || {
                if let Some(y) = vertical_y {
                    sweep.row(
                        row_costs(y),
                        horizontal_before,
                        vertical_out,
                        range,
                        penalties,
                        plan.diagonals,
                    );
                }
            };
            let choose = || {
                if let Some(y) = choose_y {
                    let row = &mut disparities[y * width..(y + 1) * width];
                    choose_row(
                        finished,
                        range,
                        params.min_disparity,
                        params.uniqueness_ratio,
                        row,
                        right_matches,
                        right_costs,
                    );
                    if let Some(max_diff) = params.disp12_max_diff {
                        check_left_right(row, right_matches, max_diff);
                    }
                }
            };
            rayon::join(aggregate_horizontal, || {
                rayon::join(aggregate_vertical, choose)
            });
        }
    }
}
