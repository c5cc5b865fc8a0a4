//! Block matching, the cheapest dense matcher (OpenCV's `StereoBM`, stereo_image_proc's
//! `stereo_algorithm: 0`): both images are pre-filtered with a clipped horizontal Sobel
//! derivative, each left pixel takes the disparity whose square window has the least
//! sum of absolute differences, and matches are rejected where the window has too
//! little texture, where another disparity is nearly as good, where the right image's
//! own best match disagrees, and in small speckles. Sub-pixel positions come from the
//! equiangular ("V") fit that suits absolute differences.
//!
//! Window sums slide: column sums over the window's height are updated row by row, and
//! the window sum over them column by column, so a pixel costs two additions per
//! disparity whatever the window's size. Bands of rows run in parallel; the sums are
//! exact integers, so the result does not depend on the number of threads.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::params::{validate_filters, validate_search};
use super::simd;
use super::speckle::SpeckleFilter;
use super::{DisparityMap, StereoError, check_pair};
use crate::image::{Image, Samples};

/// Fewest rows a band of the parallel loop matches.
const MIN_BAND_ROWS: usize = 32;

/// Parameters of a [`BlockMatcher`], with stereo_image_proc's names and meanings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BmParams {
    /// Smallest disparity searched, pixels (may be negative).
    pub min_disparity: i32,
    /// Number of disparities searched, a positive multiple of 16 below the image width.
    pub disparity_range: usize,
    /// Side of the square matching window, pixels: odd, 5 to 255.
    pub window: usize,
    /// The pre-filtered derivative is clipped to `[-prefilter_cap, prefilter_cap]`
    /// (1 to 63).
    pub prefilter_cap: u8,
    /// A match is kept only where the window's summed pre-filtered derivative
    /// magnitude reaches this (0 turns the check off).
    pub texture_threshold: u32,
    /// A match is kept only when every disparity more than one pixel away from it costs
    /// more than this many percent above it (0 turns the check off).
    pub uniqueness_ratio: u32,
    /// Largest difference, pixels, between a left pixel's disparity and the one its
    /// match in the right image finds; `None` turns the check off.
    pub disp12_max_diff: Option<u32>,
    /// Connected regions of similar disparity with at most this many pixels are taken
    /// for noise and invalidated (0 turns the speckle filter off).
    pub speckle_size: usize,
    /// Largest disparity difference, pixels, between neighbours of one speckle region.
    pub speckle_range: f32,
}

impl Default for BmParams {
    /// stereo_image_proc's block-matching defaults, with 64 disparities and the
    /// left-right check of [`super::SgmParams`]'s defaults (1 px).
    fn default() -> Self {
        Self {
            min_disparity: 0,
            disparity_range: 64,
            window: 15,
            prefilter_cap: 31,
            texture_threshold: 10,
            uniqueness_ratio: 15,
            disp12_max_diff: Some(1),
            speckle_size: 100,
            speckle_range: 4.0,
        }
    }
}

impl BmParams {
    /// Checks the parameters against an image `width` pixels wide.
    pub fn validate(&self, width: usize) -> Result<(), StereoError> {
        validate_search(self.min_disparity, self.disparity_range, width)?;
        if !(5..=255).contains(&self.window) || self.window.is_multiple_of(2) {
            return Err(StereoError::Parameter(format!(
                "the matching window must be odd, from 5 to 255 pixels, got {}",
                self.window
            )));
        }
        if !(1..=63).contains(&self.prefilter_cap) {
            return Err(StereoError::Parameter(format!(
                "prefilter_cap must be from 1 to 63, got {}",
                self.prefilter_cap
            )));
        }
        validate_filters(self.uniqueness_ratio, self.speckle_range)
    }
}

/// Block matching of rectified pairs; buffers are kept from pair to pair.
pub struct BlockMatcher {
    params: BmParams,
    left: Vec<u8>,
    right: Vec<u8>,
    bands: Vec<BandBuffers>,
    speckles: SpeckleFilter,
}

/// What one band of rows works in, kept from pair to pair.
#[derive(Default)]
pub(crate) struct BandBuffers {
    /// Per column, the window's column sums of absolute differences per disparity.
    sad: Vec<u16>,
    /// Per column, the window's column sum of derivative magnitudes.
    texture: Vec<u32>,
    /// The window's sums per disparity at the current pixel.
    window: Vec<u32>,
    /// Per right column, its least cost and disparity index (left-right check).
    right_best: Vec<u64>,
    /// Per left column of the current row, the chosen disparity index and offset.
    chosen: Vec<Option<(usize, f32)>>,
}

/// What every band of one pair reads.
pub(crate) struct Pair<'a> {
    left: &'a [u8],
    right: &'a [u8],
    width: usize,
    height: usize,
    params: &'a BmParams,
}

impl BlockMatcher {
    /// A matcher with `params`, checked when a pair arrives (they depend on its width).
    pub fn new(params: BmParams) -> Self {
        Self {
            params,
            left: Vec::new(),
            right: Vec::new(),
            bands: Vec::new(),
            speckles: SpeckleFilter::default(),
        }
    }

    /// The parameters in use.
    pub fn params(&self) -> &BmParams {
        &self.params
    }

    /// Disparities of the left image of a rectified pair (mono8 or mono16, both of the
    /// same size and encoding): for each left pixel `x`, its match in the right image
    /// is at `x - disparity` on the same row. Pixels whose window or whose matches leave
    /// the image are invalid (NaN).
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
        check_pair(left, right)?;
        let (width, height) = (left.width, left.height);
        self.params.validate(width)?;
        let cap = self.params.prefilter_cap;
        for (image, filtered) in [(left, &mut self.left), (right, &mut self.right)] {
            filtered.resize(width * height, 0);
            match &image.samples {
                Samples::U8(v) => prefilter_xsobel(v, width, height, cap, filtered),
                Samples::U16(v) => prefilter_xsobel(v, width, height, cap, filtered),
            }
        }
        let params = &self.params;
        out.reset(width, height, params.min_disparity, params.disparity_range);
        out.data.fill(f32::NAN);
        let pair = Pair {
            left: &self.left,
            right: &self.right,
            width,
            height,
            params,
        };
        // A band restarts its column sums, so bands are as few as keep every thread busy;
        // the sums are exact, so the result does not depend on how the rows are cut.
        let band_rows = height
            .div_ceil(2 * rayon::current_num_threads())
            .max(MIN_BAND_ROWS);
        self.bands
            .resize_with(height.div_ceil(band_rows), BandBuffers::default);
        out.data
            .par_chunks_mut(width * band_rows)
            .zip(self.bands.par_iter_mut())
            .enumerate()
            .for_each(|(band, (rows, buffers))| {
                match_band(&pair, band * band_rows, rows, buffers);
            });
        self.speckles.apply(
            &mut out.data,
            width,
            params.speckle_size,
            params.speckle_range,
        );
        Ok(())
    }
}

/// OpenCV's x-Sobel pre-filter: `clamp(d(y-1) + 2 d(y) + d(y+1), -cap, cap) + cap` with
/// `d` the horizontal difference of a row's neighbours; rows beyond the image mirror
/// (reflect-101) and the first and last columns take `cap`.
fn prefilter_xsobel<T: Copy + Into<i32> + Sync>(
    image: &[T],
    width: usize,
    height: usize,
    cap: u8,
    out: &mut [u8],
) {
    let cap = i32::from(cap);
    let reflect = |y: isize| -> usize {
        if y < 0 {
            (-y).min(height as isize - 1) as usize
        } else if y >= height as isize {
            (2 * (height as isize - 1) - y).max(0) as usize
        } else {
            y as usize
        }
    };
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let rows = [-1, 0, 1].map(|dy| {
            let r = reflect(y as isize + dy);
            &image[r * width..(r + 1) * width]
        });
        row[0] = cap as u8;
        row[width - 1] = cap as u8;
        for x in 1..width - 1 {
            let d = |r: &[T]| r[x + 1].into() - r[x - 1].into();
            let v = d(rows[0]) + 2 * d(rows[1]) + d(rows[2]);
            row[x] = (v.clamp(-cap, cap) + cap) as u8;
        }
    });
}

simd::dispatched! {
    /// Matches the rows `first..` of `out` (whole rows of the disparity map).
    fn match_band(
        pair: &Pair<'_>,
        first: usize,
        out: &mut [f32],
        buffers: &mut BandBuffers,
    ) = match_band_kernel;
}

/// [`match_band`], compiled for the baseline target and for AVX2.
///
/// Costs are kept by `j = range - 1 - k` for the disparity `min_disparity + k`, so that
/// a left column's costs read the right row forwards and every loop over disparities
/// runs over contiguous memory.
#[inline(always)]
fn match_band_kernel(pair: &Pair<'_>, first: usize, out: &mut [f32], buffers: &mut BandBuffers) {
    let Pair {
        left,
        right,
        width,
        height,
        params,
    } = *pair;
    let half = params.window / 2;
    let range = params.disparity_range;
    let min_d = params.min_disparity as isize;
    let max_d = min_d + range as isize - 1;
    // Columns whose every match stays in the image, and pixels whose window of such
    // columns and whose rows stay in it.
    let column_lo = max_d.max(0) as usize;
    let column_hi = (width as isize - 1 + min_d.min(0)) as usize;
    if column_hi < column_lo + 2 * half {
        return;
    }
    let (x_lo, x_hi) = (column_lo + half, column_hi - half);
    let rows = out.len() / width;
    // An image lower than the window has no pixel to match.
    let (y_lo, y_hi) = (
        first.max(half),
        (first + rows).min(height.saturating_sub(half)),
    );
    if y_lo >= y_hi {
        return;
    }
    let cap = i32::from(params.prefilter_cap);
    let columns = column_hi - column_lo + 1;
    // Per column: the sum over the window's rows of |left - right| per disparity (at
    // most 255 * 126, a u16), and of the left's derivative magnitude (texture).
    let BandBuffers {
        sad,
        texture,
        window,
        right_best,
        chosen,
    } = buffers;
    refill(sad, columns * range, 0);
    refill(texture, columns, 0);
    // Right column of cost j at left column x: x - max_d + j.
    let first_right = |x: usize| (x as isize - max_d) as usize;
    fn row(image: &[u8], width: usize, y: usize) -> &[u8] {
        &image[y * width..(y + 1) * width]
    }
    let row_of = |image, y| row(image, width, y);
    for y in y_lo - half..=y_lo + half {
        let (l, r) = (row_of(left, y), row_of(right, y));
        for (c, costs) in sad.chunks_exact_mut(range).enumerate() {
            let x = column_lo + c;
            let lv = l[x];
            texture[c] += (i32::from(lv) - cap).unsigned_abs();
            let r = &r[first_right(x)..first_right(x) + range];
            for (cost, &rv) in costs.iter_mut().zip(r) {
                *cost += u16::from(distance(lv, rv));
            }
        }
    }
    refill(window, range, 0);
    // Per right column: its least cost (high half) and the j of it (low half).
    refill(right_best, width, u64::MAX);
    refill(chosen, width, None);
    for y in y_lo..y_hi {
        if y > y_lo {
            let (l_in, r_in) = (row_of(left, y + half), row_of(right, y + half));
            let (l_out, r_out) = (row_of(left, y - half - 1), row_of(right, y - half - 1));
            for (c, costs) in sad.chunks_exact_mut(range).enumerate() {
                let x = column_lo + c;
                let (a, b) = (l_in[x], l_out[x]);
                texture[c] = texture[c] + (i32::from(a) - cap).unsigned_abs()
                    - (i32::from(b) - cap).unsigned_abs();
                let from = first_right(x);
                let r_in = &r_in[from..from + range];
                let r_out = &r_out[from..from + range];
                for ((cost, &ri), &ro) in costs.iter_mut().zip(r_in).zip(r_out) {
                    *cost = cost
                        .wrapping_add(u16::from(distance(a, ri)))
                        .wrapping_sub(u16::from(distance(b, ro)));
                }
            }
        }
        right_best.fill(u64::MAX);
        chosen.fill(None);
        // The window sum at x_lo, then slid one column at a time.
        window.fill(0);
        let mut window_texture = 0u32;
        for (column, &tex) in sad
            .chunks_exact(range)
            .zip(texture.iter())
            .take(params.window)
        {
            for (w, &s) in window.iter_mut().zip(column) {
                *w += u32::from(s);
            }
            window_texture += tex;
        }
        for (x, slot) in (x_lo..=x_hi).zip(&mut chosen[x_lo..=x_hi]) {
            if x > x_lo {
                let c_in = x + half - column_lo;
                let c_out = x - half - 1 - column_lo;
                let s_in = &sad[c_in * range..(c_in + 1) * range];
                let s_out = &sad[c_out * range..(c_out + 1) * range];
                for ((w, &i), &o) in window.iter_mut().zip(s_in).zip(s_out) {
                    *w = w.wrapping_add(u32::from(i)).wrapping_sub(u32::from(o));
                }
                window_texture = window_texture + texture[c_in] - texture[c_out];
            }
            if params.disp12_max_diff.is_some() {
                let from = first_right(x);
                for ((best, &cost), j) in right_best[from..from + range]
                    .iter_mut()
                    .zip(window.iter())
                    .zip(0u64..)
                {
                    *best = (*best).min(u64::from(cost) << 32 | j);
                }
            }
            if window_texture >= params.texture_threshold {
                *slot = choose(window, params.uniqueness_ratio);
            }
        }
        let row = &mut out[(y - first) * width..(y - first + 1) * width];
        for x in x_lo..=x_hi {
            let Some((j, offset)) = chosen[x] else {
                continue;
            };
            if let Some(max_diff) = params.disp12_max_diff {
                let from_right = (right_best[first_right(x) + j] & 0xffff_ffff) as usize;
                if from_right.abs_diff(j) > max_diff as usize {
                    continue;
                }
            }
            // j counts disparities downwards from max_d; the offset is along j.
            row[x] = (max_d - j as isize) as f32 - offset;
        }
    }
}

/// Makes `buffer` `len` copies of `value`, keeping its allocation.
#[inline(always)]
fn refill<T: Clone>(buffer: &mut Vec<T>, len: usize, value: T) {
    buffer.clear();
    buffer.resize(len, value);
}

/// `|a - b|` in bytes (larger minus smaller), which vectorizes as byte operations.
#[inline(always)]
fn distance(a: u8, b: u8) -> u8 {
    a.max(b) - a.min(b)
}

/// The smallest of `values` (`u32::MAX` for none), as a fold that vectorizes.
#[inline(always)]
fn smallest(values: &[u32]) -> u32 {
    values.iter().fold(u32::MAX, |m, &c| m.min(c))
}

/// The disparity index of the least cost and its sub-pixel offset, unless a
/// disparity more than one index away costs at most `uniqueness_ratio` percent more.
#[inline(always)]
fn choose(costs: &[u32], uniqueness_ratio: u32) -> Option<(usize, f32)> {
    let least = smallest(costs);
    // The first block of 16 that holds the least, found without branching inside a
    // block, then the first least in it.
    let block = costs
        .chunks(16)
        .position(|block| block.iter().fold(false, |found, &c| found | (c == least)))?;
    let best = block * 16 + costs[block * 16..].iter().position(|&c| c == least)?;
    if uniqueness_ratio > 0 {
        let bound = u64::from(least) * u64::from(100 + uniqueness_ratio) / 100;
        let before = &costs[..best.saturating_sub(1)];
        let after = costs.get(best + 2..).unwrap_or(&[]);
        if u64::from(smallest(before).min(smallest(after))) <= bound {
            return None;
        }
    }
    let offset = match (best.checked_sub(1), costs.get(best + 1)) {
        (Some(before), Some(&after)) => {
            let (before, after, least) = (costs[before] as f32, after as f32, least as f32);
            let rise = before.max(after) - least;
            if rise > 0.0 {
                (before - after) / (2.0 * rise)
            } else {
                0.0
            }
        }
        _ => 0.0,
    };
    Some((best, offset))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(width: usize, height: usize, seed: u64) -> Vec<u8> {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        (0..width * height)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 56) as u8
            })
            .collect()
    }

    fn mono(width: usize, height: usize, data: Vec<u8>) -> Image {
        Image {
            width,
            height,
            channels: 1,
            samples: Samples::U8(data),
        }
    }

    #[test]
    fn a_shifted_texture_matches_at_its_shift() {
        let (width, height, shift) = (160, 60, 7);
        let left = texture(width, height, 3);
        let right: Vec<u8> = (0..height)
            .flat_map(|y| {
                let row = &left[y * width..(y + 1) * width];
                (0..width).map(move |x| row[(x + shift).min(width - 1)])
            })
            .collect();
        let mut matcher = BlockMatcher::new(BmParams {
            disparity_range: 32,
            window: 9,
            ..BmParams::default()
        });
        let map = matcher
            .compute(&mono(width, height, left), &mono(width, height, right))
            .expect("matches");
        let valid: Vec<f32> = map.data.iter().copied().filter(|d| !d.is_nan()).collect();
        assert!(valid.len() > width * height / 3, "{} valid", valid.len());
        let worst = valid
            .iter()
            .map(|d| (d - shift as f32).abs())
            .fold(0.0f32, f32::max);
        // Sub-pixel fits of an exact shift stay within a fraction of a pixel.
        assert!(
            worst < 0.3,
            "a disparity {worst} px off the shift of {shift}"
        );
        // The first columns have matches outside the right image.
        assert!(map.at(31 + 4 - 1, 30).is_none());
    }

    #[test]
    fn an_image_lower_than_the_window_has_no_disparity() {
        let image = mono(64, 8, texture(64, 8, 2));
        let mut matcher = BlockMatcher::new(BmParams {
            disparity_range: 16,
            window: 21,
            ..BmParams::default()
        });
        let map = matcher.compute(&image, &image).expect("matched");
        assert!(map.data.iter().all(|d| d.is_nan()));
    }

    #[test]
    fn parameters_out_of_range_are_refused_with_the_reason() {
        let image = mono(128, 32, texture(128, 32, 1));
        for (params, words) in [
            (
                BmParams {
                    window: 8,
                    ..BmParams::default()
                },
                "odd",
            ),
            (
                BmParams {
                    prefilter_cap: 0,
                    ..BmParams::default()
                },
                "prefilter_cap",
            ),
            (
                BmParams {
                    disparity_range: 20,
                    ..BmParams::default()
                },
                "multiple of 16",
            ),
        ] {
            let error = BlockMatcher::new(params)
                .compute(&image, &image)
                .expect_err("refused");
            assert!(error.to_string().contains(words), "{error}");
        }
    }
}
