//! Semi-global matching of a rectified pair, with every buffer kept between frames.

use std::ops::Range;

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
/// With four or eight paths, a downward and an upward sweep run side by side, in two
/// halves: first the downward sweep over the top half of the rows and the upward one
/// over the bottom half, each storing its sums; then each sweep goes on over the other
/// half, adds the other's stored sums and chooses the disparities as it goes. So the
/// aggregated costs of the whole image are stored once, and the two sweeps keep two
/// threads busy. With five paths one downward sweep chooses as it goes. Within a
/// sweep, the image is swept one row at a time as a pipeline: while one thread
/// aggregates a row along its horizontal path, others aggregate the row before along
/// the vertical paths, compute the matching costs of the row after and choose the
/// disparities of the row before that. The costs are never stored for the whole image:
/// each sweep keeps three rows of them. The result does not depend on the number of
/// threads.
///
/// The matcher keeps its buffers between calls: matching a stream of pairs of one size
/// allocates only for the first.
pub struct SemiGlobalMatcher {
    params: SgmParams,
    census_left: Vec<u64>,
    census_right: Vec<u64>,
    /// Sums of each sweep's paths over the first half of its rows (two-sweep modes).
    sums: AlignedBuffer,
    /// A row of zero sums, the base of the first paths.
    zeros: AlignedBuffer,
    /// The downward sweep and the upward one.
    sweepers: [Sweeper; 2],
    speckles: SpeckleFilter,
    refiner: Refiner,
    /// The disparities before the refinement, kept for the matches it would move out of
    /// the searched range.
    first_estimates: Vec<f32>,
}

/// Largest number of matching costs (pixels times disparities) of a pair: the
/// aggregated sums take two bytes per cost, so about 1 GB at the limit (1920x1080 with
/// 256 disparities is within it).
pub const MAX_COST_CELLS: usize = 1 << 29;

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

/// The buffers of one sweep over the rows.
#[derive(Default)]
struct Sweeper {
    /// Horizontal paths of the row being swept and of the row before.
    horizontal: [AlignedBuffer; 2],
    /// Complete sums of the two rows waiting for their disparities to be chosen.
    finished: [AlignedBuffer; 2],
    sweep: SweepState,
    horizontal_scratch: AlignedBuffer,
    right_matches: Vec<i32>,
    right_costs: Vec<u16>,
    /// Matching costs of the rows being swept, computed as the sweep reaches them (see
    /// [`cost_ring`]).
    cost_rows: [Vec<u8>; 3],
}

/// What a sweep does at each row.
#[derive(Clone, Copy)]
struct SweepPlan {
    horizontal: Horizontal,
    diagonals: bool,
    upward: bool,
}

/// What is shared by the sweeps of a pair.
#[derive(Clone, Copy)]
struct Frame<'a> {
    params: &'a SgmParams,
    census_left: &'a [u64],
    census_right: &'a [u64],
    zeros: &'a [u16],
    width: usize,
}

/// Where a stretch of a sweep puts its sums: `rows` are the rows swept, and the
/// buffers below hold exactly those rows, first row first.
enum Output<'a> {
    /// Stores the sums of the rows.
    Store(&'a mut [u16]),
    /// Adds `other`, the other sweep's sums of the rows, and chooses the rows'
    /// disparities into `disparities`.
    Choose {
        other: Option<&'a [u16]>,
        disparities: &'a mut [f32],
    },
}

impl Sweeper {
    fn reset(&mut self, width: usize, range: usize) {
        for buffer in self.horizontal.iter_mut().chain(self.finished.iter_mut()) {
            buffer.resize(width * range);
        }
        self.horizontal_scratch.resize(2 * slot_len(range));
        self.right_matches.resize(width, 0);
        self.right_costs.resize(width, 0);
        for row in &mut self.cost_rows {
            row.resize(width * range, 0);
        }
        self.sweep.reset(width, range);
    }

    /// Sweeps `rows` (down, or up when `plan.upward`), going on from the row before
    /// them (from the image's border after [`Self::reset`]), as a pipeline: at step
    /// `i` the horizontal paths of the `i`-th row, the vertical paths of the row
    /// before, the matching costs of the row after and, when choosing, the disparities
    /// of the row before that, each on its own thread.
    fn run(&mut self, frame: Frame<'_>, plan: SweepPlan, rows: Range<usize>, output: Output<'_>) {
        let params = frame.params;
        let range = params.disparity_range;
        let width = frame.width;
        let penalties = Penalties {
            p1: params.p1,
            p2: params.p2,
        };
        let row_len = width * range;
        let count = rows.len();
        // The `step`-th row swept, and its index in `rows`.
        let row_of = |step: usize| if plan.upward { count - 1 - step } else { step };
        let (mut stored, other, mut disparities) = match output {
            Output::Store(sums) => (Some(sums), None, None),
            Output::Choose { other, disparities } => (None, other, Some(disparities)),
        };
        let costs_of = |i: usize, costs: &mut [u8]| {
            let y = rows.start + i;
            cost_row(
                &frame.census_left[y * width..(y + 1) * width],
                &frame.census_right[y * width..(y + 1) * width],
                params.min_disparity,
                range,
                costs,
            );
        };
        if count > 0 {
            costs_of(row_of(0), &mut self.cost_rows[0]);
        }
        let steps = if disparities.is_some() {
            count + 2
        } else {
            count + 1
        };
        for step in 0..steps {
            let horizontal_i = (step < count).then(|| row_of(step));
            let vertical_i = (1..=count).contains(&step).then(|| row_of(step - 1));
            let choose_i = (step >= 2).then(|| row_of(step - 2));
            let next_i = (step + 1 < count).then(|| row_of(step + 1));
            let (horizontal_costs, vertical_costs, next_costs) =
                cost_ring(&mut self.cost_rows, step);

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
            let horizontal_base = match (other, horizontal_i) {
                (Some(other), Some(i)) => &other[i * row_len..(i + 1) * row_len],
                _ => frame.zeros,
            };
            let vertical_out: &mut [u16] = match (&mut stored, vertical_i) {
                (Some(sums), Some(i)) => &mut sums[i * row_len..(i + 1) * row_len],
                _ => finishing,
            };
            let sweep = &mut self.sweep;
            let scratch = self.horizontal_scratch.as_mut_slice();
            let (right_matches, right_costs) = (&mut self.right_matches, &mut self.right_costs);
            let choose_row_of = choose_i.zip(disparities.as_deref_mut());

            let aggregate_horizontal = || {
                if horizontal_i.is_some() {
                    horizontal_row(
                        horizontal_costs,
                        range,
                        penalties,
                        plan.horizontal,
                        horizontal_base,
                        horizontal,
                        scratch,
                    );
                }
            };
            let aggregate_vertical = || {
                if vertical_i.is_some() {
                    sweep.row(
                        vertical_costs,
                        horizontal_before,
                        vertical_out,
                        range,
                        penalties,
                        plan.diagonals,
                    );
                }
            };
            let choose = || {
                if let Some((i, disparities)) = choose_row_of {
                    let row = &mut disparities[i * width..(i + 1) * width];
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
            let compute_next_costs = || {
                if let Some(i) = next_i {
                    costs_of(i, next_costs);
                }
            };
            rayon::join(aggregate_horizontal, || {
                rayon::join(aggregate_vertical, || {
                    rayon::join(compute_next_costs, choose)
                })
            });
        }
    }
}

/// The three cost rows of sweep step `step`: the row whose horizontal paths it
/// aggregates (`row_of(step)`), the row before, whose vertical paths it aggregates, and
/// the row after, whose costs it computes. Each row's costs are computed one step
/// before its horizontal paths need them and kept one step after, for its vertical
/// paths.
fn cost_ring(rows: &mut [Vec<u8>; 3], step: usize) -> (&[u8], &[u8], &mut [u8]) {
    let [a, b, c] = rows;
    match step % 3 {
        0 => (a, c, b),
        1 => (b, a, c),
        _ => (c, b, a),
    }
}

impl SemiGlobalMatcher {
    /// A matcher with `params`, checked when a pair arrives (they depend on its width).
    pub fn new(params: SgmParams) -> Self {
        Self {
            params,
            census_left: Vec::new(),
            census_right: Vec::new(),
            sums: AlignedBuffer::default(),
            zeros: AlignedBuffer::default(),
            sweepers: Default::default(),
            speckles: SpeckleFilter::default(),
            refiner: Refiner::default(),
            first_estimates: Vec::new(),
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
        if pixels
            .checked_mul(range)
            .is_none_or(|cells| cells > MAX_COST_CELLS)
        {
            return Err(StereoError::TooLarge {
                width,
                height,
                range,
                limit: MAX_COST_CELLS,
            });
        }

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
        let row_len = width * range;
        self.zeros.resize(row_len);
        self.zeros.as_mut_slice().fill(0);
        for sweeper in &mut self.sweepers {
            sweeper.reset(width, range);
        }
        out.reset(width, height, min_disparity, range);

        let frame = Frame {
            params: &self.params,
            census_left: &self.census_left,
            census_right: &self.census_right,
            zeros: self.zeros.as_slice(),
            width,
        };
        let [down, up] = &mut self.sweepers;
        match self.params.paths {
            Paths::Five => {
                let plan = SweepPlan {
                    horizontal: Horizontal::Both,
                    diagonals: true,
                    upward: false,
                };
                let output = Output::Choose {
                    other: None,
                    disparities: &mut out.data,
                };
                down.run(frame, plan, 0..height, output);
            }
            Paths::Four | Paths::Eight => {
                let diagonals = self.params.paths == Paths::Eight;
                let down_plan = SweepPlan {
                    horizontal: Horizontal::LeftToRight,
                    diagonals,
                    upward: false,
                };
                let up_plan = SweepPlan {
                    horizontal: Horizontal::RightToLeft,
                    diagonals,
                    upward: true,
                };
                let middle = height / 2;
                self.sums.resize(pixels * range);
                let (top, bottom) = self.sums.as_mut_slice().split_at_mut(middle * row_len);
                rayon::join(
                    || down.run(frame, down_plan, 0..middle, Output::Store(top)),
                    || up.run(frame, up_plan, middle..height, Output::Store(bottom)),
                );
                let (top_out, bottom_out) = out.data.split_at_mut(middle * width);
                let (top, bottom) = (&*top, &*bottom);
                rayon::join(
                    || {
                        let output = Output::Choose {
                            other: Some(bottom),
                            disparities: bottom_out,
                        };
                        down.run(frame, down_plan, middle..height, output);
                    },
                    || {
                        let output = Output::Choose {
                            other: Some(top),
                            disparities: top_out,
                        };
                        up.run(frame, up_plan, 0..middle, output);
                    },
                );
            }
        }
        self.first_estimates.clone_from(&out.data);
        self.refiner.refine(
            &mut out.data,
            left,
            right,
            self.params.refine_radius,
            REFINE_ITERATIONS,
        );
        // A refined match that leaves the searched range keeps its first estimate: a
        // disparity outside the range would read as invalid downstream.
        let lowest = self.params.min_disparity as f32;
        let highest = lowest + (range - 1) as f32;
        for (refined, &first) in out.data.iter_mut().zip(&self.first_estimates) {
            if !(lowest..=highest).contains(refined) {
                *refined = first;
            }
        }
        self.speckles.apply(
            &mut out.data,
            width,
            self.params.speckle_size,
            self.params.speckle_range,
        );
        Ok(())
    }
}
