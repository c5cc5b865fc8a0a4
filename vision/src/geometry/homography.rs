//! Homographies between two images of a plane (or two images related by a pure
//! rotation): the normalized direct linear transform, and the robust estimate with
//! RANSAC or LMedS followed by Levenberg-Marquardt on the transfer error.
//!
//! A homography is named for the frames it maps between: `image_b_from_image_a` maps a
//! point `a` of the first image to `b ~ H [a.x a.y 1]^T` in the second.

use nalgebra::{DMatrix, Matrix3, Point2, SMatrix, SVector, Vector3};

use super::consensus::{self, Estimator, RobustOptions};
use super::least_squares::{LeastSquares, levenberg_marquardt};
use super::{GeometryError, check_pairs};

/// Correspondences a homography needs.
const MIN_POINTS: usize = 4;
/// Ratio of the second smallest singular value of the DLT system to the largest below
/// which a family of homographies fits the points (collinear or coincident points).
const MIN_SINGULAR_RATIO: f64 = 1e-10;
/// Levenberg-Marquardt iterations of the refinement.
const REFINE_ITERATIONS: usize = 30;

/// The homography `H` with `b ~ H a` from at least four correspondences
/// (`image_b_from_image_a`), by the direct linear transform on Hartley-normalized points,
/// solved by SVD (which keeps exact data exact). All points are used alike: no outlier
/// is rejected. `H` is scaled so that `H[(2, 2)] = 1` when that entry does not vanish
/// next to the others, to unit Frobenius norm otherwise.
///
/// Errors: [`GeometryError::MismatchedLengths`], [`GeometryError::TooFewPoints`],
/// [`GeometryError::NonFinite`], [`GeometryError::Degenerate`] when the points do not
/// determine one homography (three of four on a line, all coincident).
pub fn homography_dlt(
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
) -> Result<Matrix3<f64>, GeometryError> {
    check_pairs(points_a, points_b, MIN_POINTS)?;
    let degenerate = || {
        GeometryError::Degenerate(
            "the points do not determine a homography (collinear or coincident)".into(),
        )
    };
    let t_a = normalizing_transform(points_a).ok_or_else(degenerate)?;
    let t_b = normalizing_transform(points_b).ok_or_else(degenerate)?;
    // At least 9 rows, so that the SVD yields every right singular vector.
    let rows = (2 * points_a.len()).max(9);
    let mut a = DMatrix::<f64>::zeros(rows, 9);
    for (i, (p, q)) in points_a.iter().zip(points_b).enumerate() {
        let p = t_a * p.to_homogeneous();
        let q = t_b * q.to_homogeneous();
        for (k, &c) in [p.x, p.y, 1.0].iter().enumerate() {
            a[(2 * i, k)] = c;
            a[(2 * i, 6 + k)] = -q.x * c;
            a[(2 * i + 1, 3 + k)] = c;
            a[(2 * i + 1, 6 + k)] = -q.y * c;
        }
    }
    let svd = a.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| GeometryError::NoSolution("the SVD of the DLT system failed".into()))?;
    let sigma = &svd.singular_values;
    if sigma[7] <= MIN_SINGULAR_RATIO * sigma[0] {
        return Err(degenerate());
    }
    let h = v_t.row(8);
    let normalized = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let h = denormalize(&normalized, &t_a, &t_b).ok_or_else(degenerate)?;
    finite(scaled(h)).ok_or_else(|| GeometryError::NoSolution("non-finite homography".into()))
}

/// A homography, and the correspondences it explains, from [`find_homography`].
#[derive(Clone, Debug, PartialEq)]
pub struct HomographyEstimate {
    /// `H` with `b ~ H a`, scaled so that `H[(2, 2)] = 1` (to unit Frobenius norm when
    /// that entry vanishes).
    pub image_b_from_image_a: Matrix3<f64>,
    /// Per correspondence, whether `H` transfers `a` to within the inlier threshold of
    /// `b`.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// RMS over the inliers of the transfer error `|b - H a|`, pixels.
    pub rms_px: f64,
    /// Samples the robust search drew.
    pub iterations: usize,
}

/// The homography `image_b_from_image_a` of correspondences of which some may be gross
/// outliers, as OpenCV's `findHomography` with RANSAC or LMEDS: 4-point samples
/// (refused when three points are collinear or the two quadrilaterals have inconsistent
/// orientations), each hypothesis scored by the squared transfer error
/// `|b - H a|^2` in pixels of the second image, the number of samples adapted to the
/// best inlier ratio; then the DLT on the winner's inliers and Levenberg-Marquardt on
/// their transfer error, re-scored, and refined again while the inlier set grows.
///
/// Pixels have their centres at integer coordinates; `options.threshold_px` is a
/// transfer distance in pixels of the second image.
///
/// Errors: as [`homography_dlt`] for the input, [`GeometryError::InvalidOption`],
/// [`GeometryError::NoConsensus`] when no hypothesis explains four correspondences,
/// [`GeometryError::Degenerate`] when the inliers do not determine a homography.
pub fn find_homography(
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
    options: &RobustOptions,
) -> Result<HomographyEstimate, GeometryError> {
    check_pairs(points_a, points_b, MIN_POINTS)?;
    let estimator = TransferError { points_a, points_b };
    let consensus = consensus::search(&estimator, options, 1.0)?;
    let (h, mask, count, rms_px) =
        consensus::refit_on_inliers(&estimator, &consensus, |h, mask| {
            let (a, b) = select(points_a, points_b, mask);
            let start = homography_dlt(&a, &b).unwrap_or(*h);
            Some(refine(&start, &a, &b))
        });
    let h = finite(h).ok_or_else(|| GeometryError::NoSolution("non-finite homography".into()))?;
    Ok(HomographyEstimate {
        image_b_from_image_a: h,
        inliers: mask,
        inlier_count: count,
        rms_px,
        iterations: consensus.iterations,
    })
}

/// Similarity moving the points' centroid to the origin and their mean distance from it
/// to sqrt(2) (Hartley's normalization); `None` when the points coincide or are not
/// finite.
pub(crate) fn normalizing_transform(points: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.x / n, y + p.y / n));
    let mean_distance = points
        .iter()
        .map(|p| ((p.x - mx).powi(2) + (p.y - my).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    if !(mean_distance > 0.0 && mean_distance.is_finite()) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / mean_distance;
    Some(Matrix3::new(
        s,
        0.0,
        -s * mx,
        0.0,
        s,
        -s * my,
        0.0,
        0.0,
        1.0,
    ))
}

/// The points of `a` and `b` whose entry in `mask` is set.
pub(crate) fn select(
    a: &[Point2<f64>],
    b: &[Point2<f64>],
    mask: &[bool],
) -> (Vec<Point2<f64>>, Vec<Point2<f64>>) {
    a.iter()
        .zip(b)
        .zip(mask)
        .filter(|(_, inlier)| **inlier)
        .map(|((p, q), _)| (*p, *q))
        .unzip()
}

/// `H` scaled so that `H[(2, 2)] = 1` when that entry does not vanish next to the
/// others, to unit Frobenius norm otherwise.
fn scaled(h: Matrix3<f64>) -> Matrix3<f64> {
    let corner = h[(2, 2)];
    if corner.abs() > 1e-12 * h.norm() {
        h / corner
    } else {
        h / h.norm()
    }
}

fn finite(h: Matrix3<f64>) -> Option<Matrix3<f64>> {
    h.iter().all(|v| v.is_finite()).then_some(h)
}

/// `T_b^-1 H T_a`: a homography between normalized points back to pixels.
fn denormalize(h: &Matrix3<f64>, t_a: &Matrix3<f64>, t_b: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    Some(t_b.try_inverse()? * h * t_a)
}

/// The homography of exactly four correspondences, through the projective basis each
/// quadruple defines; `None` when three points of either image are collinear.
fn four_point(a: &[Point2<f64>; 4], b: &[Point2<f64>; 4]) -> Option<Matrix3<f64>> {
    // The map taking the canonical basis e1, e2, e3, (1, 1, 1) to four points.
    let basis = |p: &[Point2<f64>; 4]| {
        let m = Matrix3::from_columns(&[
            p[0].to_homogeneous(),
            p[1].to_homogeneous(),
            p[2].to_homogeneous(),
        ]);
        let lambda = m.try_inverse()? * p[3].to_homogeneous();
        Some(m * Matrix3::from_diagonal(&lambda))
    };
    let h = basis(b)? * basis(a)?.try_inverse()?;
    finite(scaled(h))
}

/// The hypotheses of the robust search: `image_b_from_image_a` in pixels, scored by the
/// squared transfer error in pixels of the second image.
struct TransferError<'a> {
    points_a: &'a [Point2<f64>],
    points_b: &'a [Point2<f64>],
}

impl Estimator for TransferError<'_> {
    type Model = Matrix3<f64>;
    const SAMPLE_SIZE: usize = MIN_POINTS;

    fn len(&self) -> usize {
        self.points_a.len()
    }

    /// No three points collinear in either image, and every triangle of the sample
    /// with the same orientation in both images (a homography of a plane seen from its
    /// front side preserves it); as OpenCV's `checkSubset`.
    fn is_valid_sample(&self, sample: &[usize]) -> bool {
        const TRIANGLES: [[usize; 3]; 4] = [[0, 1, 2], [1, 2, 3], [0, 2, 3], [1, 0, 3]];
        let area = |points: &[Point2<f64>], t: &[usize; 3]| {
            let (p, q, r) = (
                points[sample[t[0]]],
                points[sample[t[1]]],
                points[sample[t[2]]],
            );
            (q - p).perp(&(r - p))
        };
        let mut negative = 0;
        for t in &TRIANGLES {
            let product = area(self.points_a, t) * area(self.points_b, t);
            if product == 0.0 || !product.is_finite() {
                return false;
            }
            negative += usize::from(product < 0.0);
        }
        negative == 0 || negative == TRIANGLES.len()
    }

    fn fit_sample(&self, sample: &[usize], models: &mut Vec<Matrix3<f64>>) {
        let a = [0, 1, 2, 3].map(|k| self.points_a[sample[k]]);
        let b = [0, 1, 2, 3].map(|k| self.points_b[sample[k]]);
        models.extend(four_point(&a, &b));
    }

    fn squared_error(&self, h: &Matrix3<f64>, index: usize) -> f64 {
        transfer_residual(h, &self.points_a[index], &self.points_b[index])
            .map_or(f64::INFINITY, |r| r.norm_squared())
    }
}

/// `H a - b` in pixels, `None` when `a` maps to infinity.
fn transfer_residual(
    h: &Matrix3<f64>,
    a: &Point2<f64>,
    b: &Point2<f64>,
) -> Option<nalgebra::Vector2<f64>> {
    let p = h * a.to_homogeneous();
    (p.z != 0.0).then(|| nalgebra::Vector2::new(p.x / p.z - b.x, p.y / p.z - b.y))
}

/// Levenberg-Marquardt on the summed squared transfer error of `h` over the
/// correspondences, on Hartley-normalized points (the residuals stay proportional to
/// pixels, so the minimum is the same), with the normalized homography's corner held at
/// 1; `h` itself when the points cannot be normalized.
fn refine(h: &Matrix3<f64>, a: &[Point2<f64>], b: &[Point2<f64>]) -> Matrix3<f64> {
    let (Some(t_a), Some(t_b)) = (normalizing_transform(a), normalizing_transform(b)) else {
        return *h;
    };
    let Some(t_a_inverse) = t_a.try_inverse() else {
        return *h;
    };
    let normalized = t_b * h * t_a_inverse;
    if normalized[(2, 2)].abs() <= 1e-12 * normalized.norm() {
        return *h;
    }
    let normalized = normalized / normalized[(2, 2)];
    let problem = NormalizedTransfer {
        a: a.iter().map(|p| t_a * p.to_homogeneous()).collect(),
        b: b.iter().map(|p| t_b * p.to_homogeneous()).collect(),
    };
    let start = SVector::<f64, 8>::from_iterator(normalized.transpose().iter().take(8).copied());
    let x = levenberg_marquardt(&problem, start, REFINE_ITERATIONS);
    let refined = Matrix3::new(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], 1.0);
    denormalize(&refined, &t_a, &t_b)
        .and_then(|h| finite(scaled(h)))
        .unwrap_or(*h)
}

/// The transfer error of a homography between normalized points, as a function of its
/// first eight entries (row by row, the ninth held at 1).
struct NormalizedTransfer {
    a: Vec<Vector3<f64>>,
    b: Vec<Vector3<f64>>,
}

impl LeastSquares<8> for NormalizedTransfer {
    type State = SVector<f64, 8>;

    fn linearize(&self, h: &Self::State) -> Option<(f64, SMatrix<f64, 8, 8>, SVector<f64, 8>)> {
        let mut jtj = SMatrix::<f64, 8, 8>::zeros();
        let mut jtr = SVector::<f64, 8>::zeros();
        let mut cost = 0.0;
        for (p, q) in self.a.iter().zip(&self.b) {
            let w = h[6] * p.x + h[7] * p.y + 1.0;
            if w == 0.0 {
                return None;
            }
            let u = (h[0] * p.x + h[1] * p.y + h[2]) / w;
            let v = (h[3] * p.x + h[4] * p.y + h[5]) / w;
            let (ru, rv) = (u - q.x / q.z, v - q.y / q.z);
            cost += ru * ru + rv * rv;
            let (x, y) = (p.x / w, p.y / w);
            let ju = SVector::<f64, 8>::from([x, y, 1.0 / w, 0.0, 0.0, 0.0, -u * x, -u * y]);
            let jv = SVector::<f64, 8>::from([0.0, 0.0, 0.0, x, y, 1.0 / w, -v * x, -v * y]);
            jtj += ju * ju.transpose() + jv * jv.transpose();
            jtr += ju * ru + jv * rv;
        }
        cost.is_finite().then_some((cost, jtj, jtr))
    }

    fn retract(&self, h: &Self::State, step: &SVector<f64, 8>) -> Self::State {
        h + step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Vec<Point2<f64>> {
        (0..6)
            .flat_map(|r| (0..9).map(move |c| Point2::new(c as f64 * 0.1, r as f64 * 0.1)))
            .collect()
    }

    fn apply(h: &Matrix3<f64>, p: &Point2<f64>) -> Point2<f64> {
        Point2::from_homogeneous(h * p.to_homogeneous()).unwrap()
    }

    #[test]
    fn recovers_a_known_homography() {
        let truth = Matrix3::new(520.0, 12.0, 300.0, -8.0, 505.0, 240.0, 0.05, -0.03, 1.0);
        let plane = grid();
        let image: Vec<Point2<f64>> = plane.iter().map(|p| apply(&truth, p)).collect();
        let h = homography_dlt(&plane, &image).unwrap();
        assert!((h - truth).norm() < 1e-9 * truth.norm(), "{h} vs {truth}");
        let four = four_point(
            &[plane[0], plane[8], plane[45], plane[53]],
            &[image[0], image[8], image[45], image[53]],
        )
        .unwrap();
        assert!(
            (four - truth).norm() < 1e-9 * truth.norm(),
            "{four} vs {truth}"
        );
    }

    #[test]
    fn collinear_points_have_no_homography() {
        let plane: Vec<Point2<f64>> = (0..8).map(|i| Point2::new(i as f64, 0.0)).collect();
        let image: Vec<Point2<f64>> = (0..8).map(|i| Point2::new(2.0 * i as f64, 1.0)).collect();
        assert!(matches!(
            homography_dlt(&plane, &image),
            Err(GeometryError::Degenerate(_))
        ));
    }

    #[test]
    fn refinement_lowers_the_transfer_error() {
        let truth = Matrix3::new(1.1, 0.05, 30.0, -0.04, 0.95, 12.0, 1e-4, -2e-4, 1.0);
        let a: Vec<Point2<f64>> = grid().iter().map(|p| p * 4000.0).collect();
        let mut b: Vec<Point2<f64>> = a.iter().map(|p| apply(&truth, p)).collect();
        for (i, p) in b.iter_mut().enumerate() {
            p.x += ((i * 7919) % 13) as f64 * 0.1 - 0.6;
            p.y += ((i * 104_729) % 11) as f64 * 0.1 - 0.5;
        }
        let cost = |h: &Matrix3<f64>| -> f64 {
            a.iter()
                .zip(&b)
                .map(|(p, q)| transfer_residual(h, p, q).unwrap().norm_squared())
                .sum()
        };
        let dlt = homography_dlt(&a, &b).unwrap();
        let refined = refine(&dlt, &a, &b);
        assert!(
            cost(&refined) < cost(&dlt),
            "{} vs {}",
            cost(&refined),
            cost(&dlt)
        );
    }
}
