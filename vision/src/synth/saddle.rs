//! Saddle-point fit: a measuring instrument for chessboard corners, used to check that
//! rendered images agree with their ground truth.

use nalgebra::{Matrix2, Matrix6, Point2, Vector2, Vector6};

use crate::camera::CameraModel;
use crate::image::{Image, Samples};

/// Parameters of [`saddle_point`] and [`saddle_point_through_lens`].
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

impl SaddleFit {
    fn is_valid(&self) -> bool {
        self.smoothing_sigma > 0.0 && self.window_sigma > 0.0
    }

    /// Radius of the fit's grid, in one-pixel steps.
    fn grid_radius(&self) -> isize {
        (3.0 * self.window_sigma).floor() as isize
    }

    /// Radius of the smoothing kernel, pixels.
    fn kernel_radius(&self) -> isize {
        (4.0 * self.smoothing_sigma).ceil() as isize
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
/// Where a lens curves the edges within the fit's reach, use
/// [`saddle_point_through_lens`]. Multi-channel images are averaged over their
/// channels. `None` when the patch leaves the image, the surface is not a saddle, or
/// the estimate runs further than `max_shift` from `initial`.
pub fn saddle_point(image: &Image, initial: &Point2<f64>, fit: &SaddleFit) -> Option<Point2<f64>> {
    if !fit.is_valid() {
        return None;
    }
    let grid_radius = fit.grid_radius();
    let kernel_radius = fit.kernel_radius();
    let patch = Patch::around(
        image,
        initial,
        grid_radius + kernel_radius + fit.max_shift.ceil() as isize + 1,
    )?;
    let smoothed = Smoothed {
        patch: &patch,
        sigma: fit.smoothing_sigma,
        radius: kernel_radius,
    };
    let mut estimate = *initial;
    for _ in 0..fit.max_iterations {
        let step = saddle_step(
            |dx, dy| smoothed.at(estimate.x + dx, estimate.y + dy),
            grid_radius,
            fit.window_sigma,
        )?;
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

/// Sub-pixel position of the chessboard corner near `initial` in an image taken
/// through `camera`'s lens, in pixel coordinates with pixel centres at integers.
///
/// A lens curves the board's edges, and a fit that assumes straight edges through the
/// corner is pulled towards their concave sides. This fit works in the corner's
/// locally rectified frame instead: every pixel of the patch is mapped through the
/// lens to the ideal pinhole image (where the edges of a planar board are straight),
/// then by the affine map that makes that image agree with the camera's to first order
/// at the current estimate (so the frame is in pixels, with the camera's resolution
/// there). Smoothing (a Gaussian of `smoothing_sigma` in that frame, each pixel
/// weighted by the area it covers there) and the quadratic fit of [`saddle_point`]
/// both happen in that frame, where the junction is point-symmetric again; each step
/// is mapped back through the lens. `None` as for [`saddle_point`], or when part of
/// the patch lies beyond the lens model's invertible range.
pub fn saddle_point_through_lens(
    image: &Image,
    camera: &CameraModel,
    initial: &Point2<f64>,
    fit: &SaddleFit,
) -> Option<Point2<f64>> {
    if !fit.is_valid() {
        return None;
    }
    let grid_radius = fit.grid_radius();
    // A sample's pixels are looked for in a box around it that is wider than the
    // kernel, so that the kernel's disc in the rectified frame stays inside the box
    // however the lens stretches the neighbourhood.
    let reach = fit.kernel_radius() + 2 + fit.kernel_radius() / 4;
    let patch = Patch::around(
        image,
        initial,
        grid_radius + reach + fit.max_shift.ceil() as isize + 1,
    )?;
    let lens = LensPatch::new(&patch, camera)?;
    let mut ray = camera.unproject(initial)?.xy();
    let mut estimate = *initial;
    for _ in 0..fit.max_iterations {
        let pixel_from_ray = pixel_jacobian(camera, &ray);
        let ray_from_pixel = pixel_from_ray.try_inverse()?;
        let local: Vec<Vector2<f64>> = lens
            .rays
            .iter()
            .map(|r| pixel_from_ray * (r - ray))
            .collect();
        let smoothed = RectifiedSmoothed {
            lens: &lens,
            local: &local,
            centre: (estimate.x.round() as isize, estimate.y.round() as isize),
            offset: estimate - Point2::new(estimate.x.round(), estimate.y.round()),
            reach,
            sigma: fit.smoothing_sigma,
        };
        let step = saddle_step(|dx, dy| smoothed.at(dx, dy), grid_radius, fit.window_sigma)?;
        ray += ray_from_pixel * step;
        estimate = camera
            .intrinsics
            .pixel_from_normalized(&camera.distortion.distort(&ray));
        if !(estimate - initial).norm().is_finite() || (estimate - initial).norm() > fit.max_shift {
            return None;
        }
        if step.norm() < fit.tolerance {
            return Some(estimate);
        }
    }
    None
}

/// Derivative of the pixel position with respect to the undistorted normalized
/// coordinate, at `ray`.
fn pixel_jacobian(camera: &CameraModel, ray: &Vector2<f64>) -> Matrix2<f64> {
    let focal = Matrix2::new(camera.intrinsics.fx, 0.0, 0.0, camera.intrinsics.fy);
    focal * camera.distortion.distort_jacobian_point(ray)
}

/// A square patch of an image, channels averaged.
struct Patch {
    values: Vec<f64>,
    size: usize,
    /// Image position of the patch's first pixel.
    left: isize,
    top: isize,
}

impl Patch {
    /// The patch of `2 half + 1` pixels a side centred on the pixel nearest `centre`;
    /// `None` when it leaves the image or the image is not 8-bit.
    fn around(image: &Image, centre: &Point2<f64>, half: isize) -> Option<Self> {
        let Samples::U8(samples) = &image.samples else {
            return None;
        };
        if !(centre.x.is_finite() && centre.y.is_finite()) || image.channels == 0 {
            return None;
        }
        let (left, top) = (
            centre.x.round() as isize - half,
            centre.y.round() as isize - half,
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
        let mut values = vec![0.0f64; size * size];
        for (r, row) in values.chunks_mut(size).enumerate() {
            let start = ((top as usize + r) * image.width + left as usize) * channels;
            for (c, value) in row.iter_mut().enumerate() {
                let pixel = samples.get(start + c * channels..start + (c + 1) * channels)?;
                *value = pixel.iter().map(|&s| f64::from(s)).sum::<f64>() / channels as f64;
            }
        }
        Some(Self {
            values,
            size,
            left,
            top,
        })
    }
}

/// A patch of the image seen through a Gaussian, at continuous positions.
struct Smoothed<'a> {
    patch: &'a Patch,
    sigma: f64,
    radius: isize,
}

impl Smoothed<'_> {
    /// The Gaussian-weighted mean of the pixels around image position `(x, y)`.
    fn at(&self, x: f64, y: f64) -> f64 {
        let (px, py) = (x - self.patch.left as f64, y - self.patch.top as f64);
        let (cx, cy) = (px.round() as isize, py.round() as isize);
        let inv = 1.0 / (2.0 * self.sigma * self.sigma);
        let weights = |centre: isize, at: f64| {
            (-self.radius..=self.radius).map(move |k| {
                let d = (centre + k) as f64 - at;
                ((centre + k) as usize, (-d * d * inv).exp())
            })
        };
        let size = self.patch.size;
        let (mut sum, mut total) = (0.0, 0.0);
        for (row, wy) in weights(cy, py) {
            let line = &self.patch.values[row * size..(row + 1) * size];
            for (col, wx) in weights(cx, px) {
                sum += wx * wy * line[col];
                total += wx * wy;
            }
        }
        sum / total
    }
}

/// A patch with every pixel's ray through the lens and the area it covers.
struct LensPatch<'a> {
    patch: &'a Patch,
    /// Undistorted normalized coordinate of each pixel, row-major.
    rays: Vec<Vector2<f64>>,
    /// Each pixel's area in the ideal pinhole image, up to a common factor:
    /// the inverse of the lens map's Jacobian determinant there.
    areas: Vec<f64>,
}

impl<'a> LensPatch<'a> {
    fn new(patch: &'a Patch, camera: &CameraModel) -> Option<Self> {
        let mut rays = Vec::with_capacity(patch.values.len());
        let mut areas = Vec::with_capacity(patch.values.len());
        for r in 0..patch.size {
            for c in 0..patch.size {
                let pixel = Point2::new(
                    (patch.left + c as isize) as f64,
                    (patch.top + r as isize) as f64,
                );
                let ray = camera.unproject(&pixel)?.xy();
                let determinant = pixel_jacobian(camera, &ray).determinant();
                if determinant.is_nan() || determinant <= 0.0 {
                    return None;
                }
                rays.push(ray);
                areas.push(1.0 / determinant);
            }
        }
        Some(Self { patch, rays, areas })
    }
}

/// The patch smoothed by a Gaussian in the rectified frame around one estimate.
struct RectifiedSmoothed<'a> {
    lens: &'a LensPatch<'a>,
    /// Each pixel's position in the rectified frame (the estimate at the origin).
    local: &'a [Vector2<f64>],
    /// Image pixel nearest the estimate.
    centre: (isize, isize),
    /// The estimate minus that pixel.
    offset: Vector2<f64>,
    reach: isize,
    sigma: f64,
}

impl RectifiedSmoothed<'_> {
    /// The area-weighted Gaussian mean of the pixels around rectified position
    /// `(x, y)`, over the pixels within four standard deviations of it.
    fn at(&self, x: f64, y: f64) -> f64 {
        let patch = self.lens.patch;
        let at = Vector2::new(x, y);
        let cut = (4.0 * self.sigma).powi(2);
        let inv = 1.0 / (2.0 * self.sigma * self.sigma);
        // The rectified frame agrees with the image to first order at the estimate, so
        // the pixels near `at` are near the estimate plus `at`.
        let near = at + self.offset;
        let col0 = self.centre.0 + near.x.round() as isize - patch.left;
        let row0 = self.centre.1 + near.y.round() as isize - patch.top;
        let (mut sum, mut total) = (0.0, 0.0);
        for row in (row0 - self.reach)..=(row0 + self.reach) {
            for col in (col0 - self.reach)..=(col0 + self.reach) {
                if row < 0 || col < 0 || row as usize >= patch.size || col as usize >= patch.size {
                    continue;
                }
                let index = row as usize * patch.size + col as usize;
                let d2 = (self.local[index] - at).norm_squared();
                if d2 > cut {
                    continue;
                }
                let weight = (-d2 * inv).exp() * self.lens.areas[index];
                sum += weight * patch.values[index];
                total += weight;
            }
        }
        sum / total
    }
}

/// One weighted quadratic fit of `value` on the grid of one-pixel steps around the
/// current estimate (`value(dx, dy)` is the smooth surface at that offset); the step
/// to the quadratic's stationary point, or `None` when that is not a saddle.
fn saddle_step(
    value: impl Fn(f64, f64) -> f64,
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
            let basis = Vector6::new(dx * dx, dx * dy, dy * dy, dx, dy, 1.0);
            normal += basis * basis.transpose() * weight;
            rhs += basis * (value(dx, dy) * weight);
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
    use crate::camera::{Distortion, Intrinsics};

    /// A 72x64 image of an ideal X-junction, each pixel's value the average of `n x n`
    /// samples: `frame` maps an image position to the plane where the junction's edges
    /// are straight, crossing at `corner` at angles `angle_a` and `angle_b` there.
    fn junction_in(
        frame: impl Fn(Point2<f64>) -> Vector2<f64>,
        corner: Vector2<f64>,
        angle_a: f64,
        angle_b: f64,
        n: usize,
    ) -> Image {
        let (w, h) = (72usize, 64usize);
        let (na, nb) = (
            Vector2::new(-angle_a.sin(), angle_a.cos()),
            Vector2::new(-angle_b.sin(), angle_b.cos()),
        );
        let mut samples = vec![0u8; w * h];
        for (i, s) in samples.iter_mut().enumerate() {
            let (u, v) = ((i % w) as f64, (i / w) as f64);
            let mut sum = 0.0f64;
            for a in 0..n {
                for b in 0..n {
                    let p = frame(Point2::new(
                        u - 0.5 + (a as f64 + 0.5) / n as f64,
                        v - 0.5 + (b as f64 + 0.5) / n as f64,
                    )) - corner;
                    let white = (p.dot(&na) > 0.0) == (p.dot(&nb) > 0.0);
                    sum += if white { 230.0 } else { 20.0 };
                }
            }
            *s = (sum / (n * n) as f64).round() as u8;
        }
        Image::new(w, h, 1, Samples::U8(samples)).unwrap()
    }

    /// An ideal X-junction with straight edges at `corner`, 64x64 samples a pixel.
    fn junction(corner: Point2<f64>, angle_a: f64, angle_b: f64) -> Image {
        junction_in(|p| p.coords, corner.coords, angle_a, angle_b, 64)
    }

    /// A fisheye whose image of 72x64 pixels lies 60-65 degrees off its axis, where a
    /// board's edges curve strongly.
    fn fisheye() -> CameraModel {
        CameraModel {
            width: 72,
            height: 64,
            intrinsics: Intrinsics {
                fx: 300.0,
                fy: 300.0,
                cx: -240.0,
                cy: -150.0,
            },
            distortion: Distortion::Equidistant {
                coeffs: [0.05, -0.02, 0.005, 0.0],
            },
        }
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
    fn finds_junctions_with_curved_edges_through_the_lens() {
        let camera = fisheye();
        let fit = SaddleFit::default();
        let (mut in_image, mut through_lens) = (0.0f64, 0.0f64);
        for (corner, a, b) in [
            (Point2::new(35.3, 31.8), 0.2, 1.9),
            (Point2::new(36.0, 32.0), 0.7, 2.4),
            (Point2::new(34.71, 30.45), -0.5, 0.6),
        ] {
            let ray = camera.unproject(&corner).unwrap().xy();
            let image = junction_in(|p| camera.unproject(&p).unwrap().xy(), ray, a, b, 16);
            let guess = Point2::new(corner.x.round() + 0.4, corner.y.round() - 0.3);
            let found = saddle_point_through_lens(&image, &camera, &guess, &fit).unwrap();
            through_lens = through_lens.max((found - corner).norm());
            let found = saddle_point(&image, &guess, &fit).unwrap();
            in_image = in_image.max((found - corner).norm());
        }
        println!("largest error {through_lens} px through the lens, {in_image} px in the image");
        assert!(through_lens < 0.012, "{through_lens} px");
        assert!(in_image > 2.0 * through_lens, "{in_image} px");
    }

    #[test]
    fn rejects_flat_patches_and_borders() {
        let flat = Image::new(30, 30, 1, Samples::U8(vec![128; 900])).unwrap();
        assert!(saddle_point(&flat, &Point2::new(15.0, 15.0), &SaddleFit::default()).is_none());
        let image = junction(Point2::new(35.3, 31.8), 0.2, 1.9);
        assert!(saddle_point(&image, &Point2::new(2.0, 2.0), &SaddleFit::default()).is_none());
        let camera = fisheye();
        let guess = Point2::new(2.0, 2.0);
        assert!(
            saddle_point_through_lens(&image, &camera, &guess, &SaddleFit::default()).is_none()
        );
    }
}
