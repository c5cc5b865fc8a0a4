//! EPnP (Lepetit, Moreno-Noguer and Fua 2009).
//!
//! Every target point is written as a weighted sum of a few control points (its
//! barycentric coordinates, fixed by the target's geometry), which makes the projection
//! equations linear in the control points' camera coordinates. Their solution lies in the
//! small null space of that linear system; the coefficients along the null space come
//! from the control points' known distances. The pose is then the rigid motion between
//! the target points and their camera-frame reconstruction. The cost is linear in the
//! number of points.

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Point2, Point3, Rotation3, SymmetricEigen, Translation3,
    UnitQuaternion, Vector3,
};

use super::{PnpError, check_solver_input};

/// Thickness (see [`PrincipalAxes::thickness`]) at or below which the target is taken as
/// planar: three control points, the points' offsets from their plane neglected.
const FLAT: f64 = 1e-6;
/// Thickness at or below which the planar solution is tried besides the general one.
const THIN: f64 = 1e-2;
/// Ratio of the second principal spread over the first below which the points are taken
/// to lie on one line.
const MIN_RELATIVE_WIDTH: f64 = 1e-9;
/// Spread below which the points are taken to coincide, relative to their distance from
/// the origin of the target frame.
const MIN_RELATIVE_SPREAD: f64 = 1e-12;
/// Gauss-Newton iterations on the null-space coefficients, at most.
const GAUSS_NEWTON_ITERATIONS: usize = 10;

/// EPnP's pose for n >= 4 correspondences, planar (3 control points) or not (4 control
/// points), with the paper's Gauss-Newton refinement of the betas.
///
/// `target_points` are in the target frame (metres); `normalized` are their undistorted
/// normalized image points `(X/Z, Y/Z)`, in the same order. The result maps target points
/// to the camera frame (`camera_from_target`); among the solutions for null spaces of 1 to
/// 4 dimensions (1 to 3 for a planar target) it is the one with the least reprojection
/// error that puts every point in front of the camera.
///
/// EPnP is fast (linear in the number of points) and needs no initial guess, but it is
/// not exact to rounding: the null space and the coefficients along it come from linear
/// systems whose conditioning depends on the geometry. On exact data the pose is typically
/// right to 1e-12, but to 1e-7 only for the hardest random configurations tested (four
/// points, nearly flat targets); a flat target's points off its plane by less than 1e-6
/// of its extent are taken as on it. Polish the pose with [`super::refine`] when accuracy
/// matters. With noise, EPnP minimizes an algebraic error, not the reprojection error.
///
/// Errors: [`PnpError::MismatchedLengths`], [`PnpError::TooFewPoints`] (fewer than 4),
/// [`PnpError::NonFinite`], [`PnpError::Degenerate`] (points coincident or on one line),
/// [`PnpError::BehindCamera`] (every solution puts points behind the camera),
/// [`PnpError::NoSolution`] (numerical failure).
pub fn epnp(
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
) -> Result<Isometry3<f64>, PnpError> {
    check_solver_input(target_points, normalized, 4)?;
    let axes = PrincipalAxes::new(target_points)?;
    let thickness = axes.thickness();
    let directions: &[usize] = if thickness <= FLAT {
        &[2]
    } else if thickness <= THIN {
        &[3, 2]
    } else {
        &[3]
    };
    let mut best = Best::default();
    for &count in directions {
        let basis = Basis::new(target_points, &axes, count);
        let kernel = kernel(&basis.alphas, normalized)?;
        let constraints = DistanceConstraints::new(&basis.control_points, &kernel);
        for dimension in 1..=kernel.len() {
            for betas in constraints.initial_betas(dimension) {
                let betas = constraints.gauss_newton(betas);
                if let Some(pose) = pose_from_betas(&betas, &kernel, &basis.alphas, target_points) {
                    best.offer(pose, target_points, normalized);
                }
            }
        }
    }
    best.into_result(target_points.len())
}

/// The pose with the least reprojection error among those putting every point in front
/// of the camera, and the fewest points behind it among the others.
#[derive(Default)]
struct Best {
    pose: Option<(f64, Isometry3<f64>)>,
    least_behind: Option<usize>,
}

impl Best {
    fn offer(
        &mut self,
        pose: Isometry3<f64>,
        target_points: &[Point3<f64>],
        normalized: &[Point2<f64>],
    ) {
        match reprojection_rms(&pose, target_points, normalized) {
            Ok(rms) if self.pose.is_none_or(|(best_rms, _)| rms < best_rms) => {
                self.pose = Some((rms, pose));
            }
            Ok(_) => {}
            Err(behind) => {
                self.least_behind = Some(self.least_behind.map_or(behind, |b| b.min(behind)));
            }
        }
    }

    fn into_result(self, total: usize) -> Result<Isometry3<f64>, PnpError> {
        match (self.pose, self.least_behind) {
            (Some((_, pose)), _) => Ok(pose),
            (None, Some(count)) if count > 0 => Err(PnpError::BehindCamera { count, total }),
            _ => Err(PnpError::NoSolution(
                "no null-space solution gave a finite pose".into(),
            )),
        }
    }
}

/// The target points' centroid and principal directions, with the RMS spread of the
/// points along each, largest first.
struct PrincipalAxes {
    centroid: Vector3<f64>,
    axes: [(Vector3<f64>, f64); 3],
}

impl PrincipalAxes {
    /// Refuses points that coincide or lie on one line.
    fn new(target_points: &[Point3<f64>]) -> Result<Self, PnpError> {
        let n = target_points.len() as f64;
        let centroid = target_points
            .iter()
            .fold(Vector3::zeros(), |sum, p| sum + p.coords)
            / n;
        let scatter = target_points.iter().fold(Matrix3::zeros(), |sum, p| {
            let d = p.coords - centroid;
            sum + d * d.transpose()
        });
        let eigen = SymmetricEigen::new(scatter);
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
        let axes = order.map(|axis| {
            (
                eigen.eigenvectors.column(axis).into_owned(),
                (eigen.eigenvalues[axis].max(0.0) / n).sqrt(),
            )
        });
        let largest_coordinate = target_points
            .iter()
            .flat_map(|p| p.coords.iter().map(|v| v.abs()))
            .fold(0.0, f64::max);
        let [(_, major), (_, minor), _] = axes;
        if major <= MIN_RELATIVE_SPREAD * largest_coordinate.max(f64::MIN_POSITIVE) {
            return Err(PnpError::Degenerate("all target points coincide".into()));
        }
        if minor <= MIN_RELATIVE_WIDTH * major {
            return Err(PnpError::Degenerate("all points on one line".into()));
        }
        Ok(Self { centroid, axes })
    }

    /// The spread across the points' best-fit plane over the spread along their main
    /// direction: 0 for a planar target.
    fn thickness(&self) -> f64 {
        self.axes[2].1 / self.axes[0].1
    }
}

/// The control points and each target point's barycentric coordinates in them.
struct Basis {
    /// Control points in the target frame: the centroid, then one step of RMS spread
    /// along each of the first principal directions.
    control_points: Vec<Vector3<f64>>,
    /// Row `i` holds point `i`'s coordinates: `p_i = sum_j alphas[(i, j)] c_j`, summing
    /// to 1. With two directions, the points' offsets from their plane are dropped.
    alphas: DMatrix<f64>,
}

impl Basis {
    /// Control points along the first `directions` (2 or 3) principal axes.
    fn new(target_points: &[Point3<f64>], axes: &PrincipalAxes, directions: usize) -> Self {
        let centroid = axes.centroid;
        let directions = &axes.axes[..directions.min(3)];
        let mut control_points = vec![centroid];
        control_points.extend(directions.iter().map(|(e, s)| centroid + e * *s));
        let alphas = DMatrix::from_fn(target_points.len(), control_points.len(), |i, j| {
            let d = target_points[i].coords - centroid;
            let along = |(e, s): &(Vector3<f64>, f64)| e.dot(&d) / s;
            match j {
                0 => 1.0 - directions.iter().map(along).sum::<f64>(),
                _ => along(&directions[j - 1]),
            }
        });
        Self {
            control_points,
            alphas,
        }
    }
}

/// The null space of the projection equations: for each of its `k` smallest right
/// singular vectors (`k` the number of control points), smallest first, the camera-frame
/// control points it stands for.
///
/// A point's projection `(u, v)` gives `sum_j a_j (x_j - u z_j) = 0` and
/// `sum_j a_j (y_j - v z_j) = 0` for control points `(x_j, y_j, z_j)` in the camera frame.
fn kernel(
    alphas: &DMatrix<f64>,
    normalized: &[Point2<f64>],
) -> Result<Vec<Vec<Vector3<f64>>>, PnpError> {
    let k = alphas.ncols();
    // At least as many rows as unknowns, so that the SVD yields every right singular
    // vector.
    let mut m = DMatrix::<f64>::zeros((2 * normalized.len()).max(3 * k), 3 * k);
    for (i, q) in normalized.iter().enumerate() {
        for j in 0..k {
            let a = alphas[(i, j)];
            m[(2 * i, 3 * j)] = a;
            m[(2 * i, 3 * j + 2)] = -a * q.x;
            m[(2 * i + 1, 3 * j + 1)] = a;
            m[(2 * i + 1, 3 * j + 2)] = -a * q.y;
        }
    }
    let v_t = m
        .svd(false, true)
        .v_t
        .filter(|v_t| v_t.iter().all(|v| v.is_finite()))
        .ok_or_else(|| PnpError::NoSolution("SVD of the projection equations failed".into()))?;
    Ok((0..k)
        .map(|i| {
            let row = v_t.row(3 * k - 1 - i);
            (0..k)
                .map(|j| Vector3::new(row[3 * j], row[3 * j + 1], row[3 * j + 2]))
                .collect()
        })
        .collect())
}

/// The control points' distances, which the camera-frame control points
/// `c_j = sum_i beta_i kernel[i][j]` must keep: for each pair `(a, b)`,
/// `beta^T Q beta = rho`, with `Q[(i, l)] = dv_i . dv_l`,
/// `dv_i = kernel[i][a] - kernel[i][b]` and `rho = |c_a - c_b|^2` in the target frame.
struct DistanceConstraints {
    kernel_dimension: usize,
    q: Vec<DMatrix<f64>>,
    rho: Vec<f64>,
}

impl DistanceConstraints {
    fn new(control_points: &[Vector3<f64>], kernel: &[Vec<Vector3<f64>>]) -> Self {
        let k = control_points.len();
        let pairs: Vec<(usize, usize)> = (0..k)
            .flat_map(|a| (a + 1..k).map(move |b| (a, b)))
            .collect();
        let difference = |i: usize, (a, b): (usize, usize)| kernel[i][a] - kernel[i][b];
        let q = pairs
            .iter()
            .map(|&pair| {
                DMatrix::from_fn(kernel.len(), kernel.len(), |i, l| {
                    difference(i, pair).dot(&difference(l, pair))
                })
            })
            .collect();
        let rho = pairs
            .iter()
            .map(|&(a, b)| (control_points[a] - control_points[b]).norm_squared())
            .collect();
        Self {
            kernel_dimension: kernel.len(),
            q,
            rho,
        }
    }

    /// Initial coefficients for solutions in the span of the first `dimension` null-space
    /// vectors (the others zero), from the distance constraints made linear in the
    /// products `beta_i beta_l`.
    ///
    /// When the constraints are at least as many as the products, the products are their
    /// least-squares solution. Otherwise they are underdetermined, and two starts are
    /// tried: the paper's relinearization (the products must form a rank-1 matrix, whose
    /// 2x2 minors vanish: linear equations in the coordinates along the family of
    /// solutions and their products), when those equations determine it; and the
    /// products with `beta_1` alone, the others neglected.
    fn initial_betas(&self, dimension: usize) -> Vec<DVector<f64>> {
        let products: Vec<(usize, usize)> = (0..dimension)
            .flat_map(|i| (i..dimension).map(move |l| (i, l)))
            .collect();
        if products.len() <= self.rho.len() {
            return self
                .linearized(&products)
                .and_then(|b| rank_one(&self.product_matrix(&products, &b)))
                .into_iter()
                .collect();
        }
        let first_row: Vec<(usize, usize)> = (0..dimension).map(|l| (0, l)).collect();
        let from_first_row = self.linearized(&first_row).and_then(|b| {
            let first = b[0].abs().sqrt();
            let mut betas = DVector::zeros(self.kernel_dimension);
            for (l, value) in b.iter().enumerate() {
                betas[l] = value / first;
            }
            betas[0] = first;
            (first > 0.0 && betas.iter().all(|v| v.is_finite())).then_some(betas)
        });
        self.relinearized(dimension, &products)
            .into_iter()
            .chain(from_first_row)
            .collect()
    }

    /// The matrix of the distance constraints, linear in `products`.
    fn linear_system(&self, products: &[(usize, usize)]) -> DMatrix<f64> {
        DMatrix::from_fn(self.q.len(), products.len(), |p, c| {
            let (i, l) = products[c];
            let q = self.q[p][(i, l)];
            if i == l { q } else { 2.0 * q }
        })
    }

    /// The least-squares (minimum-norm) values of `products` under the distance
    /// constraints made linear in them.
    fn linearized(&self, products: &[(usize, usize)]) -> Option<DVector<f64>> {
        least_squares(
            self.linear_system(products),
            &DVector::from_column_slice(&self.rho),
        )
    }

    /// The symmetric matrix `B[(i, l)] = beta_i beta_l` from the values of `products`,
    /// sized to the whole null space.
    fn product_matrix(&self, products: &[(usize, usize)], values: &DVector<f64>) -> DMatrix<f64> {
        let mut b = DMatrix::zeros(self.kernel_dimension, self.kernel_dimension);
        for (&(i, l), &value) in products.iter().zip(values.iter()) {
            b[(i, l)] = value;
            b[(l, i)] = value;
        }
        b
    }

    /// The `products` (all of them, over the first `dimension` coefficients) by
    /// relinearization: they are `b0 + sum_k lambda_k w_k` (`b0` the least-squares
    /// solution, `w_k` the null space of the linear system), and every 2x2 minor of their
    /// matrix vanishes, which is linear in `1`, `lambda_k` and `lambda_k lambda_m`. `None`
    /// when those equations do not determine `lambda`.
    fn relinearized(&self, dimension: usize, products: &[(usize, usize)]) -> Option<DVector<f64>> {
        let system = self.linear_system(products);
        let family = products.len().checked_sub(self.rho.len())?;
        let b0 = least_squares(system.clone(), &DVector::from_column_slice(&self.rho))?;
        let w = null_space(system, family)?;
        let mut index = DMatrix::<usize>::zeros(dimension, dimension);
        for (c, &(i, l)) in products.iter().enumerate() {
            index[(i, l)] = c;
            index[(l, i)] = c;
        }
        // The product `beta_i beta_l` as an affine function of lambda: its constant, then
        // its coefficients.
        let affine = |i: usize, l: usize| -> DVector<f64> {
            let c = index[(i, l)];
            DVector::from_iterator(
                family + 1,
                std::iter::once(b0[c]).chain(w.row(c).iter().copied()),
            )
        };
        let quadratic: Vec<(usize, usize)> = (0..family)
            .flat_map(|k| (k..family).map(move |m| (k, m)))
            .collect();
        let unknowns = 1 + family + quadratic.len();
        let pairs: Vec<(usize, usize)> = (0..dimension)
            .flat_map(|a| (a + 1..dimension).map(move |b| (a, b)))
            .collect();
        let mut rows = Vec::new();
        for &(i, k) in &pairs {
            for &(j, l) in &pairs {
                // B_ij B_kl - B_il B_kj as a row over [1, lambda, lambda lambda].
                let mut row = DVector::zeros(unknowns);
                for (sign, f, g) in [
                    (1.0, affine(i, j), affine(k, l)),
                    (-1.0, affine(i, l), affine(k, j)),
                ] {
                    row[0] += sign * f[0] * g[0];
                    for m in 0..family {
                        row[1 + m] += sign * (f[0] * g[m + 1] + g[0] * f[m + 1]);
                    }
                    for (c, &(m, o)) in quadratic.iter().enumerate() {
                        let value = if m == o {
                            f[m + 1] * g[m + 1]
                        } else {
                            f[m + 1] * g[o + 1] + f[o + 1] * g[m + 1]
                        };
                        row[1 + family + c] += sign * value;
                    }
                }
                rows.push(row.transpose());
            }
        }
        let z = null_space(DMatrix::from_rows(&rows), 1)?;
        // A solution at infinity: lambda is not determined.
        if z[(0, 0)].abs() <= 1e-12 {
            return None;
        }
        let lambda = z.column(0).rows(1, family) / z[(0, 0)];
        rank_one(&self.product_matrix(products, &(b0 + w * lambda)))
    }

    /// The distance constraints' residuals `beta^T Q beta - rho` and their Jacobian
    /// `2 (Q beta)^T`.
    fn residuals(&self, betas: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let mut residuals = DVector::zeros(self.q.len());
        let mut jacobian = DMatrix::zeros(self.q.len(), betas.len());
        for (p, (q, rho)) in self.q.iter().zip(&self.rho).enumerate() {
            let q_beta = q * betas;
            residuals[p] = betas.dot(&q_beta) - rho;
            jacobian.row_mut(p).copy_from(&(2.0 * q_beta.transpose()));
        }
        (residuals, jacobian)
    }

    /// Gauss-Newton on all the coefficients, minimizing the squared residuals of the
    /// distance constraints; a step that does not decrease them ends it.
    fn gauss_newton(&self, mut betas: DVector<f64>) -> DVector<f64> {
        let (mut residuals, mut jacobian) = self.residuals(&betas);
        for _ in 0..GAUSS_NEWTON_ITERATIONS {
            let Some(step) = least_squares(jacobian.clone(), &-&residuals) else {
                break;
            };
            let candidate = &betas + step;
            let (new_residuals, new_jacobian) = self.residuals(&candidate);
            let new_cost = new_residuals.norm_squared();
            if new_cost.is_nan() || new_cost >= residuals.norm_squared() {
                break;
            }
            betas = candidate;
            residuals = new_residuals;
            jacobian = new_jacobian;
        }
        betas
    }
}

/// The `dimension` right singular vectors of `a` with the smallest singular values, as
/// columns; `None` when the next singular value vanishes too (the null space is larger)
/// or the SVD fails.
fn null_space(a: DMatrix<f64>, dimension: usize) -> Option<DMatrix<f64>> {
    let columns = a.ncols();
    // At least as many rows as columns, so that the SVD yields every right singular
    // vector.
    let rows = a.nrows().max(columns);
    let a = a.resize_vertically(rows, 0.0);
    let svd = a.svd(false, true);
    let v_t = svd.v_t?;
    let sigma = &svd.singular_values;
    let next = *sigma.get(columns.checked_sub(dimension + 1)?)?;
    if next.is_nan() || next <= 1e-10 * sigma.get(0)? {
        return None;
    }
    let rows = v_t.rows(columns - dimension, dimension);
    Some(rows.transpose()).filter(|n| n.iter().all(|v| v.is_finite()))
}

/// The coefficients `beta` with `beta beta^T` nearest to the symmetric `b`, from its
/// leading eigenpair; `None` unless that eigenvalue is positive.
fn rank_one(b: &DMatrix<f64>) -> Option<DVector<f64>> {
    let eigen = SymmetricEigen::new(b.clone());
    let (index, &largest) = eigen
        .eigenvalues
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    (largest > 0.0 && largest.is_finite())
        .then(|| eigen.eigenvectors.column(index) * largest.sqrt())
}

/// The minimum-norm least-squares solution of `a x = b`, by SVD, ignoring singular values
/// below `1e-12` of the largest.
fn least_squares(a: DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let svd = a.svd(true, true);
    let largest = svd.singular_values.iter().copied().fold(0.0, f64::max);
    if !(largest > 0.0 && largest.is_finite()) {
        return None;
    }
    svd.solve(b, 1e-12 * largest)
        .ok()
        .filter(|x| x.iter().all(|v| v.is_finite()))
}

/// The pose mapping `target_points` onto their camera-frame reconstruction from `betas`;
/// the reconstruction is mirrored through the camera centre when it lies behind it
/// (`beta` and `-beta` keep the same distances).
fn pose_from_betas(
    betas: &DVector<f64>,
    kernel: &[Vec<Vector3<f64>>],
    alphas: &DMatrix<f64>,
    target_points: &[Point3<f64>],
) -> Option<Isometry3<f64>> {
    let control_points: Vec<Vector3<f64>> = (0..alphas.ncols())
        .map(|j| {
            kernel
                .iter()
                .zip(betas.iter())
                .map(|(vector, beta)| vector[j] * *beta)
                .sum()
        })
        .collect();
    let mut in_camera: Vec<Vector3<f64>> = alphas
        .row_iter()
        .map(|a| a.iter().zip(&control_points).map(|(a, c)| c * *a).sum())
        .collect();
    if in_camera.iter().map(|p| p.z).sum::<f64>() < 0.0 {
        in_camera.iter_mut().for_each(|p| *p = -*p);
    }
    rigid_motion(target_points, &in_camera)
}

/// The rotation and translation best mapping `from` onto `to` in the least-squares
/// sense (Procrustes, with a proper rotation).
fn rigid_motion(from: &[Point3<f64>], to: &[Vector3<f64>]) -> Option<Isometry3<f64>> {
    let n = from.len() as f64;
    let from_centroid = from.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
    let to_centroid = to.iter().fold(Vector3::zeros(), |s, p| s + p) / n;
    let covariance = from.iter().zip(to).fold(Matrix3::zeros(), |s, (f, t)| {
        s + (t - to_centroid) * (f.coords - from_centroid).transpose()
    });
    let svd = covariance.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    // The singular values are sorted, so flipping the last axis fixes a reflection at
    // the least cost.
    let reflection =
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, (u * v_t).determinant().signum()));
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
        u * reflection * v_t,
    ));
    let translation = to_centroid - rotation * from_centroid;
    let pose = Isometry3::from_parts(Translation3::from(translation), rotation);
    (pose.rotation.coords.iter().all(|v| v.is_finite())
        && pose.translation.vector.iter().all(|v| v.is_finite()))
    .then_some(pose)
}

/// A pose's RMS reprojection error on the `z = 1` plane, or the number of points it puts
/// at or behind the camera (0 when the error is not finite).
fn reprojection_rms(
    pose: &Isometry3<f64>,
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
) -> Result<f64, usize> {
    let mut behind = 0;
    let mut sum = 0.0;
    for (p, q) in target_points.iter().zip(normalized) {
        let c = pose * p;
        if c.z > 0.0 {
            sum += (c.xy() / c.z - q).norm_squared();
        } else {
            behind += 1;
        }
    }
    let rms = (sum / target_points.len() as f64).sqrt();
    match behind {
        0 if rms.is_finite() => Ok(rms),
        _ => Err(behind),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::f64::consts::{PI, TAU};

    /// Target points, their normalized images, the true pose.
    struct Problem {
        target_points: Vec<Point3<f64>>,
        normalized: Vec<Point2<f64>>,
        camera_from_target: Isometry3<f64>,
    }

    fn rotation_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
        (a.rotation.inverse() * b.rotation).angle()
    }

    /// Translation error relative to the true distance.
    fn translation_error(estimate: &Isometry3<f64>, truth: &Isometry3<f64>) -> f64 {
        (estimate.translation.vector - truth.translation.vector).norm()
            / truth.translation.vector.norm()
    }

    fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        UnitQuaternion::from_scaled_axis(axis.normalize() * rng.random_range(0.0..PI))
    }

    /// Gaussian noise by the Box-Muller transform.
    fn gaussian(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
        let u: f64 = rng.random_range(f64::EPSILON..1.0);
        let v: f64 = rng.random_range(0.0..TAU);
        sigma * (-2.0 * u.ln()).sqrt() * v.cos()
    }

    /// `n` points in a box of the given half-extents around a random target-frame origin,
    /// seen from 3 to 8 m by a camera at a random orientation, all in front of it; image
    /// points with Gaussian noise of `sigma` (normalized units).
    fn problem(rng: &mut ChaCha8Rng, n: usize, half_extents: Vector3<f64>, sigma: f64) -> Problem {
        let box_from_target_rotation = random_rotation(rng);
        let box_centre = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let target_points: Vec<Point3<f64>> = (0..n)
            .map(|_| {
                let in_box = Vector3::new(
                    rng.random_range(-1.0..1.0) * half_extents.x,
                    rng.random_range(-1.0..1.0) * half_extents.y,
                    rng.random_range(-1.0..1.0) * half_extents.z,
                );
                Point3::from(box_centre + box_from_target_rotation * in_box)
            })
            .collect();
        let depth = rng.random_range(3.0..8.0);
        let rotation = random_rotation(rng);
        let aim = Vector3::new(
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.3..0.3),
            1.0,
        );
        let camera_from_target = Isometry3::from_parts(
            Translation3::from(aim * depth - rotation * box_centre),
            rotation,
        );
        let normalized = target_points
            .iter()
            .map(|p| {
                let c = camera_from_target * p;
                assert!(c.z > 0.0);
                Point2::new(
                    c.x / c.z + gaussian(rng, sigma),
                    c.y / c.z + gaussian(rng, sigma),
                )
            })
            .collect();
        Problem {
            target_points,
            normalized,
            camera_from_target,
        }
    }

    fn random_extents(rng: &mut ChaCha8Rng, planar: bool) -> Vector3<f64> {
        Vector3::new(
            rng.random_range(0.2..1.0),
            rng.random_range(0.2..1.0),
            if planar {
                0.0
            } else {
                rng.random_range(0.2..1.0)
            },
        )
    }

    fn assert_exact(problem: &Problem, context: &str) {
        let pose = epnp(&problem.target_points, &problem.normalized).unwrap();
        let truth = &problem.camera_from_target;
        // EPnP is not exact to rounding: the null space and the coefficients along it come
        // from linear systems whose conditioning depends on the geometry. Typically 1e-12,
        // 1e-7 at worst over thousands of random problems (four points, nearly flat sets).
        assert!(
            rotation_error(&pose, truth) < 1e-6,
            "{context}: rotation off by {:e}",
            rotation_error(&pose, truth)
        );
        assert!(
            translation_error(&pose, truth) < 1e-6,
            "{context}: translation off by {:e}",
            translation_error(&pose, truth)
        );
        assert!(problem.target_points.iter().all(|p| (pose * p).z > 0.0));
    }

    #[test]
    fn recovers_exact_poses_of_spatial_targets() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        for trial in 0..300 {
            let n = if trial < 50 {
                4
            } else {
                rng.random_range(5..60)
            };
            let extents = random_extents(&mut rng, false);
            let problem = problem(&mut rng, n, extents, 0.0);
            assert_exact(&problem, &format!("trial {trial}, {n} points"));
        }
    }

    #[test]
    fn recovers_exact_poses_of_planar_targets() {
        let mut rng = ChaCha8Rng::seed_from_u64(19);
        for trial in 0..300 {
            let n = if trial < 50 {
                4
            } else {
                rng.random_range(5..60)
            };
            let extents = random_extents(&mut rng, true);
            let problem = problem(&mut rng, n, extents, 0.0);
            assert_exact(&problem, &format!("trial {trial}, {n} points"));
        }
    }

    #[test]
    fn recovers_exact_poses_of_a_board_on_z_0() {
        // The target frame's own z = 0 plane: the scatter has an exactly zero eigenvalue.
        let board: Vec<Point3<f64>> = (0..6)
            .flat_map(|r| (0..9).map(move |c| Point3::new(c as f64 * 0.04, r as f64 * 0.04, 0.0)))
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        for trial in 0..100 {
            let tilt = UnitQuaternion::from_euler_angles(
                rng.random_range(-1.2..1.2),
                rng.random_range(-1.2..1.2),
                rng.random_range(0.0..TAU),
            );
            let camera_from_target = Isometry3::from_parts(
                Translation3::new(
                    rng.random_range(-0.3..0.3),
                    rng.random_range(-0.3..0.3),
                    1.5,
                ),
                tilt,
            ) * Translation3::new(-0.16, -0.1, 0.0);
            let normalized = board
                .iter()
                .map(|p| {
                    let c = camera_from_target * p;
                    Point2::from(c.xy() / c.z)
                })
                .collect();
            let problem = Problem {
                target_points: board.clone(),
                normalized,
                camera_from_target,
            };
            assert_exact(&problem, &format!("trial {trial}"));
        }
    }

    #[test]
    fn recovers_exact_poses_of_thin_targets() {
        // Between a flat target (three control points) and a thick one (four), both
        // solutions are tried.
        let mut rng = ChaCha8Rng::seed_from_u64(29);
        for thickness in [1e-9, 1e-7, 1e-5, 1e-4, 1e-3, 5e-3, 2e-2] {
            for trial in 0..40 {
                let n = rng.random_range(4..40);
                let extents = Vector3::new(0.5, 0.4, 0.5 * thickness);
                let problem = problem(&mut rng, n, extents, 0.0);
                assert_exact(&problem, &format!("thickness {thickness}, trial {trial}"));
            }
        }
    }

    /// The median and 90th percentile of `values`.
    fn median_and_p90(mut values: Vec<f64>) -> (f64, f64) {
        values.sort_by(f64::total_cmp);
        (values[values.len() / 2], values[values.len() * 9 / 10])
    }

    #[test]
    fn noisy_spatial_targets_land_close_to_the_truth() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        let (mut rotations, mut translations) = (Vec::new(), Vec::new());
        for _ in 0..200 {
            let extents = random_extents(&mut rng, false);
            // One pixel of noise at a focal length of 1000 pixels.
            let problem = problem(&mut rng, 50, extents, 1e-3);
            let pose = epnp(&problem.target_points, &problem.normalized).unwrap();
            rotations.push(rotation_error(&pose, &problem.camera_from_target).to_degrees());
            translations.push(translation_error(&pose, &problem.camera_from_target));
        }
        let (median, p90) = median_and_p90(rotations.clone());
        assert!(
            median < 0.4 && p90 < 1.0,
            "rotation error median {median} p90 {p90} deg"
        );
        assert!(rotations.iter().all(|&e| e < 3.0));
        let (median, p90) = median_and_p90(translations.clone());
        assert!(
            median < 0.003 && p90 < 0.008,
            "translation error median {median} p90 {p90}"
        );
        assert!(translations.iter().all(|&e| e < 0.03));
    }

    #[test]
    fn noisy_planar_targets_land_close_to_the_truth_or_explain_the_image_better() {
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        let mut rotations = Vec::new();
        for _ in 0..200 {
            let extents = random_extents(&mut rng, true);
            let problem = problem(&mut rng, 50, extents, 1e-3);
            let pose = epnp(&problem.target_points, &problem.normalized).unwrap();
            let error = rotation_error(&pose, &problem.camera_from_target).to_degrees();
            if error > 3.0 {
                // The planar ambiguity: the noise made another pose fit better.
                let rms =
                    |pose| reprojection_rms(pose, &problem.target_points, &problem.normalized);
                assert!(rms(&pose).unwrap() < rms(&problem.camera_from_target).unwrap());
            }
            rotations.push(error);
        }
        let (median, p90) = median_and_p90(rotations);
        assert!(
            median < 0.5 && p90 < 1.5,
            "rotation error median {median} p90 {p90} deg"
        );
    }

    #[test]
    fn refuses_degenerate_points() {
        let line: Vec<Point3<f64>> = (0..6)
            .map(|i| Point3::new(0.1 * i as f64, 0.2, 1.0))
            .collect();
        let image: Vec<Point2<f64>> = (0..6).map(|i| Point2::new(0.01 * i as f64, 0.0)).collect();
        assert_eq!(
            epnp(&line, &image),
            Err(PnpError::Degenerate("all points on one line".into()))
        );
        let same = vec![Point3::new(0.3, 0.2, 1.0); 6];
        assert_eq!(
            epnp(&same, &image),
            Err(PnpError::Degenerate("all target points coincide".into()))
        );
    }

    #[test]
    fn refuses_bad_input() {
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        let extents = random_extents(&mut rng, false);
        let mut problem = problem(&mut rng, 8, extents, 0.0);
        assert_eq!(
            epnp(&problem.target_points[..3], &problem.normalized[..3]),
            Err(PnpError::TooFewPoints { needed: 4, got: 3 })
        );
        assert_eq!(
            epnp(&problem.target_points, &problem.normalized[..7]),
            Err(PnpError::MismatchedLengths {
                target_points: 8,
                image_points: 7
            })
        );
        problem.normalized[2].y = f64::NAN;
        assert_eq!(
            epnp(&problem.target_points, &problem.normalized),
            Err(PnpError::NonFinite("image points"))
        );
        problem.target_points[5].x = f64::NEG_INFINITY;
        assert_eq!(
            epnp(&problem.target_points, &problem.normalized),
            Err(PnpError::NonFinite("target points"))
        );
    }
}
