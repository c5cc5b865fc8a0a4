//! Fundamental matrices of two uncalibrated views: the normalized 8-point algorithm
//! with rank-2 enforcement, the 7-point minimal solver, and the robust estimate with
//! RANSAC or LMedS scored by the Sampson distance.
//!
//! Convention (OpenCV's): pixels `a` of the first image and `b` of the second satisfy
//! `[b.x b.y 1] F [a.x a.y 1]^T = 0`; `F a` is the epipolar line of `a` in the second
//! image.

use nalgebra::{DMatrix, Matrix3, Matrix4x3, Point2};

use super::consensus::{self, Estimator, RobustOptions};
use super::homography::{normalizing_transform, select};
use super::null_space::null_space;
use super::polynomial::real_roots;
use super::{GeometryError, check_not_collinear, check_pairs};

/// Correspondences of the 8-point algorithm.
const MIN_POINTS: usize = 8;
/// Correspondences of the minimal solver.
const SAMPLE_SIZE: usize = 7;
/// Ratio of the second smallest singular value of the 8-point system to the largest
/// below which a family of matrices fits the points (too few distinct points, or a
/// scene where the epipolar geometry is not determined, such as a plane).
const MIN_SINGULAR_RATIO: f64 = 1e-10;

/// A fundamental matrix, and the correspondences it explains, from [`find_fundamental`].
#[derive(Clone, Debug, PartialEq)]
pub struct FundamentalEstimate {
    /// `F` with `b^T F a = 0` on pixels, of rank 2, scaled so that `F[(2, 2)] = 1` (to
    /// unit Frobenius norm when that entry vanishes).
    pub fundamental: Matrix3<f64>,
    /// Per correspondence, whether its Sampson distance is within the inlier threshold.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// RMS of the Sampson distance over the inliers, pixels.
    pub rms_px: f64,
    /// Samples the robust search drew.
    pub iterations: usize,
}

/// The Sampson distance of a correspondence to the epipolar geometry `F`, in pixels:
/// the first-order approximation of the distance, in the joint 4-D space of `(a, b)`, to
/// the nearest pair that satisfies `b^T F a = 0` exactly. Infinite when `a` and `b`
/// are both at their epipoles.
pub fn sampson_distance(f: &Matrix3<f64>, a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    sampson_squared(f, a, b).sqrt()
}

/// The fundamental matrix of at least eight correspondences by the normalized 8-point
/// algorithm (OpenCV's `FM_8POINT`): the least-squares solution of `b^T F a = 0` on
/// Hartley-normalized points, by SVD, made rank 2 by zeroing its smallest singular
/// value, scaled so that `F[(2, 2)] = 1` (to unit Frobenius norm when that entry
/// vanishes). All points are used alike: no outlier is rejected.
///
/// Errors: [`GeometryError::MismatchedLengths`], [`GeometryError::TooFewPoints`],
/// [`GeometryError::NonFinite`], [`GeometryError::Degenerate`] when the points do not
/// determine `F` (all on one line in either image, or on one plane of the scene).
pub fn fundamental_8point(
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
) -> Result<Matrix3<f64>, GeometryError> {
    check_pairs(points_a, points_b, MIN_POINTS)?;
    check_not_collinear(points_a, points_b)?;
    let degenerate = || {
        GeometryError::Degenerate(
            "the points do not determine a fundamental matrix (coincident points, or a \
             planar scene)"
                .into(),
        )
    };
    let t_a = normalizing_transform(points_a).ok_or_else(degenerate)?;
    let t_b = normalizing_transform(points_b).ok_or_else(degenerate)?;
    let rows = points_a.len().max(9);
    let mut a = DMatrix::<f64>::zeros(rows, 9);
    for (i, (p, q)) in points_a.iter().zip(points_b).enumerate() {
        let row = epipolar_row(&(t_a * p.to_homogeneous()), &(t_b * q.to_homogeneous()));
        for (k, value) in row.iter().enumerate() {
            a[(i, k)] = *value;
        }
    }
    let svd = a.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| GeometryError::NoSolution("the SVD of the 8-point system failed".into()))?;
    let sigma = &svd.singular_values;
    if sigma[7] <= MIN_SINGULAR_RATIO * sigma[0] {
        return Err(degenerate());
    }
    let f = v_t.row(8);
    let normalized = Matrix3::new(f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7], f[8]);
    let rank2 = rank_two(&normalized)
        .ok_or_else(|| GeometryError::NoSolution("the SVD of F failed".into()))?;
    finite(scaled(t_b.transpose() * rank2 * t_a))
        .ok_or_else(|| GeometryError::NoSolution("non-finite fundamental matrix".into()))
}

/// The fundamental matrix of correspondences of which some may be gross outliers, as
/// OpenCV's `findFundamentalMat` with `FM_RANSAC` or `FM_LMEDS`: 7-point samples (up to
/// three hypotheses each), scored by the squared Sampson distance in pixels, the number
/// of samples adapted to the best inlier ratio; then the 8-point algorithm on the
/// winner's inliers, re-scored, and refitted while the inlier set grows.
///
/// Pixels have their centres at integer coordinates; `options.threshold_px` bounds the
/// Sampson distance ([`sampson_distance`]) of an inlier, in pixels. For a
/// correspondence off only in one image, the Sampson distance is about its distance to
/// its epipolar line divided by sqrt(2).
///
/// Errors: as [`fundamental_8point`] for the input (at least eight points),
/// [`GeometryError::InvalidOption`], [`GeometryError::NoConsensus`] when no hypothesis
/// explains seven correspondences, [`GeometryError::Degenerate`] when the inliers do
/// not determine `F`.
pub fn find_fundamental(
    points_a: &[Point2<f64>],
    points_b: &[Point2<f64>],
    options: &RobustOptions,
) -> Result<FundamentalEstimate, GeometryError> {
    check_pairs(points_a, points_b, MIN_POINTS)?;
    check_not_collinear(points_a, points_b)?;
    let degenerate = || GeometryError::Degenerate("all points coincide in one image".into());
    let t_a = normalizing_transform(points_a).ok_or_else(degenerate)?;
    let t_b = normalizing_transform(points_b).ok_or_else(degenerate)?;
    let estimator = SampsonError {
        points_a,
        points_b,
        normalized_a: points_a.iter().map(|p| t_a * p.to_homogeneous()).collect(),
        normalized_b: points_b.iter().map(|p| t_b * p.to_homogeneous()).collect(),
        t_a,
        t_b,
    };
    let consensus = consensus::search(&estimator, options, 1.0)?;
    let (f, mask, count, rms_px) =
        consensus::refit_on_inliers(&estimator, &consensus, |_, mask| {
            let (a, b) = select(points_a, points_b, mask);
            fundamental_8point(&a, &b).ok()
        });
    let f = finite(scaled(f))
        .ok_or_else(|| GeometryError::NoSolution("non-finite fundamental matrix".into()))?;
    Ok(FundamentalEstimate {
        fundamental: f,
        inliers: mask,
        inlier_count: count,
        rms_px,
        iterations: consensus.iterations,
    })
}

/// The squared Sampson distance, as [`sampson_distance`].
pub(crate) fn sampson_squared(f: &Matrix3<f64>, a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    let fa = f * a.to_homogeneous();
    let ftb = f.tr_mul(&b.to_homogeneous());
    let residual = b.x * fa.x + b.y * fa.y + fa.z;
    let gradient = fa.x * fa.x + fa.y * fa.y + ftb.x * ftb.x + ftb.y * ftb.y;
    if gradient > 0.0 {
        residual * residual / gradient
    } else {
        f64::INFINITY
    }
}

/// The coefficients of `b^T F a` in the entries of `F`, row by row.
pub(crate) fn epipolar_row(a: &nalgebra::Vector3<f64>, b: &nalgebra::Vector3<f64>) -> [f64; 9] {
    [
        b.x * a.x,
        b.x * a.y,
        b.x * a.z,
        b.y * a.x,
        b.y * a.y,
        b.y * a.z,
        b.z * a.x,
        b.z * a.y,
        b.z * a.z,
    ]
}

/// The singular values of `m` (descending) and its SVD factors, by the general SVD: a
/// zero fourth row selects it, and nalgebra's special 3x3 SVD would go through
/// `m^T m` and lose half the digits of nearly equal singular values.
pub(crate) fn svd3(m: &Matrix3<f64>) -> Option<(Matrix3<f64>, [f64; 3], Matrix3<f64>)> {
    let mut padded = Matrix4x3::zeros();
    padded.fixed_rows_mut::<3>(0).copy_from(m);
    let svd = padded.try_svd(true, true, f64::EPSILON, 1000)?;
    let u: Matrix3<f64> = svd.u?.fixed_rows::<3>(0).into_owned();
    let v_t = svd.v_t?;
    let mut order = [0, 1, 2];
    let s = svd.singular_values;
    order.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
    let u = Matrix3::from_columns(&order.map(|i| u.column(i).into_owned()));
    let v_t = Matrix3::from_rows(&order.map(|i| v_t.row(i).into_owned()));
    Some((u, order.map(|i| s[i]), v_t))
}

/// The rank-2 matrix nearest to `m` in the Frobenius norm.
fn rank_two(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let (u, s, v_t) = svd3(m)?;
    Some(u * Matrix3::from_diagonal(&nalgebra::Vector3::new(s[0], s[1], 0.0)) * v_t)
}

/// `F` scaled so that `F[(2, 2)] = 1` when that entry does not vanish next to the
/// others, to unit Frobenius norm otherwise.
fn scaled(f: Matrix3<f64>) -> Matrix3<f64> {
    let corner = f[(2, 2)];
    if corner.abs() > 1e-12 * f.norm() {
        f / corner
    } else {
        f / f.norm()
    }
}

fn finite(f: Matrix3<f64>) -> Option<Matrix3<f64>> {
    f.iter().all(|v| v.is_finite()).then_some(f)
}

/// The hypotheses of the robust search: `F` on pixels, from 7-point samples of the
/// Hartley-normalized points, scored by the squared Sampson distance in pixels.
struct SampsonError<'a> {
    points_a: &'a [Point2<f64>],
    points_b: &'a [Point2<f64>],
    normalized_a: Vec<nalgebra::Vector3<f64>>,
    normalized_b: Vec<nalgebra::Vector3<f64>>,
    t_a: Matrix3<f64>,
    t_b: Matrix3<f64>,
}

impl Estimator for SampsonError<'_> {
    type Model = Matrix3<f64>;
    const SAMPLE_SIZE: usize = SAMPLE_SIZE;

    fn len(&self) -> usize {
        self.points_a.len()
    }

    /// The 7-point algorithm: `F = x F1 + (1 - x) F2` over the two-dimensional null
    /// space of the seven constraints, `x` a real root of the cubic `det F = 0`.
    fn fit_sample(&self, sample: &[usize], models: &mut Vec<Matrix3<f64>>) {
        let rows: [[f64; 9]; SAMPLE_SIZE] = std::array::from_fn(|k| {
            epipolar_row(&self.normalized_a[sample[k]], &self.normalized_b[sample[k]])
        });
        let Some(basis) = null_space(&rows) else {
            return;
        };
        let f1 = Matrix3::from_row_slice(&basis[0]);
        let f2 = Matrix3::from_row_slice(&basis[1]);
        let det = |x: f64| (f1 * x + f2 * (1.0 - x)).determinant();
        // The cubic's coefficients from its values at 0, 1, -1 and 2.
        let (d0, d1, dm1, d2) = (det(0.0), det(1.0), det(-1.0), det(2.0));
        let c2 = (d1 + dm1) * 0.5 - d0;
        let odd = (d1 - dm1) * 0.5;
        let c3 = ((d2 - d0 - 4.0 * c2) * 0.5 - odd) / 3.0;
        let c1 = odd - c3;
        for x in real_roots(&[d0, c1, c2, c3]) {
            let f = self.t_b.transpose() * (f1 * x + f2 * (1.0 - x)) * self.t_a;
            if let Some(f) = finite(scaled(f)) {
                models.push(f);
            }
        }
    }

    fn squared_error(&self, f: &Matrix3<f64>, index: usize) -> f64 {
        sampson_squared(f, &self.points_a[index], &self.points_b[index])
    }
}
