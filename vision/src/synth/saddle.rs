//! Saddle-point fit: a measuring instrument for chessboard corners, used to check that
//! rendered images agree with their ground truth.

use nalgebra::{Matrix2, Matrix6, Point2, Vector2, Vector6};

use crate::image::{Image, Samples};

/// Parameters of [`saddle_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SaddleFit {
    /// Standard deviation of the Gaussian smoothing applied before fitting, pixels: it
    /// makes the corner's neighbourhood a smooth surface a quadratic can follow.
    pub smoothing_sigma: f64,
    /// Standard deviation of the Gaussian weights of the fit around the current
    /// estimate, pixels (pixels within three of them take part).
    pub window_sigma: f64,
    /// Largest distance the saddle may lie from the initial guess, pixels.
    pub max_shift: f64,
    /// Iterations stop once a step is shorter than this, pixels.
    pub tolerance: f64,
    /// Iterations at most.
    pub max_iterations: usize,
}

impl Default for SaddleFit {
    fn default() -> Self {
        Self {
            smoothing_sigma: 2.0,
            window_sigma: 2.5,
            max_shift: 2.0,
            tolerance: 1e-5,
            max_iterations: 50,
        }
    }
}

/// Sub-pixel position of the chessboard corner (intensity saddle) near `initial`, in
/// pixel coordinates with pixel centres at integers.
///
/// Works on the image convolved with a Gaussian of `smoothing_sigma`, evaluated
/// directly at any continuous position (the Gaussian-weighted sum of the pixels there,
/// so no interpolation is involved). It repeatedly samples that smooth surface on a
/// grid of one-pixel steps centred on the current estimate, fits
/// `I(dx, dy) = a dx^2 + b dx dy + c dy^2 + d dx + e dy + f` by Gaussian-weighted least
/// squares and moves to the quadratic's stationary point. Because the grid is
/// symmetric about the estimate, the iteration stops exactly where the image is
/// point-symmetric: at the crossing of two straight edges, whatever their angles.
/// Multi-channel images are averaged over their channels. `None` when the patch leaves
/// the image, the surface is not a saddle, or the estimate runs further than
/// `max_shift` from `initial`.
pub fn saddle_point(image: &Image, initial: &Point2<f64>, fit: &SaddleFit) -> Option<Point2<f64>> {
    let Samples::U8(samples) = &image.samples else {
        return None;
    };
    if !(initial.x.is_finite() && initial.y.is_finite())
        || image.channels == 0
        || !(fit.smoothing_sigma > 0.0 && fit.window_sigma > 0.0)
    {
        return None;
    }
    let grid_radius = (3.0 * fit.window_sigma).floor() as isize;
    let kernel_radius = (4.0 * fit.smoothing_sigma).ceil() as isize;
    let half = grid_radius + kernel_radius + fit.max_shift.ceil() as isize + 1;
    let (left, top) = (
        initial.x.round() as isize - half,
        initial.y.round() as isize - half,
    );
    let size = (2 * half + 1) as usize;
    if left < 0
        || top < 0
        || left as usize + size > image.width
        || top as usize + size > image.height
    {
        return None;
    }
    let channels = image.channels;
    let mut patch = vec![0.0f64; size * size];
    for (r, row) in patch.chunks_mut(size).enumerate() {
        let start = ((top as usize + r) * image.width + left as usize) * channels;
        for (c, value) in row.iter_mut().enumerate() {
            let pixel = &samples[start + c * channels..start + (c + 1) * channels];
            *value = pixel.iter().map(|&s| f64::from(s)).sum::<f64>() / channels as f64;
        }
    }
    let smoothed = Smoothed {
        patch: &patch,
        size,
        origin: (left as f64, top as f64),
        sigma: fit.smoothing_sigma,
        radius: kernel_radius,
    };

    let mut estimate = *initial;
    for _ in 0..fit.max_iterations {
        let step = saddle_step(&smoothed, &estimate, grid_radius, fit.window_sigma)?;
        estimate += step;
        if (estimate - initial).norm() > fit.max_shift {
            return None;
        }
        if step.norm() < fit.tolerance {
            return Some(estimate);
        }
    }
    None
}

/// A patch of the image seen through a Gaussian, at continuous positions.
struct Smoothed<'a> {
    patch: &'a [f64],
    size: usize,
    /// Image position of the patch's first pixel.
    origin: (f64, f64),
    sigma: f64,
    radius: isize,
}

impl Smoothed<'_> {
    /// The Gaussian-weighted mean of the pixels around image position `(x, y)`.
    fn at(&self, x: f64, y: f64) -> f64 {
        let (px, py) = (x - self.origin.0, y - self.origin.1);
        let (cx, cy) = (px.round() as isize, py.round() as isize);
        let inv = 1.0 / (2.0 * self.sigma * self.sigma);
        let weights = |centre: isize, at: f64| {
            (-self.radius..=self.radius).map(move |k| {
                let d = (centre + k) as f64 - at;
                ((centre + k) as usize, (-d * d * inv).exp())
            })
        };
        let (mut sum, mut total) = (0.0, 0.0);
        for (row, wy) in weights(cy, py) {
            let line = &self.patch[row * self.size..(row + 1) * self.size];
            for (col, wx) in weights(cx, px) {
                sum += wx * wy * line[col];
                total += wx * wy;
            }
        }
        sum / total
    }
}

/// One weighted quadratic fit on the grid of one-pixel steps around `estimate`; the
/// step to its stationary point, or `None` when that is not a saddle.
fn saddle_step(
    smoothed: &Smoothed,
    estimate: &Point2<f64>,
    grid_radius: isize,
    window_sigma: f64,
) -> Option<Vector2<f64>> {
    let radius2 = (grid_radius * grid_radius) as f64;
    let inv_two_s2 = 1.0 / (2.0 * window_sigma * window_sigma);
    let mut normal = Matrix6::<f64>::zeros();
    let mut rhs = Vector6::<f64>::zeros();
    for j in -grid_radius..=grid_radius {
        for i in -grid_radius..=grid_radius {
            let (dx, dy) = (i as f64, j as f64);
            let d2 = dx * dx + dy * dy;
            if d2 > radius2 {
                continue;
            }
            let weight = (-d2 * inv_two_s2).exp();
            let value = smoothed.at(estimate.x + dx, estimate.y + dy);
            let basis = Vector6::new(dx * dx, dx * dy, dy * dy, dx, dy, 1.0);
            normal += basis * basis.transpose() * weight;
            rhs += basis * (value * weight);
        }
    }
    let q = normal.cholesky()?.solve(&rhs);
    let hessian = Matrix2::new(2.0 * q[0], q[1], q[1], 2.0 * q[2]);
    if hessian.determinant() >= 0.0 {
        return None;
    }
    Some(-(hessian.try_inverse()? * Vector2::new(q[3], q[4])))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An ideal X-junction at `corner`, edges at `angle_a` and `angle_b`, each pixel's
    /// value the average of 16x16 samples.
    fn junction(corner: Point2<f64>, angle_a: f64, angle_b: f64) -> Image {
        const N: usize = 64;
        let (w, h) = (72usize, 64usize);
        let (na, nb) = (
            Vector2::new(-angle_a.sin(), angle_a.cos()),
            Vector2::new(-angle_b.sin(), angle_b.cos()),
        );
        let mut samples = vec![0u8; w * h];
        for (i, s) in samples.iter_mut().enumerate() {
            let (u, v) = ((i % w) as f64, (i / w) as f64);
            let mut sum = 0.0f64;
            for a in 0..N {
                for b in 0..N {
                    let p = Vector2::new(
                        u - 0.5 + (a as f64 + 0.5) / N as f64 - corner.x,
                        v - 0.5 + (b as f64 + 0.5) / N as f64 - corner.y,
                    );
                    let white = (p.dot(&na) > 0.0) == (p.dot(&nb) > 0.0);
                    sum += if white { 230.0 } else { 20.0 };
                }
            }
            *s = (sum / (N * N) as f64).round() as u8;
        }
        Image::new(w, h, 1, Samples::U8(samples)).unwrap()
    }

    #[test]
    fn finds_skewed_junctions_to_a_hundredth_of_a_pixel() {
        for (corner, a, b) in [
            (Point2::new(35.3, 31.8), 0.2, 1.9),
            (Point2::new(36.0, 32.0), 0.0, std::f64::consts::FRAC_PI_2),
            (Point2::new(34.71, 30.45), -0.5, 0.6),
        ] {
            let image = junction(corner, a, b);
            let guess = Point2::new(corner.x.round() + 0.4, corner.y.round() - 0.3);
            let found = saddle_point(&image, &guess, &SaddleFit::default()).unwrap();
            assert!((found - corner).norm() < 0.012, "{found} vs {corner}");
        }
    }

    #[test]
    fn rejects_flat_patches_and_borders() {
        let flat = Image::new(30, 30, 1, Samples::U8(vec![128; 900])).unwrap();
        assert!(saddle_point(&flat, &Point2::new(15.0, 15.0), &SaddleFit::default()).is_none());
        let image = junction(Point2::new(35.3, 31.8), 0.2, 1.9);
        assert!(saddle_point(&image, &Point2::new(2.0, 2.0), &SaddleFit::default()).is_none());
    }
}
