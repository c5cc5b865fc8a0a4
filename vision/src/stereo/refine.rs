//! Sub-pixel refinement on the images themselves: Lucas-Kanade along the row. The
//! parabola through the aggregated census costs locks disparities towards whole pixels
//! (census costs are integers that change in steps); minimizing the zero-mean squared
//! difference between a left window and the bilinearly interpolated right window
//! removes that bias, down to the noise of the window.
//!
//! The window's sums are kept in [`LANES`] partial sums each, added in a fixed order,
//! so that the loops vectorize and every processor (and every number of threads) gets
//! the same bits. The columns of the window past its last whole group of [`LANES`] are
//! read down the columns of transposed copies of the images, [`LANES`] rows at a time.

use rayon::prelude::*;

use super::simd::dispatched;
use crate::image::{Image, Samples};

/// Largest correction, pixels, the refinement may make: beyond it the window does not
/// see what the aggregated costs matched, and the match keeps its first estimate.
const MAX_CORRECTION: f32 = 1.0;

/// Partial sums per window sum.
const LANES: usize = 8;

/// Reused buffers of the refinement: both images and the right one's gradient along x,
/// as floats, row after row and (`*_columns`) column after column.
#[derive(Default)]
pub(crate) struct Refiner {
    left: Vec<f32>,
    right: Vec<f32>,
    gradient: Vec<f32>,
    left_columns: Vec<f32>,
    right_columns: Vec<f32>,
    gradient_columns: Vec<f32>,
}

fn to_floats(image: &Image, out: &mut Vec<f32>) {
    out.clear();
    match &image.samples {
        Samples::U8(v) => out.extend(v.iter().map(|&s| f32::from(s))),
        Samples::U16(v) => out.extend(v.iter().map(|&s| f32::from(s))),
    }
}

/// Writes the `width` x `height` row-major `values` column after column into `out`.
fn transpose(values: &[f32], width: usize, height: usize, out: &mut Vec<f32>) {
    // Blocks of columns: each task reads whole cache lines of every row.
    const BLOCK: usize = 16;
    out.resize(width * height, 0.0);
    out.par_chunks_mut(BLOCK * height)
        .enumerate()
        .for_each(|(k, columns)| {
            let x0 = k * BLOCK;
            let n = columns.len() / height;
            for (y, row) in values.chunks_exact(width).enumerate() {
                for (i, &v) in row[x0..x0 + n].iter().enumerate() {
                    columns[i * height + y] = v;
                }
            }
        });
}

/// The images as the refinement reads them.
#[derive(Clone, Copy)]
pub(crate) struct Planes<'a> {
    width: usize,
    height: usize,
    left: &'a [f32],
    right: &'a [f32],
    gradient: &'a [f32],
    left_columns: &'a [f32],
    right_columns: &'a [f32],
    gradient_columns: &'a [f32],
}

impl Refiner {
    /// Refines every valid disparity of the left image whose window (`2 * radius + 1`
    /// square) lies inside both images, with `iterations` Gauss-Newton steps.
    pub(crate) fn refine(
        &mut self,
        disparities: &mut [f32],
        left: &Image,
        right: &Image,
        radius: usize,
        iterations: usize,
    ) {
        let (width, height) = (left.width, left.height);
        if radius == 0 || iterations == 0 || width < 2 * radius + 3 || height < 2 * radius + 1 {
            return;
        }
        to_floats(left, &mut self.left);
        to_floats(right, &mut self.right);
        self.gradient.clear();
        self.gradient.resize(width * height, 0.0);
        self.gradient
            .par_chunks_mut(width)
            .zip(self.right.par_chunks(width))
            .for_each(|(gradient, row)| {
                for x in 1..width - 1 {
                    gradient[x] = 0.5 * (row[x + 1] - row[x - 1]);
                }
            });
        transpose(&self.left, width, height, &mut self.left_columns);
        transpose(&self.right, width, height, &mut self.right_columns);
        transpose(&self.gradient, width, height, &mut self.gradient_columns);
        let planes = Planes {
            width,
            height,
            left: &self.left,
            right: &self.right,
            gradient: &self.gradient,
            left_columns: &self.left_columns,
            right_columns: &self.right_columns,
            gradient_columns: &self.gradient_columns,
        };
        disparities
            .par_chunks_mut(width)
            .enumerate()
            .skip(radius)
            .take(height - 2 * radius)
            .for_each(|(y, row)| refine_row(planes, y, row, radius, iterations));
    }
}

/// Refines the valid disparities of row `y` whose window lies inside the image.
#[inline(always)]
fn refine_row_body<A: Accumulator>(
    planes: Planes<'_>,
    y: usize,
    row: &mut [f32],
    radius: usize,
    iterations: usize,
) {
    let width = planes.width;
    for (x, disparity) in row.iter_mut().enumerate().take(width - radius).skip(radius) {
        if disparity.is_nan() {
            continue;
        }
        if let Some(refined) = refine_pixel::<A>(planes, x, y, radius, iterations, *disparity) {
            *disparity = refined;
        }
    }
}

dispatched! {
    /// Refines one row of disparities (see `refine_row_body`).
    fn refine_row(planes: Planes<'_>, y: usize, row: &mut [f32], radius: usize, iterations: usize)
        = refine_row_body::<Avx2>, refine_row_body::<Sums>;
}

/// The window's sums, [`LANES`] partial sums each: gradient times difference, gradient
/// squared, difference, gradient.
#[derive(Default)]
struct Sums {
    ge: [f32; LANES],
    gg: [f32; LANES],
    e: [f32; LANES],
    g: [f32; LANES],
}

/// Adds samples of the window into [`LANES`] partial sums of each window sum.
trait Accumulator {
    /// Partial sums of zero.
    fn zero() -> Self;
    /// Adds [`LANES`] samples: left values `l`, the right values and gradients at the
    /// whole positions `r0`, `g0` and one further `r1`, `g1`, interpolated at `f`.
    fn add(&mut self, l: &[f32], r0: &[f32], r1: &[f32], g0: &[f32], g1: &[f32], f: f32);
    /// The partial sums.
    fn lanes(&self) -> Sums;
}

impl Sums {
    /// [`Accumulator::add`] for up to [`LANES`] samples.
    #[inline(always)]
    fn add_some(&mut self, l: &[f32], r0: &[f32], r1: &[f32], g0: &[f32], g1: &[f32], f: f32) {
        let samples = l.iter().zip(r0).zip(r1).zip(g0).zip(g1);
        for (k, ((((&l, &r0), &r1), &g0), &g1)) in samples.enumerate().take(LANES) {
            let rv = r0 + f * (r1 - r0);
            let gv = g0 + f * (g1 - g0);
            let e = l - rv;
            self.ge[k] += gv * e;
            self.gg[k] += gv * gv;
            self.e[k] += e;
            self.g[k] += gv;
        }
    }

    /// The four sums, their partial sums added pairwise.
    #[inline(always)]
    fn totals(&self) -> [f32; 4] {
        fn total(lanes: &[f32; LANES]) -> f32 {
            let [a, b, c, d, e, f, g, h] = *lanes;
            ((a + e) + (c + g)) + ((b + f) + (d + h))
        }
        [
            total(&self.ge),
            total(&self.gg),
            total(&self.e),
            total(&self.g),
        ]
    }
}

impl Accumulator for Sums {
    #[inline(always)]
    fn zero() -> Self {
        Self::default()
    }

    #[inline(always)]
    fn add(&mut self, l: &[f32], r0: &[f32], r1: &[f32], g0: &[f32], g1: &[f32], f: f32) {
        self.add_some(l, r0, r1, g0, g1, f);
    }

    #[inline(always)]
    fn lanes(&self) -> Sums {
        Sums {
            ge: self.ge,
            gg: self.gg,
            e: self.e,
            g: self.g,
        }
    }
}

/// The partial sums in AVX registers: the same operations in the same order as
/// [`Sums`], so the same bits. Only ever named inside the AVX2 copy of the kernel (see
/// `simd::dispatched`).
#[cfg(target_arch = "x86_64")]
struct Avx2 {
    ge: std::arch::x86_64::__m256,
    gg: std::arch::x86_64::__m256,
    e: std::arch::x86_64::__m256,
    g: std::arch::x86_64::__m256,
}

#[cfg(target_arch = "x86_64")]
impl Accumulator for Avx2 {
    #[inline(always)]
    fn zero() -> Self {
        use std::arch::x86_64::*;
        // SAFETY: `Avx2` is used only by the AVX2 copy of the kernel, which runs only on
        // processors that have AVX2.
        let zero = unsafe { _mm256_setzero_ps() };
        Self {
            ge: zero,
            gg: zero,
            e: zero,
            g: zero,
        }
    }

    #[inline(always)]
    fn add(&mut self, l: &[f32], r0: &[f32], r1: &[f32], g0: &[f32], g1: &[f32], f: f32) {
        use std::arch::x86_64::*;
        let (l, r0, r1, g0, g1) = (
            &l[..LANES],
            &r0[..LANES],
            &r1[..LANES],
            &g0[..LANES],
            &g1[..LANES],
        );
        // SAFETY: as in `zero`; every slice holds `LANES` (8) values, 32 bytes.
        unsafe {
            let load = |values: &[f32]| _mm256_loadu_ps(values.as_ptr());
            let f = _mm256_set1_ps(f);
            let (r0, g0) = (load(r0), load(g0));
            let rv = _mm256_add_ps(r0, _mm256_mul_ps(f, _mm256_sub_ps(load(r1), r0)));
            let gv = _mm256_add_ps(g0, _mm256_mul_ps(f, _mm256_sub_ps(load(g1), g0)));
            let e = _mm256_sub_ps(load(l), rv);
            self.ge = _mm256_add_ps(self.ge, _mm256_mul_ps(gv, e));
            self.gg = _mm256_add_ps(self.gg, _mm256_mul_ps(gv, gv));
            self.e = _mm256_add_ps(self.e, e);
            self.g = _mm256_add_ps(self.g, gv);
        }
    }

    #[inline(always)]
    fn lanes(&self) -> Sums {
        use std::arch::x86_64::*;
        let mut sums = Sums::default();
        // SAFETY: as in `zero`; every array holds `LANES` (8) values, 32 bytes.
        unsafe {
            _mm256_storeu_ps(sums.ge.as_mut_ptr(), self.ge);
            _mm256_storeu_ps(sums.gg.as_mut_ptr(), self.gg);
            _mm256_storeu_ps(sums.e.as_mut_ptr(), self.e);
            _mm256_storeu_ps(sums.g.as_mut_ptr(), self.g);
        }
        sums
    }
}

/// The refined disparity of the left pixel `(x, y)` from `first`, or `None` where the
/// window leaves the right image, the texture gives no gradient, or the correction
/// exceeds [`MAX_CORRECTION`].
#[inline(always)]
fn refine_pixel<'a, A: Accumulator>(
    planes: Planes<'a>,
    x: usize,
    y: usize,
    radius: usize,
    iterations: usize,
    first: f32,
) -> Option<f32> {
    let (width, height) = (planes.width, planes.height);
    let side = 2 * radius + 1;
    let whole = side - side % LANES;
    let n = (side * side) as f32;
    let (left_x, top) = (x - radius, y - radius);
    let mut disparity = first;
    for _ in 0..iterations {
        // Right samples of the window's first column: x0 + f (x0 whole, f in [0, 1)).
        let position = left_x as f32 - disparity;
        let x0 = position.floor();
        // Column 0 has no central difference: windows start at column 1.
        if x0 < 1.0 || x0 as usize + side >= width {
            return None;
        }
        let (x0, f) = (x0 as usize, position - x0);
        let mut sums = A::zero();
        for j in top..top + side {
            let at = j * width;
            let l = &planes.left[at + left_x..at + left_x + whole];
            let r = &planes.right[at + x0..at + x0 + whole + 1];
            let g = &planes.gradient[at + x0..at + x0 + whole + 1];
            for i in (0..whole).step_by(LANES) {
                let (this, next) = (i..i + LANES, i + 1..i + 1 + LANES);
                sums.add(
                    &l[this.clone()],
                    &r[this.clone()],
                    &r[next.clone()],
                    &g[this],
                    &g[next],
                    f,
                );
            }
        }
        // The columns past the whole groups, down their columns: whole groups of rows
        // into `sums`, the rows left over into `tail`.
        let mut tail = Sums::default();
        let whole_rows = side - side % LANES;
        for i in whole..side {
            let column = |values: &'a [f32], x: usize| -> &'a [f32] {
                let at = x * height + top;
                &values[at..at + side]
            };
            let l = column(planes.left_columns, left_x + i);
            let (r0, r1) = (
                column(planes.right_columns, x0 + i),
                column(planes.right_columns, x0 + i + 1),
            );
            let (g0, g1) = (
                column(planes.gradient_columns, x0 + i),
                column(planes.gradient_columns, x0 + i + 1),
            );
            for j in (0..whole_rows).step_by(LANES) {
                let rows = j..j + LANES;
                sums.add(
                    &l[rows.clone()],
                    &r0[rows.clone()],
                    &r1[rows.clone()],
                    &g0[rows.clone()],
                    &g1[rows],
                    f,
                );
            }
            let rows = whole_rows..side;
            tail.add_some(
                &l[rows.clone()],
                &r0[rows.clone()],
                &r1[rows.clone()],
                &g0[rows.clone()],
                &g1[rows],
                f,
            );
        }
        let (main, tail) = (sums.lanes().totals(), tail.totals());
        let [ge, gg, e_sum, g_sum] = std::array::from_fn(|k| main[k] + tail[k]);
        // Zero-mean: a brightness offset between the cameras moves nothing.
        let numerator = ge - e_sum * g_sum / n;
        let denominator = gg - g_sum * g_sum / n;
        if denominator <= f32::EPSILON * n {
            return None;
        }
        disparity -= numerator / denominator;
        if disparity.is_nan() || (disparity - first).abs() > MAX_CORRECTION {
            return None;
        }
    }
    Some(disparity)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shifted_texture_is_found_to_three_hundredths_of_a_pixel() {
        let (width, height) = (64, 16);
        let texture = |x: f64, y: f64| {
            // Broadband, with wavelengths from 7 to 30 pixels. Over a 7-pixel window,
            // linear interpolation of the right image biases the match by up to about
            // 0.025 px where four sines curve together; a real texture's many
            // wavelengths average that out (a 9-pixel window finds a textured wall at
            // 3 m to 0.15 px at the 95th percentile, sensor noise included).
            [
                (0.9, 0.3, 1.0),
                (0.55, -0.4, 2.0),
                (0.33, 0.7, 3.0),
                (0.2, -0.2, 4.0),
            ]
            .iter()
            .map(|(wx, wy, phase): &(f64, f64, f64)| 25.0 * (wx * x + wy * y + phase).sin())
            .sum::<f64>()
                + 110.0
        };
        let shift = 7.3;
        let left: Vec<u16> = (0..width * height)
            .map(|i| (texture((i % width) as f64, (i / width) as f64) * 100.0) as u16)
            .collect();
        let right: Vec<u16> = (0..width * height)
            .map(|i| (texture((i % width) as f64 + shift, (i / width) as f64) * 100.0) as u16)
            .collect();
        let image = |s: Vec<u16>| Image::new(width, height, 1, Samples::U16(s)).unwrap();
        let mut disparities = vec![7.0f32; width * height];
        Refiner::default().refine(&mut disparities, &image(left), &image(right), 3, 3);
        let y = 8;
        for x in 20..50 {
            let d = disparities[y * width + x];
            assert!((d - shift as f32).abs() < 0.03, "x {x}: {d}");
        }
        // Rows whose window leaves the image keep the first estimate.
        assert_eq!(disparities[width + 30], 7.0);
    }

    #[test]
    fn every_processor_refines_to_the_same_bits() {
        let (width, height) = (48, 24);
        let sample = |i: usize, shift: usize| ((i + shift) * 7919 % 251) as u8;
        let left: Vec<u8> = (0..width * height).map(|i| sample(i, 0)).collect();
        let right: Vec<u8> = (0..width * height).map(|i| sample(i, 5)).collect();
        let image = |s: Vec<u8>| Image::new(width, height, 1, Samples::U8(s)).unwrap();
        let (left, right) = (image(left), image(right));
        for radius in [2, 4, 5] {
            let mut refiner = Refiner::default();
            let mut first = vec![4.7f32; width * height];
            refiner.refine(&mut first, &left, &right, radius, 2);
            let planes = Planes {
                width,
                height,
                left: &refiner.left,
                right: &refiner.right,
                gradient: &refiner.gradient,
                left_columns: &refiner.left_columns,
                right_columns: &refiner.right_columns,
                gradient_columns: &refiner.gradient_columns,
            };
            let mut portable = vec![4.7f32; width * height];
            for (y, row) in portable.chunks_exact_mut(width).enumerate() {
                if (radius..height - radius).contains(&y) {
                    refine_row_body::<Sums>(planes, y, row, radius, 2);
                }
            }
            assert_eq!(
                first.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                portable.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                "radius {radius}"
            );
            assert!(first.iter().any(|&d| d != 4.7));
        }
    }
}
