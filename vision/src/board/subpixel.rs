//! Sub-pixel corner refinement whose window follows the size of the squares in the
//! image.
//!
//! The estimator is the one of OpenCV's `cornerSubPix`: the corner is the point `q`
//! that every image gradient in the window is orthogonal to (`g(p) . (p - q) = 0`),
//! solved in least squares with Gaussian weights and iterated from the window
//! re-centred on the last estimate. A window reaching the neighbouring corners pulls
//! the estimate towards their edges, and a window that is too small sees too few
//! edge pixels; so the half-size is a fraction of the local square side, measured per
//! corner.

use nalgebra::{Point2, Vector2};

use super::Gray;

/// How the refinement window is sized and when the iteration stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubpixelWindow {
    /// Window half-size as a fraction of the local square side.
    pub fraction: f64,
    /// Smallest half-size, pixels.
    pub min_half: usize,
    /// Largest half-size, pixels.
    pub max_half: usize,
    /// Iterations at most.
    pub max_iterations: usize,
    /// Stop when an iteration moves the corner less than this, pixels.
    pub epsilon: f64,
    /// Standard deviation of the Gaussian the image is sampled through, as a
    /// fraction of the window half-size: the more a window holds, the more blur it
    /// affords, and the better the blur hides the pixel grid.
    pub sigma_fraction: f64,
    /// Smallest and largest standard deviation of that Gaussian, pixels.
    pub sigma_range: (f64, f64),
}

impl Default for SubpixelWindow {
    fn default() -> Self {
        Self {
            fraction: 0.3,
            min_half: 2,
            max_half: 12,
            max_iterations: 30,
            epsilon: 0.001,
            sigma_fraction: 0.1,
            sigma_range: (1.0, 2.0),
        }
    }
}

impl SubpixelWindow {
    /// Half-size of the window (the window is `2 h + 1` pixels wide) for a corner
    /// whose shortest adjacent square side is `square_px` pixels.
    pub fn half_size(&self, square_px: f64) -> usize {
        let half = (self.fraction * square_px).round();
        if half.is_finite() && half > 0.0 {
            (half as usize).clamp(self.min_half, self.max_half)
        } else {
            self.min_half
        }
    }
}

/// Refines each corner in place, with the window sized from the corner's entry in
/// `square_px` (the shortest side of the squares around it, pixels). A corner whose
/// refinement fails or leaves the window keeps its position; the result says, per
/// corner, whether it was refined.
pub fn refine_corners(
    gray: &Gray,
    corners: &mut [Point2<f64>],
    square_px: &[f64],
    window: &SubpixelWindow,
) -> Vec<bool> {
    corners
        .iter_mut()
        .zip(square_px)
        .map(|(corner, &square)| {
            match refine_corner(gray, *corner, window.half_size(square), window) {
                Some(refined) => {
                    *corner = refined;
                    true
                }
                None => false,
            }
        })
        .collect()
}

/// One corner: the gradient-orthogonality estimate from `start` with a window of
/// half-size `half`; `None` when the window leaves the image, the gradients do not
/// determine a point, or the estimate moves farther than the window from `start`.
pub fn refine_corner(
    gray: &Gray,
    start: Point2<f64>,
    half: usize,
    window: &SubpixelWindow,
) -> Option<Point2<f64>> {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2.
        return unsafe { refine_corner_avx2(gray, start, half, window) };
    }
    refine(gray, start, half, window)
}

/// [`refine`] compiled for AVX2: four doubles per instruction instead of two. The
/// arithmetic is the same IEEE operations (no fused multiply-add), so the result is
/// identical.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn refine_corner_avx2(
    gray: &Gray,
    start: Point2<f64>,
    half: usize,
    window: &SubpixelWindow,
) -> Option<Point2<f64>> {
    refine(gray, start, half, window)
}

/// The body of [`refine_corner`]. Its loops run across the window's columns, free of
/// branches, so that the compiler vectorizes them.
#[inline(always)]
fn refine(
    gray: &Gray,
    start: Point2<f64>,
    half: usize,
    window: &SubpixelWindow,
) -> Option<Point2<f64>> {
    let side = 2 * half + 1;
    // Gaussian weights falling to exp(-1) at the window's edge, as cornerSubPix.
    let weights: Vec<f64> = (0..side)
        .map(|i| {
            let t = (i as f64 - half as f64) / half as f64;
            (-t * t).exp()
        })
        .collect();
    let offsets: Vec<f64> = (0..side).map(|i| i as f64 - half as f64).collect();
    let (min_sigma, max_sigma) = window.sigma_range;
    let sigma = (window.sigma_fraction * half as f64).clamp(min_sigma, max_sigma);
    let mut resampler = Resampler::new(sigma, half + 1);
    let sampled = side + 2;
    // Per column of the window, sums over its rows of the weighted moments
    // gx gx, gx gy, gy gy, and of the right-hand sides.
    let mut columns = vec![[0.0f64; 5]; side];
    let mut q = start;
    for _ in 0..window.max_iterations {
        let patch = resampler.sample(gray, q)?;
        columns.fill([0.0; 5]);
        for (row, (&wy, &py)) in weights.iter().zip(&offsets).enumerate() {
            let line = (row + 1) * sampled;
            let left = &patch[line..][..side];
            let right = &patch[line + 2..][..side];
            let above = &patch[line - sampled + 1..][..side];
            let below = &patch[line + sampled + 1..][..side];
            for col in 0..side {
                let gx = right[col] - left[col];
                let gy = below[col] - above[col];
                let w = weights[col] * wy;
                let px = offsets[col];
                let (gxx, gxy, gyy) = (gx * gx * w, gx * gy * w, gy * gy * w);
                let sums = &mut columns[col];
                sums[0] += gxx;
                sums[1] += gxy;
                sums[2] += gyy;
                sums[3] += gxx * px + gxy * py;
                sums[4] += gxy * px + gyy * py;
            }
        }
        let [a, b, c, bb1, bb2] = columns.iter().fold([0.0; 5], |mut total, sums| {
            for (t, s) in total.iter_mut().zip(sums) {
                *t += s;
            }
            total
        });
        let det = a * c - b * b;
        if det.abs() <= f64::EPSILON * (a * c).abs().max(1.0) {
            return None;
        }
        let step = Vector2::new(c * bb1 - b * bb2, a * bb2 - b * bb1) / det;
        q += step;
        if step.norm() < window.epsilon {
            break;
        }
    }
    let moved = q - start;
    (moved.x.abs() <= half as f64 && moved.y.abs() <= half as f64).then_some(q)
}

/// Samples the image, seen through a Gaussian, on the grid of one-pixel steps
/// centred on a continuous position.
///
/// Every sample has the same sub-pixel phase, so this is a separable convolution
/// with one set of taps. Unlike bilinear interpolation, a Gaussian of about a pixel
/// hides the pixel grid: the samples of a point-symmetric corner are point-symmetric
/// about the centre whatever its phase, so the estimate has no phase-dependent bias.
struct Resampler {
    sigma: f64,
    /// Samples reach `r` steps each side of the centre.
    r: usize,
    /// Kernel radius, pixels.
    k: usize,
    taps_x: Vec<f64>,
    taps_y: Vec<f64>,
    /// Outputs per row, rounded up to whole blocks of [`Resampler::BLOCK`].
    width: usize,
    /// One image row of the kernel's span, as `f64`, zero beyond the span.
    line: Vec<f64>,
    /// The image filtered along rows, `width` per row.
    rows: Vec<f64>,
    out: Vec<f64>,
}

impl Resampler {
    fn new(sigma: f64, r: usize) -> Self {
        let k = (3.0 * sigma).ceil().max(1.0) as usize;
        let side = 2 * r + 1;
        let width = side.div_ceil(Self::BLOCK) * Self::BLOCK;
        Self {
            sigma,
            r,
            k,
            taps_x: vec![0.0; 2 * k + 2],
            taps_y: vec![0.0; 2 * k + 2],
            width,
            line: vec![0.0; width + 2 * k + 1],
            rows: vec![0.0; (side + 2 * k + 1) * width],
            out: vec![0.0; side * side],
        }
    }

    /// Outputs computed together, their sums held in registers.
    const BLOCK: usize = 8;

    /// Taps for pixels `floor(c) - k ..= floor(c) + k + 1` around position `c`.
    fn taps(sigma: f64, k: usize, phase: f64, taps: &mut [f64]) {
        let inv = 1.0 / (2.0 * sigma * sigma);
        let mut total = 0.0;
        for (t, tap) in taps.iter_mut().enumerate() {
            let d = t as f64 - k as f64 - phase;
            *tap = (-d * d * inv).exp();
            total += *tap;
        }
        taps.iter_mut().for_each(|tap| *tap /= total);
    }

    /// The `(2 r + 1)^2` samples around `centre`, row after row; `None` when the
    /// kernel would leave the image.
    #[inline(always)]
    fn sample(&mut self, gray: &Gray, centre: Point2<f64>) -> Option<&[f64]> {
        if !(centre.x.is_finite() && centre.y.is_finite()) {
            return None;
        }
        let (r, k) = (self.r as isize, self.k as isize);
        let (nx, ny) = (centre.x.floor() as isize, centre.y.floor() as isize);
        let (x0, y0) = (nx - r - k, ny - r - k);
        let side = 2 * self.r + 1;
        let span = side + 2 * self.k + 1;
        if x0 < 0 || y0 < 0 || x0 as usize + span > gray.width || y0 as usize + span > gray.height {
            return None;
        }
        Self::taps(self.sigma, self.k, centre.x - nx as f64, &mut self.taps_x);
        Self::taps(self.sigma, self.k, centre.y - ny as f64, &mut self.taps_y);
        let (x0, y0) = (x0 as usize, y0 as usize);
        // Each output accumulates its taps in ascending order, as a dot product
        // would, but a block of outputs at a time so that the loops vectorize.
        const B: usize = Resampler::BLOCK;
        let width = self.width;
        for (row, filtered) in self.rows.chunks_exact_mut(width).enumerate() {
            let pixels = &gray.data[(y0 + row) * gray.width + x0..][..span];
            for (value, &p) in self.line.iter_mut().zip(pixels) {
                *value = p as f64;
            }
            for (block, out) in filtered.chunks_exact_mut(B).enumerate() {
                let mut sums = [0.0; B];
                for (t, &tap) in self.taps_x.iter().enumerate() {
                    let line = &self.line[block * B + t..][..B];
                    for (sum, &p) in sums.iter_mut().zip(line) {
                        *sum += p * tap;
                    }
                }
                out.copy_from_slice(&sums);
            }
        }
        for (row, out_row) in self.out.chunks_exact_mut(side).enumerate() {
            for (block, out) in out_row.chunks_mut(B).enumerate() {
                let mut sums = [0.0; B];
                for (t, &tap) in self.taps_y.iter().enumerate() {
                    let above = &self.rows[(row + t) * width + block * B..][..B];
                    for (sum, &p) in sums.iter_mut().zip(above) {
                        *sum += p * tap;
                    }
                }
                out.copy_from_slice(&sums[..out.len()]);
            }
        }
        Some(&self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SS: usize = 32;

    /// An anti-aliased saddle at `(cx, cy)` with axes rotated by `angle`.
    fn saddle(width: usize, cx: f64, cy: f64, angle: f64) -> Gray {
        let (s, c) = angle.sin_cos();
        let mut data = Vec::with_capacity(width * width);
        for y in 0..width {
            for x in 0..width {
                let mut sum = 0.0f64;
                for sy in 0..SS {
                    for sx in 0..SS {
                        let dx = x as f64 - 0.5 + (sx as f64 + 0.5) / SS as f64 - cx;
                        let dy = y as f64 - 0.5 + (sy as f64 + 0.5) / SS as f64 - cy;
                        let u = c * dx + s * dy;
                        let v = -s * dx + c * dy;
                        sum += if u * v > 0.0 { 40.0 } else { 210.0 };
                    }
                }
                data.push((sum / (SS * SS) as f64).round() as u8);
            }
        }
        Gray {
            width,
            height: width,
            data,
        }
    }

    #[test]
    fn finds_a_sharp_saddle_to_two_hundredths() {
        let window = SubpixelWindow::default();
        for (cx, cy, angle) in [(20.3, 19.7, 0.3), (21.55, 20.1, -0.7), (20.0, 20.0, 0.0)] {
            let gray = saddle(41, cx, cy, angle);
            let found = refine_corner(&gray, Point2::new(20.0, 20.0), 10, &window).unwrap();
            let error = (found - Point2::new(cx, cy)).norm();
            assert!(error < 0.02, "({cx}, {cy}): error {error}");
        }
    }

    #[test]
    fn window_follows_square_size() {
        let window = SubpixelWindow::default();
        assert_eq!(window.half_size(3.0), 2);
        assert_eq!(window.half_size(24.0), 7);
        assert_eq!(window.half_size(500.0), 12);
        assert_eq!(window.half_size(f64::NAN), 2);
    }

    #[test]
    fn flat_or_outside_windows_fail() {
        let window = SubpixelWindow::default();
        let flat = Gray {
            width: 30,
            height: 30,
            data: vec![128; 900],
        };
        assert_eq!(
            refine_corner(&flat, Point2::new(15.0, 15.0), 4, &window),
            None
        );
        let gray = saddle(41, 20.0, 20.0, 0.2);
        assert_eq!(
            refine_corner(&gray, Point2::new(2.0, 20.0), 4, &window),
            None
        );
    }
}
