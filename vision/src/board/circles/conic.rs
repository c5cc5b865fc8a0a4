//! A circle's image located from its grey-level gradients: every pixel near the edge
//! gives the line through it across its gradient, a tangent of the edge, and the dual
//! conic (the ellipse as the envelope of its tangents) is fitted to those lines by
//! weighted linear least squares (Ouellet and Hébert, "Precise ellipse estimation
//! without contour point extraction", 2009). No edge is thresholded or traced, so blur
//! and noise only spread the weights.
//!
//! Under perspective the centre of the image ellipse is not the image of the circle's
//! centre. That image is the pole, with respect to the ellipse, of the image of the
//! plane's line at infinity (pole and polar survive any projective map, and the centre
//! of a circle is the pole of the line at infinity): [`Ellipse::pole`], with the
//! vanishing line from the grid's homography.

use nalgebra::{Matrix2, Matrix3, Matrix5, Point2, Vector2, Vector3, Vector5};

use crate::board::Gray;

/// Gradients are taken over the annulus between these fractions of the ellipse's size
/// (the edge of a sharp circle lies at 1).
const INNER: f64 = 0.4;
/// Outer bound of the annulus: short of the nearest neighbour of a grid whose circles
/// are as large as 0.7 of their spacing.
const OUTER: f64 = 1.7;
/// Fewer weighted pixels than this do not determine an ellipse.
const MIN_PIXELS: usize = 12;

/// An ellipse in the image, as its dual conic: lines `l` tangent to it satisfy
/// `l^T C* l = 0`. Pixel centres at integer coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Ellipse {
    dual: Matrix3<f64>,
}

impl Ellipse {
    /// The ellipse's own centre, pixels.
    pub fn centre(&self) -> Option<Point2<f64>> {
        self.pole(&Vector3::new(0.0, 0.0, 1.0))
    }

    /// The pole of `line` (`a x + b y + c = 0`): the image of a circle's centre when
    /// `line` is its plane's vanishing line.
    pub fn pole(&self, line: &Vector3<f64>) -> Option<Point2<f64>> {
        let p = self.dual * line;
        (p.z.abs() > f64::EPSILON * p.xy().norm()).then(|| Point2::new(p.x / p.z, p.y / p.z))
    }

    /// The quadratic form of the ellipse around its centre: `(p - c)^T M (p - c) = 1`
    /// on the ellipse. `None` when the conic is not a real ellipse.
    pub fn shape(&self) -> Option<(Point2<f64>, Matrix2<f64>)> {
        let conic = self.dual.try_inverse()?;
        let m = conic.fixed_view::<2, 2>(0, 0).into_owned();
        let centre = self.centre()?;
        let c = Vector2::new(centre.x, centre.y);
        let level = c.dot(&(m * c)) - conic[(2, 2)];
        let m = m / level;
        let eigen = m.symmetric_eigen();
        (eigen.eigenvalues.min() > 0.0).then_some((centre, m))
    }
}

/// Tangent lines gathered for a weighted least-squares fit of a dual conic, in
/// coordinates centred at `origin` and divided by `scale` (for conditioning).
pub(super) struct TangentFit {
    origin: Point2<f64>,
    scale: f64,
    normal: Matrix5<f64>,
    rhs: Vector5<f64>,
    lines: usize,
}

impl TangentFit {
    /// An empty fit around `origin`, at the scale of the ellipse (`scale` pixels).
    pub fn new(origin: Point2<f64>, scale: f64) -> Self {
        Self {
            origin,
            scale,
            normal: Matrix5::zeros(),
            rhs: Vector5::zeros(),
            lines: 0,
        }
    }

    /// Adds the line through `point` across the unit `normal`, with `weight`.
    pub fn add(&mut self, point: Point2<f64>, normal: Vector2<f64>, weight: f64) {
        let p = (point - self.origin) / self.scale;
        let l = Vector3::new(normal.x, normal.y, -normal.dot(&p));
        // l^T C* l = 0 with C* = [A B D; B C E; D E -1].
        let row = Vector5::new(
            l.x * l.x,
            2.0 * l.x * l.y,
            l.y * l.y,
            2.0 * l.x * l.z,
            2.0 * l.y * l.z,
        );
        self.normal += row * row.transpose() * weight;
        self.rhs += row * (l.z * l.z) * weight;
        self.lines += 1;
    }

    /// The ellipse the lines are tangent to; `None` with too few lines or no ellipse.
    pub fn solve(&self) -> Option<Ellipse> {
        if self.lines < MIN_PIXELS {
            return None;
        }
        let x = self.normal.cholesky()?.solve(&self.rhs);
        let normalized = Matrix3::new(x[0], x[1], x[3], x[1], x[2], x[4], x[3], x[4], -1.0);
        // Back to pixels: p = T q with T = [s 0 ox; 0 s oy; 0 0 1]; C* = T C*' T^T.
        let (s, o) = (self.scale, self.origin);
        let t = Matrix3::new(s, 0.0, o.x, 0.0, s, o.y, 0.0, 0.0, 1.0);
        let ellipse = Ellipse {
            dual: t * normalized * t.transpose(),
        };
        ellipse.shape().map(|_| ellipse)
    }
}

/// The ellipse fitted to the gradients of `gray` around a dark circle roughly at
/// `centre` whose shape is `(p - centre)^T shape (p - centre) = 1`; `None` when too few
/// pixels see its edge or the fit is not an ellipse.
pub(super) fn fit_ellipse(
    gray: &Gray,
    centre: Point2<f64>,
    shape: &Matrix2<f64>,
) -> Option<Ellipse> {
    let inverse = shape.try_inverse()?;
    // Half extents of the outer ellipse of the annulus along x and y.
    let reach_x = OUTER * inverse[(0, 0)].max(0.0).sqrt();
    let reach_y = OUTER * inverse[(1, 1)].max(0.0).sqrt();
    let (width, height) = (gray.width as f64, gray.height as f64);
    let x0 = (centre.x - reach_x).floor().max(1.0);
    let x1 = (centre.x + reach_x).ceil().min(width - 2.0);
    let y0 = (centre.y - reach_y).floor().max(1.0);
    let y1 = (centre.y + reach_y).ceil().min(height - 2.0);
    if !(x0 <= x1 && y0 <= y1) {
        return None;
    }
    let mut fit = TangentFit::new(centre, reach_x.max(reach_y) / OUTER);
    let stride = gray.width;
    let at = |x: usize, y: usize| f64::from(gray.data[y * stride + x]);
    for y in y0 as usize..=y1 as usize {
        for x in x0 as usize..=x1 as usize {
            let d = Vector2::new(x as f64 - centre.x, y as f64 - centre.y);
            let rho2 = d.dot(&(shape * d));
            if !(INNER * INNER..=OUTER * OUTER).contains(&rho2) {
                continue;
            }
            // Scharr derivatives.
            let gx = (3.0 * (at(x + 1, y - 1) - at(x - 1, y - 1))
                + 10.0 * (at(x + 1, y) - at(x - 1, y))
                + 3.0 * (at(x + 1, y + 1) - at(x - 1, y + 1)))
                / 32.0;
            let gy = (3.0 * (at(x - 1, y + 1) - at(x - 1, y - 1))
                + 10.0 * (at(x, y + 1) - at(x, y - 1))
                + 3.0 * (at(x + 1, y + 1) - at(x + 1, y - 1)))
                / 32.0;
            let g = Vector2::new(gx, gy);
            let magnitude2 = g.norm_squared();
            // A dark circle on a light board: grey rises outwards.
            if magnitude2 == 0.0 || g.dot(&d) <= 0.0 {
                continue;
            }
            let point = Point2::new(x as f64, y as f64);
            fit.add(point, g / magnitude2.sqrt(), magnitude2);
        }
    }
    fit.solve()
}

/// The ellipse refitted around its own centre and shape: the first fit's window comes
/// from the blob, which thresholding and blur make larger or smaller than the edge.
pub(super) fn refit(gray: &Gray, ellipse: &Ellipse) -> Option<Ellipse> {
    let (centre, shape) = ellipse.shape()?;
    fit_ellipse(gray, centre, &shape)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dark ellipse (semi-axes `a`, `b`, rotated by `angle`) on a light background,
    /// each pixel the share of 16x16 samples inside.
    fn ellipse_image(centre: Point2<f64>, a: f64, b: f64, angle: f64) -> Gray {
        let (width, height) = (80, 70);
        let (s, c) = angle.sin_cos();
        let mut data = vec![0u8; width * height];
        for y in 0..height {
            for x in 0..width {
                let mut inside = 0;
                for k in 0..256 {
                    let px = x as f64 - 0.5 + ((k % 16) as f64 + 0.5) / 16.0 - centre.x;
                    let py = y as f64 - 0.5 + ((k / 16) as f64 + 0.5) / 16.0 - centre.y;
                    let (u, v) = (c * px + s * py, -s * px + c * py);
                    if (u / a).powi(2) + (v / b).powi(2) <= 1.0 {
                        inside += 1;
                    }
                }
                data[y * width + x] = (220.0 - 190.0 * inside as f64 / 256.0).round() as u8;
            }
        }
        Gray {
            width,
            height,
            data,
        }
    }

    #[test]
    fn a_sharp_ellipse_is_located_to_two_hundredths_of_a_pixel() {
        for (centre, a, b, angle) in [
            (Point2::new(40.3, 33.7), 9.0, 9.0, 0.0),
            (Point2::new(38.71, 36.02), 12.0, 6.0, 0.6),
            (Point2::new(41.5, 35.25), 7.0, 4.5, -1.1),
        ] {
            let gray = ellipse_image(centre, a, b, angle);
            let shape = Matrix2::identity() / (a * b);
            let first = fit_ellipse(&gray, centre + Vector2::new(0.7, -0.5), &shape).unwrap();
            let ellipse = refit(&gray, &first).unwrap();
            let found = ellipse.centre().unwrap();
            assert!((found - centre).norm() < 0.02, "{centre} found at {found}");
            let (_, m) = ellipse.shape().unwrap();
            let axes = m.symmetric_eigen().eigenvalues.map(|v| 1.0 / v.sqrt());
            assert!(
                (axes.max() - a.max(b)).abs() < 0.3 && (axes.min() - a.min(b)).abs() < 0.3,
                "axes {axes:?} for {a}, {b}"
            );
        }
    }

    #[test]
    fn the_pole_of_the_line_at_infinity_is_the_centre() {
        let gray = ellipse_image(Point2::new(40.0, 35.0), 10.0, 8.0, 0.3);
        let ellipse = fit_ellipse(
            &gray,
            Point2::new(40.0, 35.0),
            &(Matrix2::identity() / 80.0),
        )
        .unwrap();
        assert_eq!(ellipse.pole(&Vector3::new(0.0, 0.0, 1.0)), ellipse.centre());
        // A flat image with no edge gives nothing.
        let flat = Gray {
            width: 80,
            height: 70,
            data: vec![128; 80 * 70],
        };
        assert!(
            fit_ellipse(
                &flat,
                Point2::new(40.0, 35.0),
                &(Matrix2::identity() / 80.0)
            )
            .is_none()
        );
    }
}
