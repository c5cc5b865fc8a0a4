//! Where a circle's image centre lies against the centre of its image ellipse.
//!
//! Perspective and lens distortion bend a circle's image, so the centre of the ellipse
//! fitted to its edge is not the image of the circle's centre. Around each circle, the
//! grid's map from the board to the image is modelled as a homography (perspective,
//! exactly) plus a quadratic in board coordinates (the lens, to second order, which is
//! the order of the bias), fitted to the neighbouring centres. The bias is then the
//! ellipse fit run on the modelled edge of the circle, against the modelled centre.

use nalgebra::{Matrix2, Matrix3, Point2, SMatrix, SVector, Vector2, Vector3};

use super::conic::TangentFit;
use crate::geometry::homography_dlt;

/// Points on the modelled edge of a circle.
const EDGE_SAMPLES: usize = 48;
/// Fewer neighbours than this leave the lens term out: the homography alone.
const MIN_POINTS_FOR_LENS: usize = 9;

/// A map from board coordinates (around a circle, in units of the grid's spacing) to
/// the image: a homography plus a quadratic `a . [1, x, y, x², x y, y²]` per image
/// coordinate.
#[derive(Clone, Copy, Debug)]
pub(super) struct LocalMap {
    image_from_board: Matrix3<f64>,
    u: SVector<f64, 6>,
    v: SVector<f64, 6>,
}

fn terms(p: &Point2<f64>) -> SVector<f64, 6> {
    SVector::<f64, 6>::from([1.0, p.x, p.y, p.x * p.x, p.x * p.y, p.y * p.y])
}

impl LocalMap {
    /// The map fitted to `board` points and their `image` points: the homography by
    /// the direct linear transform, the quadratic by least squares on what it leaves
    /// (with at least [`MIN_POINTS_FOR_LENS`] points spread in two dimensions). `None`
    /// when the points do not determine a homography.
    pub fn fit(board: &[Point2<f64>], image: &[Point2<f64>]) -> Option<Self> {
        let image_from_board = homography_dlt(board, image).ok()?;
        let mut map = Self {
            image_from_board,
            u: SVector::zeros(),
            v: SVector::zeros(),
        };
        if board.len() < MIN_POINTS_FOR_LENS {
            return Some(map);
        }
        let mut normal = SMatrix::<f64, 6, 6>::zeros();
        let mut rhs_u = SVector::<f64, 6>::zeros();
        let mut rhs_v = SVector::<f64, 6>::zeros();
        for (b, i) in board.iter().zip(image) {
            let t = terms(b);
            let residual = i - map.map(b);
            normal += t * t.transpose();
            rhs_u += t * residual.x;
            rhs_v += t * residual.y;
        }
        if let Some(cholesky) = normal.cholesky() {
            // Points poorly spread leave a nearly singular system: no lens term then.
            let diagonal = cholesky.l_dirty().diagonal();
            if diagonal.min() > 1e-6 * diagonal.max() {
                map.u = cholesky.solve(&rhs_u);
                map.v = cholesky.solve(&rhs_v);
            }
        }
        Some(map)
    }

    /// The image of board point `p`.
    pub fn map(&self, p: &Point2<f64>) -> Point2<f64> {
        let q = self.image_from_board * Vector3::new(p.x, p.y, 1.0);
        let t = terms(p);
        Point2::new(q.x / q.z + self.u.dot(&t), q.y / q.z + self.v.dot(&t))
    }

    /// The derivative of the map at `p`: columns along board x and y.
    pub fn jacobian(&self, p: &Point2<f64>) -> Matrix2<f64> {
        let h = &self.image_from_board;
        let q = h * Vector3::new(p.x, p.y, 1.0);
        let w2 = q.z * q.z;
        let perspective =
            |row: usize, column: usize| (h[(row, column)] * q.z - q[row] * h[(2, column)]) / w2;
        let d =
            |a: &SVector<f64, 6>| (2.0 * a[0] * p.x + a[1] * p.y, a[1] * p.x + 2.0 * a[2] * p.y);
        let (ux, uy) = d(&self.u);
        let (vx, vy) = d(&self.v);
        Matrix2::new(
            perspective(0, 0) + ux,
            perspective(0, 1) + uy,
            perspective(1, 0) + vx,
            perspective(1, 1) + vy,
        )
    }
}

/// How far the centre of the ellipse fitted to the image of a circle of `radius`
/// (board units) centred at `centre` lies from the image of `centre`, under `map`.
pub(super) fn centre_bias(
    map: &LocalMap,
    centre: &Point2<f64>,
    radius: f64,
) -> Option<Vector2<f64>> {
    let image_centre = map.map(centre);
    let scale = radius * map.jacobian(centre).determinant().abs().sqrt();
    let mut fit = TangentFit::new(image_centre, scale);
    for k in 0..EDGE_SAMPLES {
        let angle = std::f64::consts::TAU * k as f64 / EDGE_SAMPLES as f64;
        let (sin, cos) = angle.sin_cos();
        let on_edge = centre + Vector2::new(cos, sin) * radius;
        let tangent = map.jacobian(&on_edge) * Vector2::new(-sin, cos) * radius;
        let length = tangent.norm();
        // The fit on an image weighs the edge per pixel along it: by arc length here.
        if let Some(normal) = Vector2::new(tangent.y, -tangent.x).try_normalize(1e-12) {
            fit.add(map.map(&on_edge), normal, length);
        }
    }
    Some(fit.solve()?.centre()? - image_centre)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn an_affine_map_has_no_bias_and_a_homography_has_the_exact_one() {
        let grid: Vec<Point2<f64>> = (-2..=2)
            .flat_map(|j| (-2..=2).map(move |i| Point2::new(f64::from(i), f64::from(j))))
            .collect();
        let affine = |p: &Point2<f64>| {
            Point2::new(
                300.0 + 40.0 * p.x + 5.0 * p.y,
                200.0 - 3.0 * p.x + 35.0 * p.y,
            )
        };
        let image: Vec<_> = grid.iter().map(affine).collect();
        let map = LocalMap::fit(&grid, &image).unwrap();
        let bias = centre_bias(&map, &Point2::origin(), 0.2).unwrap();
        assert!(bias.norm() < 1e-9, "{bias}");

        // A strongly tilted board: the bias of a circle's ellipse centre is the distance
        // from the ellipse centre to the pole of the vanishing line.
        let h = Matrix3::new(40.0, 2.0, 300.0, -3.0, 35.0, 200.0, 0.15, 0.05, 1.0);
        let project = |p: &Point2<f64>| {
            let q = h * Vector3::new(p.x, p.y, 1.0);
            Point2::new(q.x / q.z, q.y / q.z)
        };
        let image: Vec<_> = grid.iter().map(project).collect();
        let map = LocalMap::fit(&grid, &image).unwrap();
        let bias = centre_bias(&map, &Point2::origin(), 0.3).unwrap();
        // The exact image of the circle is the conic H^-T C H^-1.
        let circle = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -0.09);
        let h_inv = h.try_inverse().unwrap();
        let conic = h_inv.transpose() * circle * h_inv;
        let dual = conic.try_inverse().unwrap();
        let centre = dual * Vector3::new(0.0, 0.0, 1.0);
        let exact =
            Point2::new(centre.x / centre.z, centre.y / centre.z) - project(&Point2::origin());
        assert!(exact.norm() > 0.1, "{exact}");
        assert!(
            (bias - exact).norm() < 0.01 * exact.norm(),
            "{bias} against {exact}"
        );
    }
}
