//! Essential matrices of two calibrated views: Nistér's 5-point solver and the robust
//! estimate with RANSAC or LMedS on normalized image points (OpenCV's
//! `findEssentialMat`), refined by Levenberg-Marquardt on the Sampson error over the
//! essential manifold; and the four relative poses an essential matrix holds.
//!
//! Convention (OpenCV's): normalized image points `a` of the first camera and `b` of
//! the second (undistorted `(X/Z, Y/Z, 1)`) satisfy `b^T E a = 0`, with `E = [t]x R` for
//! `camera_b_from_camera_a = (R, t)`.

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Point2, Rotation3, SMatrix, SVector, Translation3, Unit,
    UnitQuaternion, Vector3,
};

use super::consensus::{self, Estimator, RobustOptions};
use super::fundamental::{epipolar_row, sampson_squared, svd3};
use super::homography::select;
use super::least_squares::{LeastSquares, levenberg_marquardt};
use super::null_space::null_space;
use super::{GeometryError, check_pairs};
use crate::camera::CameraModel;

/// Correspondences of the minimal solver.
const SAMPLE_SIZE: usize = 5;
/// Levenberg-Marquardt iterations of the refinement.
const REFINE_ITERATIONS: usize = 20;
/// Step of the central differences of the refinement's Jacobian, radians (and unit
/// vector components).
const DIFFERENCE_STEP: f64 = 1e-7;

/// An essential matrix, and the correspondences it explains, from [`find_essential`].
#[derive(Clone, Debug, PartialEq)]
pub struct EssentialEstimate {
    /// `E` with `b^T E a = 0` on normalized image points, singular values `(1, 1, 0)`
    /// (so its sign is arbitrary).
    pub essential: Matrix3<f64>,
    /// Per correspondence, whether its Sampson distance is within the inlier threshold.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// RMS over the inliers of the Sampson distance, in pixels (normalized units times
    /// the mean focal length).
    pub rms_px: f64,
    /// Samples the robust search drew.
    pub iterations: usize,
}

/// The essential matrices of five correspondences of normalized image points, by
/// Nistér's 5-point algorithm: `E` in the four-dimensional null space of the epipolar
/// constraints, `E = x X + y Y + z Z + W`, where the cubic constraints `det E = 0` and
/// `2 E E^T E - trace(E E^T) E = 0` reduce, after Gauss-Jordan elimination, to a
/// polynomial of degree 10 in `z`, whose real roots give up to ten solutions. Each is
/// scaled to unit Frobenius norm; none for a degenerate sample.
pub fn essential_5point(a: &[Point2<f64>; 5], b: &[Point2<f64>; 5]) -> Vec<Matrix3<f64>> {
    let rows: [[f64; 9]; 5] =
        std::array::from_fn(|k| epipolar_row(&a[k].to_homogeneous(), &b[k].to_homogeneous()));
    let Some(basis) = null_space(&rows) else {
        return Vec::new();
    };
    five_point::solve(&basis)
}

/// The four relative poses `camera_b_from_camera_a` an essential matrix holds, with unit
/// translation (OpenCV's `decomposeEssentialMat`): rotations `U W V^T` and `U W^T V^T`,
/// translations `±u3`, from the SVD `E = U diag(1, 1, 0) V^T` with `det U, det V > 0`.
/// Only one of them puts the scene in front of both cameras ([`recover_pose`](super::recover_pose)
/// chooses it). `None` when `E` is not finite, has rank below 2, or its SVD fails.
pub fn decompose_essential(essential: &Matrix3<f64>) -> Option<[Isometry3<f64>; 4]> {
    let (mut u, sigma, mut v_t) = svd3(essential)?;
    // A matrix of rank below 2 holds no pose.
    if sigma[1] <= 1e-9 * sigma[0] || !sigma[0].is_finite() {
        return None;
    }
    if u.determinant() < 0.0 {
        u = -u;
    }
    if v_t.determinant() < 0.0 {
        v_t = -v_t;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let rotation = |m: Matrix3<f64>| {
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
    };
    let r1 = rotation(u * w * v_t);
    let r2 = rotation(u * w.transpose() * v_t);
    let t = u.column(2).normalize();
    let pose = |r, t: Vector3<f64>| Isometry3::from_parts(Translation3::from(t), r);
    let poses = [pose(r1, t), pose(r1, -t), pose(r2, t), pose(r2, -t)];
    poses
        .iter()
        .all(|p| p.translation.vector.iter().all(|v| v.is_finite()))
        .then_some(poses)
}

/// The essential matrix of correspondences of which some may be gross outliers, as
/// OpenCV's `findEssentialMat` with RANSAC or LMEDS: pixels are undistorted through
/// each camera model to normalized image points, 5-point samples
/// ([`essential_5point`]) give up to ten hypotheses, each scored by the squared
/// Sampson distance on normalized points; the pixel threshold is converted with the
/// mean focal length of the two cameras (OpenCV's `threshold / focal`). The winner is
/// refined by Levenberg-Marquardt on the Sampson error of its inliers over the
/// essential manifold (rotation and unit translation), re-scored, and refined again
/// while the inlier set grows.
///
/// Pixels have their centres at integer coordinates.
///
/// Errors: [`GeometryError::MismatchedLengths`], [`GeometryError::TooFewPoints`]
/// (fewer than six), [`GeometryError::NonFinite`], [`GeometryError::Unprojectable`]
/// for a pixel with no ray through its camera, [`GeometryError::InvalidOption`],
/// [`GeometryError::NoConsensus`] when no hypothesis explains five correspondences.
pub fn find_essential(
    camera_a: &CameraModel,
    pixels_a: &[Point2<f64>],
    camera_b: &CameraModel,
    pixels_b: &[Point2<f64>],
    options: &RobustOptions,
) -> Result<EssentialEstimate, GeometryError> {
    check_pairs(pixels_a, pixels_b, SAMPLE_SIZE + 1)?;
    let normalized_a = normalize(camera_a, pixels_a, "first")?;
    let normalized_b = normalize(camera_b, pixels_b, "second")?;
    let focal = mean_focal(camera_a, camera_b)?;
    let estimator = NormalizedSampson {
        a: &normalized_a,
        b: &normalized_b,
    };
    let consensus = consensus::search(&estimator, options, 1.0 / focal)?;
    let (e, mask, count, rms) = consensus::refit_on_inliers(&estimator, &consensus, |e, mask| {
        let (a, b) = select(&normalized_a, &normalized_b, mask);
        refine(e, &a, &b)
    });
    let e = essential_of(&e)
        .ok_or_else(|| GeometryError::NoSolution("non-finite essential matrix".into()))?;
    Ok(EssentialEstimate {
        essential: e,
        inliers: mask,
        inlier_count: count,
        rms_px: rms * focal,
        iterations: consensus.iterations,
    })
}

/// The undistorted normalized image points of `pixels` through `camera`.
pub(crate) fn normalize(
    camera: &CameraModel,
    pixels: &[Point2<f64>],
    image: &'static str,
) -> Result<Vec<Point2<f64>>, GeometryError> {
    camera
        .unproject_all(pixels)
        .into_iter()
        .zip(pixels)
        .enumerate()
        .map(|(index, (ray, pixel))| {
            ray.filter(|r| r.iter().all(|v| v.is_finite()))
                .map(|r| Point2::new(r.x, r.y))
                .ok_or(GeometryError::Unprojectable {
                    image,
                    index,
                    x: pixel.x,
                    y: pixel.y,
                })
        })
        .collect()
}

/// The mean of the two cameras' focal lengths, pixels.
pub(crate) fn mean_focal(a: &CameraModel, b: &CameraModel) -> Result<f64, GeometryError> {
    let focal = (a.intrinsics.fx + a.intrinsics.fy + b.intrinsics.fx + b.intrinsics.fy) / 4.0;
    if focal > 0.0 && focal.is_finite() {
        Ok(focal)
    } else {
        Err(GeometryError::InvalidOption(format!(
            "the cameras' focal lengths must be positive and finite, their mean is {focal}"
        )))
    }
}

/// The nearest essential matrix to `m` (singular values `(1, 1, 0)`), if finite.
fn essential_of(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let (u, _, v_t) = svd3(m)?;
    let e = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)) * v_t;
    e.iter().all(|v| v.is_finite()).then_some(e)
}

/// The hypotheses of the robust search, on normalized image points.
struct NormalizedSampson<'a> {
    a: &'a [Point2<f64>],
    b: &'a [Point2<f64>],
}

impl Estimator for NormalizedSampson<'_> {
    type Model = Matrix3<f64>;
    const SAMPLE_SIZE: usize = SAMPLE_SIZE;

    fn len(&self) -> usize {
        self.a.len()
    }

    fn fit_sample(&self, sample: &[usize], models: &mut Vec<Matrix3<f64>>) {
        let a = std::array::from_fn(|k| self.a[sample[k]]);
        let b = std::array::from_fn(|k| self.b[sample[k]]);
        models.extend(essential_5point(&a, &b));
    }

    fn squared_error(&self, e: &Matrix3<f64>, index: usize) -> f64 {
        sampson_squared(e, &self.a[index], &self.b[index])
    }
}

/// Levenberg-Marquardt on the summed squared Sampson error of `e` over the
/// correspondences, parametrized by a rotation and a unit translation; `None` when `e`
/// has no such decomposition.
fn refine(e: &Matrix3<f64>, a: &[Point2<f64>], b: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    let [pose, ..] = decompose_essential(e)?;
    let problem = SampsonProblem { a, b };
    let start = (pose.rotation, Unit::new_normalize(pose.translation.vector));
    let (rotation, translation) = levenberg_marquardt(&problem, start, REFINE_ITERATIONS);
    essential_of(&(translation.cross_matrix() * rotation.to_rotation_matrix().matrix()))
}

struct SampsonProblem<'a> {
    a: &'a [Point2<f64>],
    b: &'a [Point2<f64>],
}

impl SampsonProblem<'_> {
    /// The signed Sampson residuals of `E = [t]x R`.
    fn residuals(&self, state: &(UnitQuaternion<f64>, Unit<Vector3<f64>>)) -> DVector<f64> {
        let e = state.1.cross_matrix() * state.0.to_rotation_matrix().matrix();
        DVector::from_iterator(
            self.a.len(),
            self.a.iter().zip(self.b).map(|(a, b)| {
                let fa = e * a.to_homogeneous();
                let ftb = e.tr_mul(&b.to_homogeneous());
                let residual = b.x * fa.x + b.y * fa.y + fa.z;
                let gradient = fa.x * fa.x + fa.y * fa.y + ftb.x * ftb.x + ftb.y * ftb.y;
                residual / gradient.sqrt()
            }),
        )
    }
}

impl LeastSquares<5> for SampsonProblem<'_> {
    type State = (UnitQuaternion<f64>, Unit<Vector3<f64>>);

    fn linearize(&self, state: &Self::State) -> Option<(f64, SMatrix<f64, 5, 5>, SVector<f64, 5>)> {
        let r = self.residuals(state);
        let cost = r.norm_squared();
        if !cost.is_finite() {
            return None;
        }
        let mut jacobian = DMatrix::<f64>::zeros(r.nrows(), 5);
        for k in 0..5 {
            let mut step = SVector::<f64, 5>::zeros();
            step[k] = DIFFERENCE_STEP;
            let plus = self.residuals(&self.retract(state, &step));
            let minus = self.residuals(&self.retract(state, &-step));
            jacobian.set_column(k, &((plus - minus) / (2.0 * DIFFERENCE_STEP)));
        }
        let jtj = jacobian.tr_mul(&jacobian);
        let jtr = jacobian.tr_mul(&r);
        let jtj = SMatrix::<f64, 5, 5>::from_iterator(jtj.iter().copied());
        let jtr = SVector::<f64, 5>::from_iterator(jtr.iter().copied());
        jtj.iter()
            .all(|v| v.is_finite())
            .then_some((cost, jtj, jtr))
    }

    /// Rotates by the first three components (a rotation vector, applied on the right)
    /// and moves the translation along the two directions orthogonal to it.
    fn retract(&self, state: &Self::State, step: &SVector<f64, 5>) -> Self::State {
        let rotation =
            state.0 * UnitQuaternion::from_scaled_axis(step.fixed_rows::<3>(0).into_owned());
        let t = state.1.into_inner();
        let helper = if t.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let u = t.cross(&helper).normalize();
        let v = t.cross(&u);
        let translation = Unit::new_normalize(t + u * step[3] + v * step[4]);
        (rotation, translation)
    }
}

/// Nistér's reduction of the 5-point problem to a polynomial of degree 10.
mod five_point {
    use nalgebra::Matrix3;

    use super::super::polynomial::{evaluate, real_roots};

    /// A polynomial in `x, y, z` of degree at most 3: coefficients of the monomials
    /// in Nistér's order, [`MONOMIALS`].
    type Poly = [f64; 20];

    /// Exponents of `(x, y, z)` of the twenty monomials: x³ y³ x²y xy² x²z x² y²z y²
    /// xyz xy | xz² xz x yz² yz y z³ z² z 1. The ten before the bar are eliminated.
    const MONOMIALS: [[u8; 3]; 20] = [
        [3, 0, 0],
        [0, 3, 0],
        [2, 1, 0],
        [1, 2, 0],
        [2, 0, 1],
        [2, 0, 0],
        [0, 2, 1],
        [0, 2, 0],
        [1, 1, 1],
        [1, 1, 0],
        [1, 0, 2],
        [1, 0, 1],
        [1, 0, 0],
        [0, 1, 2],
        [0, 1, 1],
        [0, 1, 0],
        [0, 0, 3],
        [0, 0, 2],
        [0, 0, 1],
        [0, 0, 0],
    ];
    /// Indices of the monomials of degree at most 1 and at most 2.
    const LINEAR: [usize; 4] = [12, 15, 18, 19];
    const QUADRATIC: [usize; 10] = [5, 7, 9, 11, 12, 14, 15, 17, 18, 19];
    /// `PRODUCT[i][j]`: the index of monomial i times monomial j (20 when the product
    /// has degree above 3).
    const PRODUCT: [[usize; 20]; 20] = product_table();

    const fn product_table() -> [[usize; 20]; 20] {
        let mut table = [[20; 20]; 20];
        let mut i = 0;
        while i < 20 {
            let mut j = 0;
            while j < 20 {
                let e = [
                    MONOMIALS[i][0] + MONOMIALS[j][0],
                    MONOMIALS[i][1] + MONOMIALS[j][1],
                    MONOMIALS[i][2] + MONOMIALS[j][2],
                ];
                let mut k = 0;
                while k < 20 {
                    if MONOMIALS[k][0] == e[0] && MONOMIALS[k][1] == e[1] && MONOMIALS[k][2] == e[2]
                    {
                        table[i][j] = k;
                    }
                    k += 1;
                }
                j += 1;
            }
            i += 1;
        }
        table
    }

    fn multiply(p: &Poly, p_support: &[usize], q: &Poly, q_support: &[usize]) -> Poly {
        let mut out = [0.0; 20];
        for &i in p_support {
            if p[i] == 0.0 {
                continue;
            }
            for &j in q_support {
                let k = PRODUCT[i][j];
                if k < 20 {
                    out[k] += p[i] * q[j];
                }
            }
        }
        out
    }

    fn add(p: &Poly, q: &Poly, scale: f64) -> Poly {
        std::array::from_fn(|k| p[k] + scale * q[k])
    }

    /// The product of two polynomials in `z`, lowest degree first, truncated to `K`
    /// coefficients (exact when `K >= N + M - 1`).
    fn product<const N: usize, const M: usize, const K: usize>(
        a: &[f64; N],
        b: &[f64; M],
    ) -> [f64; K] {
        let mut out = [0.0; K];
        for (i, x) in a.iter().enumerate() {
            for (j, y) in b.iter().enumerate() {
                if i + j < K {
                    out[i + j] += x * y;
                }
            }
        }
        out
    }

    fn difference<const K: usize>(a: &[f64; K], b: &[f64; K]) -> [f64; K] {
        std::array::from_fn(|k| a[k] - b[k])
    }

    /// The solutions `E = x X + y Y + z Z + W` for the null-space basis `[X, Y, Z, W]`
    /// (row-major 3x3 matrices), at unit Frobenius norm.
    pub(super) fn solve(basis: &[[f64; 9]]) -> Vec<Matrix3<f64>> {
        let [x, y, z, w] = [0, 1, 2, 3].map(|k| basis[k]);
        let entry = |i: usize, j: usize| -> Poly {
            let mut p = [0.0; 20];
            let k = 3 * i + j;
            (p[12], p[15], p[18], p[19]) = (x[k], y[k], z[k], w[k]);
            p
        };
        let e: [[Poly; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| entry(i, j)));
        let mut eet = [[[0.0; 20]; 3]; 3];
        for i in 0..3 {
            for j in i..3 {
                let mut sum = [0.0; 20];
                for (p, q) in e[i].iter().zip(&e[j]) {
                    sum = add(&sum, &multiply(p, &LINEAR, q, &LINEAR), 1.0);
                }
                eet[i][j] = sum;
                eet[j][i] = sum;
            }
        }
        let trace = add(&add(&eet[0][0], &eet[1][1], 1.0), &eet[2][2], 1.0);
        let mut rows = [[0.0; 20]; 10];
        for i in 0..3 {
            for j in 0..3 {
                let mut sum = multiply(&trace, &QUADRATIC, &e[i][j], &LINEAR);
                sum = sum.map(|v| -v);
                for k in 0..3 {
                    sum = add(
                        &sum,
                        &multiply(&eet[i][k], &QUADRATIC, &e[k][j], &LINEAR),
                        2.0,
                    );
                }
                rows[3 * i + j] = sum;
            }
        }
        let minor = |a: usize, b: usize, c: usize, d: usize| {
            add(
                &multiply(&e[1][a], &LINEAR, &e[2][b], &LINEAR),
                &multiply(&e[1][c], &LINEAR, &e[2][d], &LINEAR),
                -1.0,
            )
        };
        let det = add(
            &add(
                &multiply(&minor(1, 2, 2, 1), &QUADRATIC, &e[0][0], &LINEAR),
                &multiply(&minor(0, 2, 2, 0), &QUADRATIC, &e[0][1], &LINEAR),
                -1.0,
            ),
            &multiply(&minor(0, 1, 1, 0), &QUADRATIC, &e[0][2], &LINEAR),
            1.0,
        );
        rows[9] = det;
        let Some(g) = eliminate(rows) else {
            return Vec::new();
        };
        // Each reduced row r reads: monomial r + x A(z) + y B(z) + C(z) = 0 over the
        // trailing monomials xz² xz x yz² yz y z³ z² z 1.
        let split = |r: usize| {
            let t = &g[r];
            (
                [t[12], t[11], t[10]],
                [t[15], t[14], t[13]],
                [t[19], t[18], t[17], t[16]],
            )
        };
        // Row (x²z) - z row (x²), and likewise for y² and xy: x²z, y²z and xyz cancel,
        // leaving three equations linear in x, y, 1 with coefficients polynomial in z.
        let shifted = |upper: usize, lower: usize| {
            let (a0, b0, c0) = split(upper);
            let (a1, b1, c1) = split(lower);
            let shift3 = |p: [f64; 3]| [0.0, p[0], p[1], p[2]];
            let shift4 = |p: [f64; 4]| [0.0, p[0], p[1], p[2], p[3]];
            (
                difference(&[a0[0], a0[1], a0[2], 0.0], &shift3(a1)),
                difference(&[b0[0], b0[1], b0[2], 0.0], &shift3(b1)),
                difference(&[c0[0], c0[1], c0[2], c0[3], 0.0], &shift4(c1)),
            )
        };
        let (ak, bk, ck) = shifted(4, 5);
        let (al, bl, cl) = shifted(6, 7);
        let (am, bm, cm) = shifted(8, 9);
        let p1: [f64; 8] = difference(&product(&bl, &cm), &product(&cl, &bm));
        let p2: [f64; 8] = difference(&product(&cl, &am), &product(&al, &cm));
        let p3: [f64; 7] = difference(&product(&al, &bm), &product(&bl, &am));
        let n: [f64; 11] = {
            let terms: [[f64; 11]; 3] = [product(&ak, &p1), product(&bk, &p2), product(&ck, &p3)];
            std::array::from_fn(|k| terms[0][k] + terms[1][k] + terms[2][k])
        };
        let mut solutions = Vec::new();
        for root in real_roots(&n) {
            let row = |a: &[f64; 4], b: &[f64; 4], c: &[f64; 5]| {
                nalgebra::Vector3::new(evaluate(a, root), evaluate(b, root), evaluate(c, root))
            };
            let (k, l, m) = (row(&ak, &bk, &ck), row(&al, &bl, &cl), row(&am, &bm, &cm));
            let Some(v) = [k.cross(&l), l.cross(&m), m.cross(&k)]
                .into_iter()
                .max_by(|p, q| p.z.abs().total_cmp(&q.z.abs()))
            else {
                continue;
            };
            if v.z == 0.0 {
                continue;
            }
            let (xs, ys) = (v.x / v.z, v.y / v.z);
            let flat: [f64; 9] =
                std::array::from_fn(|k| xs * x[k] + ys * y[k] + root * z[k] + w[k]);
            let e = Matrix3::from_row_slice(&flat);
            let norm = e.norm();
            if norm > 0.0 && norm.is_finite() {
                solutions.push(e / norm);
            }
        }
        solutions
    }

    /// Gauss-Jordan elimination of the first ten columns (partial pivoting): the rows
    /// of `[I | G]`, or `None` when the ten leading monomials cannot be eliminated.
    fn eliminate(mut m: [Poly; 10]) -> Option<[Poly; 10]> {
        for c in 0..10 {
            let pivot = (c..10).max_by(|&i, &j| m[i][c].abs().total_cmp(&m[j][c].abs()))?;
            let scale = m[pivot].iter().fold(0.0_f64, |s, v| s.max(v.abs()));
            if m[pivot][c].abs() <= 1e-14 * scale || !m[pivot][c].is_finite() {
                return None;
            }
            m.swap(c, pivot);
            let inverse = 1.0 / m[c][c];
            m[c] = m[c].map(|v| v * inverse);
            let row = m[c];
            for (i, other) in m.iter_mut().enumerate() {
                if i != c && other[c] != 0.0 {
                    *other = add(other, &row, -other[c]);
                }
            }
        }
        Some(m)
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn the_product_table_multiplies_monomials() {
            // x * yz = xyz; x² * x = x³; z³ * z is beyond degree 3.
            assert_eq!(PRODUCT[12][14], 8);
            assert_eq!(PRODUCT[5][12], 0);
            assert_eq!(PRODUCT[16][18], 20);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points() -> Vec<Vector3<f64>> {
        vec![
            Vector3::new(0.1, -0.2, 4.0),
            Vector3::new(-0.6, 0.4, 5.0),
            Vector3::new(0.8, 0.5, 6.5),
            Vector3::new(-0.3, -0.7, 3.5),
            Vector3::new(0.5, 0.1, 8.0),
            Vector3::new(-1.0, 0.9, 7.0),
        ]
    }

    #[test]
    fn five_points_give_the_true_essential_matrix() {
        let b_from_a = Isometry3::new(
            Vector3::new(0.4, -0.1, 0.05),
            Vector3::new(0.05, -0.1, 0.02),
        );
        let truth = b_from_a.translation.vector.normalize().cross_matrix()
            * b_from_a.rotation.to_rotation_matrix().matrix();
        let truth = truth / truth.norm();
        let xs = points();
        let a: [Point2<f64>; 5] =
            std::array::from_fn(|k| Point2::new(xs[k].x / xs[k].z, xs[k].y / xs[k].z));
        let b: [Point2<f64>; 5] = std::array::from_fn(|k| {
            let p = b_from_a * nalgebra::Point3::from(xs[k]);
            Point2::new(p.x / p.z, p.y / p.z)
        });
        let solutions = essential_5point(&a, &b);
        assert!(!solutions.is_empty());
        let best = solutions
            .iter()
            .map(|e| (e - truth).norm().min((e + truth).norm()))
            .fold(f64::INFINITY, f64::min);
        assert!(best < 1e-9, "{best} among {}", solutions.len());
        for e in &solutions {
            for k in 0..5 {
                let r = b[k].to_homogeneous().dot(&(e * a[k].to_homogeneous()));
                assert!(r.abs() < 1e-9, "{r}");
            }
        }
    }

    #[test]
    fn the_decomposition_holds_the_true_pose() {
        let b_from_a = Isometry3::new(Vector3::new(0.3, 0.2, -0.1), Vector3::new(-0.2, 0.1, 0.3));
        let t = b_from_a.translation.vector.normalize();
        let e = t.cross_matrix() * b_from_a.rotation.to_rotation_matrix().matrix();
        let poses = decompose_essential(&e).unwrap();
        let found = poses.iter().any(|p| {
            p.rotation.angle_to(&b_from_a.rotation) < 1e-10
                && (p.translation.vector - t).norm() < 1e-10
        });
        assert!(found, "{poses:?}");
    }
}
