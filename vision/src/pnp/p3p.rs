//! Lambda Twist P3P (Persson and Nordberg 2018).
//!
//! The pose of a camera from three target points and the rays on which it sees them:
//! "Lambda Twist: An Accurate Fast Robust Perspective Three Point (P3P) Solver", ECCV
//! 2018. The unknowns are the depths `lambda_i` of the points along their unit rays
//! `y_i`; the target's distances give three quadrics
//! `lambda_i^2 + lambda_j^2 - 2 (y_i . y_j) lambda_i lambda_j = |x_i - x_j|^2`.
//! Two homogeneous combinations `D1`, `D2` of them are blended into a singular
//! `D0 = D1 + gamma D2` by one real root `gamma` of a cubic; a singular indefinite
//! quadric is a pair of planes through the origin, found from the eigen-decomposition
//! of `D0`, and each plane meets the quadric `D1` (or `D2`) in at most two directions.
//! The depths so found are polished by Newton's method on the three original
//! equations, and the rotation follows from the two triangles, target and camera.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Sine of the angle below which two rays, or two edges of the target triangle, count
/// as parallel: the problem has no isolated solutions then.
const PARALLEL_SINE: f64 = 1e-9;
/// Newton steps on the depths after the closed-form solution (the paper's choice).
const DEPTH_NEWTON_STEPS: usize = 5;
/// Newton iterations allowed for the cubic's root, beyond which it is not improving.
const CUBIC_ITERATIONS: usize = 100;
/// Largest sine of the angle between a solved point and its ray for the pose to be
/// returned: solutions are accurate to far better, so this only drops the spurious
/// ones that the closed form produces for ill-conditioned intersections.
const RAY_TOLERANCE: f64 = 1e-10;

/// All real poses that put each target point on its ray (up to four), each
/// `camera_from_target`.
///
/// `target_points` are in the target frame (metres); `rays[i]` is the direction, in the
/// camera frame, on which `target_points[i]` is seen, of any nonzero length (a
/// normalized image point `(x, y)` gives the ray `(x, y, 1)`). Every returned pose is
/// finite and puts each point on the forward half of its ray at positive depth (for
/// rays with positive `z`, in front of the camera). Degenerate input returns no pose:
/// non-finite values, collinear or coincident target points, a zero ray, two parallel
/// or opposite rays. The poses come in no particular order.
pub fn lambda_twist(
    target_points: &[Point3<f64>; 3],
    rays: &[Vector3<f64>; 3],
) -> Vec<Isometry3<f64>> {
    let Some(problem) = Problem::new(target_points, rays) else {
        return Vec::new();
    };
    problem
        .depth_candidates()
        .into_iter()
        .map(|depths| problem.newton_depths(depths))
        .filter_map(|depths| problem.pose_from_depths(&depths))
        .filter(|pose| problem.puts_points_on_rays(pose))
        .collect()
}

/// The index pairs of the three distance equations, in the order of
/// [`Problem::squared_distances`] and [`Problem::ray_terms`].
const PAIRS: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];

/// A checked, non-degenerate P3P problem with unit rays.
struct Problem {
    points: [Point3<f64>; 3],
    rays: [Vector3<f64>; 3],
    /// `a_ij = |x_i - x_j|^2` for the pairs 12, 13, 23.
    squared_distances: [f64; 3],
    /// `b_ij = -2 y_i . y_j` for the pairs 12, 13, 23.
    ray_terms: [f64; 3],
}

impl Problem {
    fn new(points: &[Point3<f64>; 3], rays: &[Vector3<f64>; 3]) -> Option<Self> {
        let finite = |v: &Vector3<f64>| v.iter().all(|c| c.is_finite());
        if !points.iter().all(|p| finite(&p.coords)) || !rays.iter().all(finite) {
            return None;
        }
        let rays = rays.map(|ray| ray.try_normalize(0.0));
        let [Some(y1), Some(y2), Some(y3)] = rays else {
            return None;
        };
        let rays = [y1, y2, y3];
        let d12 = points[0] - points[1];
        let d13 = points[0] - points[2];
        let d23 = points[1] - points[2];
        let collinear = d12.cross(&d13).norm() <= PARALLEL_SINE * d12.norm() * d13.norm();
        let parallel_rays = PAIRS
            .iter()
            .any(|&(i, j)| rays[i].cross(&rays[j]).norm() <= PARALLEL_SINE);
        if collinear || parallel_rays {
            return None;
        }
        let ray_terms = PAIRS.map(|(i, j)| -2.0 * rays[i].dot(&rays[j]));
        Some(Self {
            points: *points,
            rays,
            squared_distances: [d12, d13, d23].map(|d| d.norm_squared()),
            ray_terms,
        })
    }

    /// The quadratic form `M_ij` with `lambda^T M_ij lambda = |lambda_i y_i - lambda_j y_j|^2`.
    fn pair_form(&self, pair: usize) -> Matrix3<f64> {
        let (i, j) = PAIRS[pair];
        let mut form = Matrix3::zeros();
        form[(i, i)] = 1.0;
        form[(j, j)] = 1.0;
        form[(i, j)] = 0.5 * self.ray_terms[pair];
        form[(j, i)] = 0.5 * self.ray_terms[pair];
        form
    }

    /// The depths (all positive, metres) that the closed form gives: up to two per
    /// plane of the singular quadric `D0`.
    fn depth_candidates(&self) -> Vec<Vector3<f64>> {
        let [a12, a13, a23] = self.squared_distances;
        let [m12, m13, m23] = [0, 1, 2].map(|pair| self.pair_form(pair));
        // Scale-free equations lambda^T D lambda = 0: D1 says that pair 12's camera
        // distance relates to pair 23's as in the target, D2 the same of pair 13.
        let d1 = m12 * a23 - m23 * a12;
        let d2 = m13 * a23 - m23 * a13;
        let Some(pencil) = SingularPencil::new(&d1, &d2) else {
            return Vec::new();
        };
        let Some(eigen) = KnownZeroEigen::new(&pencil.singular) else {
            return Vec::new();
        };
        eigen
            .plane_normals()
            .iter()
            .flat_map(|normal| directions_in_plane(normal, &pencil.intersecting))
            .filter_map(|direction| self.scaled_depths(&direction))
            .collect()
    }

    /// Depths along `direction` (either sign) at the target's scale, or `None` unless
    /// all three are positive.
    fn scaled_depths(&self, direction: &Vector3<f64>) -> Option<Vector3<f64>> {
        let direction = if direction.sum() < 0.0 {
            -direction
        } else {
            *direction
        };
        if !direction.iter().all(|&d| d > 0.0) {
            return None;
        }
        let camera_size: f64 = (0..3)
            .map(|pair| (direction.transpose() * self.pair_form(pair) * direction).x)
            .sum();
        let target_size: f64 = self.squared_distances.iter().sum();
        let depths = direction * (target_size / camera_size).sqrt();
        depths.iter().all(|d| d.is_finite()).then_some(depths)
    }

    /// The three distance equations' residuals at `depths`.
    fn residuals(&self, depths: &Vector3<f64>) -> Vector3<f64> {
        Vector3::from_fn(|pair, _| {
            let (i, j) = PAIRS[pair];
            let (li, lj) = (depths[i], depths[j]);
            li * li + lj * lj + self.ray_terms[pair] * li * lj - self.squared_distances[pair]
        })
    }

    /// Newton's method on the three distance equations, keeping only steps that reduce
    /// the residual (the closed form is already close: this removes its rounding).
    fn newton_depths(&self, mut depths: Vector3<f64>) -> Vector3<f64> {
        let [b12, b13, b23] = self.ray_terms;
        let scale: f64 = self.squared_distances.iter().sum();
        let mut residual = self.residuals(&depths);
        for _ in 0..DEPTH_NEWTON_STEPS {
            if residual.abs().sum() <= f64::EPSILON * scale {
                break;
            }
            let [l1, l2, l3] = [depths.x, depths.y, depths.z];
            #[rustfmt::skip]
            let jacobian = Matrix3::new(
                2.0 * l1 + b12 * l2, 2.0 * l2 + b12 * l1, 0.0,
                2.0 * l1 + b13 * l3, 0.0, 2.0 * l3 + b13 * l1,
                0.0, 2.0 * l2 + b23 * l3, 2.0 * l3 + b23 * l2,
            );
            let Some(step) = jacobian.lu().solve(&residual) else {
                break;
            };
            let candidate = depths - step;
            let candidate_residual = self.residuals(&candidate);
            // False for NaN too, which stops the iteration.
            let improves = candidate_residual.abs().sum() < residual.abs().sum();
            if !improves {
                break;
            }
            depths = candidate;
            residual = candidate_residual;
        }
        depths
    }

    /// The pose mapping the target triangle onto the camera-frame triangle the depths
    /// give; `None` for a mirrored or non-finite triangle.
    fn pose_from_depths(&self, depths: &Vector3<f64>) -> Option<Isometry3<f64>> {
        let [y1, y2, y3] = self.rays;
        let [c1, c2, c3] = [y1 * depths.x, y2 * depths.y, y3 * depths.z];
        let [x1, x2, x3] = self.points.map(|p| p.coords);
        let frame =
            |e1: Vector3<f64>, e2: Vector3<f64>| Matrix3::from_columns(&[e1, e2, e1.cross(&e2)]);
        let target = frame(x1 - x2, x1 - x3);
        let camera = frame(c1 - c2, c1 - c3);
        let rotation = nearest_rotation(&(camera * target.try_inverse()?))?;
        let translation = (c1 + c2 + c3) / 3.0 - rotation * ((x1 + x2 + x3) / 3.0);
        let pose = Isometry3::from_parts(
            Translation3::from(translation),
            UnitQuaternion::from_rotation_matrix(&rotation),
        );
        let finite = pose.translation.vector.iter().all(|v| v.is_finite())
            && pose.rotation.coords.iter().all(|v| v.is_finite());
        finite.then_some(pose)
    }

    /// Whether `pose` puts every target point on the forward half of its ray.
    fn puts_points_on_rays(&self, pose: &Isometry3<f64>) -> bool {
        self.points.iter().zip(&self.rays).all(|(point, ray)| {
            let p = (pose * point).coords;
            p.dot(ray) > 0.0 && p.cross(ray).norm() <= RAY_TOLERANCE * p.norm()
        })
    }
}

/// A singular member `F + gamma G` of the pencil of two quadrics, and the member used
/// to intersect its planes with.
struct SingularPencil {
    singular: Matrix3<f64>,
    intersecting: Matrix3<f64>,
}

impl SingularPencil {
    /// `det(D1 + gamma D2) = 0` is a cubic in `gamma`; its leading coefficient is
    /// `det(D2)`, so the roles swap when `det(D1)` is larger, keeping the monic cubic's
    /// coefficients bounded.
    fn new(d1: &Matrix3<f64>, d2: &Matrix3<f64>) -> Option<Self> {
        let (f, g) = if d2.determinant().abs() >= d1.determinant().abs() {
            (d1, d2)
        } else {
            (d2, d1)
        };
        let [c0, c1, c2, c3] = pencil_determinant(f, g);
        let gamma = if c3 == 0.0 {
            // Both determinants vanish: F itself is singular.
            0.0
        } else {
            steepest_real_root(c2 / c3, c1 / c3, c0 / c3)?
        };
        // On a plane of F + gamma G, F = -gamma G, so either member is zero exactly
        // where the other is: take the one that is larger there.
        let intersecting = if gamma.abs() <= 1.0 { *g } else { *f };
        Some(Self {
            singular: f + g * gamma,
            intersecting,
        })
    }
}

/// The coefficients `[c0, c1, c2, c3]` of `det(F + gamma G) = c0 + c1 gamma + c2
/// gamma^2 + c3 gamma^3`, from the columns of `F` and `G`.
fn pencil_determinant(f: &Matrix3<f64>, g: &Matrix3<f64>) -> [f64; 4] {
    let det = |a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>| a.dot(&b.cross(&c));
    let [f1, f2, f3] = [0, 1, 2].map(|i| f.column(i).into_owned());
    let [g1, g2, g3] = [0, 1, 2].map(|i| g.column(i).into_owned());
    [
        det(f1, f2, f3),
        det(g1, f2, f3) + det(f1, g2, f3) + det(f1, f2, g3),
        det(f1, g2, g3) + det(g1, f2, g3) + det(g1, g2, f3),
        det(g1, g2, g3),
    ]
}

/// A real root of the monic cubic `x^3 + b x^2 + c x + d`: where there are three, the
/// one the paper's starting point leads to, an outer root where the cubic is steep.
/// Newton's method kept inside a shrinking sign-change bracket, so it always converges.
/// `None` for non-finite coefficients.
fn steepest_real_root(b: f64, c: f64, d: f64) -> Option<f64> {
    if ![b, c, d].iter().all(|v| v.is_finite()) {
        return None;
    }
    let h = |x: f64| ((x + b) * x + c) * x + d;
    let slope = |x: f64| (3.0 * x + 2.0 * b) * x + c;
    // Cauchy's bound: every root lies strictly between -bound and bound.
    let bound = 1.0 + b.abs().max(c.abs()).max(d.abs());
    let (mut negative, mut positive) = (-bound, bound);
    let spread = b * b - 3.0 * c;
    let mut x = if spread > 0.0 {
        // Two stationary points: start from the outer root of the parabola that
        // approximates h around the one on the side where the root must lie.
        let v = spread.sqrt();
        let local_max = (-b - v) / 3.0;
        let at_max = h(local_max);
        if at_max > 0.0 {
            local_max - (at_max / v).sqrt()
        } else {
            let local_min = (-b + v) / 3.0;
            local_min + (-h(local_min) / v).max(0.0).sqrt()
        }
    } else {
        // Monotonic: start at the inflection point, where h is least steep.
        -b / 3.0
    };
    for _ in 0..CUBIC_ITERATIONS {
        let value = h(x);
        if value == 0.0 {
            return Some(x);
        }
        if value < 0.0 {
            negative = x;
        } else {
            positive = x;
        }
        let newton = x - value / slope(x);
        let (low, high) = (negative.min(positive), negative.max(positive));
        let next = if newton > low && newton < high {
            newton
        } else {
            0.5 * (low + high)
        };
        let converged = (next - x).abs() <= 4.0 * f64::EPSILON * x.abs();
        x = next;
        if converged {
            break;
        }
    }
    x.is_finite().then_some(x)
}

/// The eigen-decomposition of a symmetric 3x3 matrix known to have one zero
/// eigenvalue: the other two from the characteristic polynomial divided by `sigma`,
/// their eigenvectors as cross products of rows of `M - sigma I`.
struct KnownZeroEigen {
    /// The eigenvalue of largest magnitude.
    sigma1: f64,
    /// Its unit eigenvector.
    e1: Vector3<f64>,
    /// The other nonzero eigenvalue.
    sigma2: f64,
    /// Its unit eigenvector, when it can be told apart from the null space.
    e2: Option<Vector3<f64>>,
}

impl KnownZeroEigen {
    fn new(m: &Matrix3<f64>) -> Option<Self> {
        let trace = m.trace();
        let minors = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(0, 1)] + m[(0, 0)] * m[(2, 2)]
            - m[(0, 2)] * m[(0, 2)]
            + m[(1, 1)] * m[(2, 2)]
            - m[(1, 2)] * m[(1, 2)];
        // sigma^2 - trace sigma + minors = 0; real for a symmetric matrix.
        let root = (trace * trace - 4.0 * minors).max(0.0).sqrt();
        let sigma1 = 0.5 * (trace + trace.signum() * root);
        if sigma1 == 0.0 || !sigma1.is_finite() {
            return None;
        }
        let sigma2 = minors / sigma1;
        let e1 = null_vector(&(m - Matrix3::identity() * sigma1))?;
        let e2 = null_vector(&(m - Matrix3::identity() * sigma2))
            .and_then(|e2| (e2 - e1 * e1.dot(&e2)).try_normalize(0.0));
        Some(Self {
            sigma1,
            e1,
            sigma2,
            e2,
        })
    }

    /// The normals of the planes through the origin on which the quadric is zero:
    /// `sigma1 (e1.l)^2 + sigma2 (e2.l)^2 = sigma1 ((e1 - s e2).l) ((e1 + s e2).l)` with
    /// `s = sqrt(-sigma2 / sigma1)`. Two planes for an indefinite matrix, one (the plane
    /// through the null vector and `e2`) when it is semi-definite.
    fn plane_normals(&self) -> Vec<Vector3<f64>> {
        let s_squared = -self.sigma2 / self.sigma1;
        match self.e2 {
            Some(e2) if s_squared > 0.0 => {
                let s = s_squared.sqrt();
                vec![self.e1 - e2 * s, self.e1 + e2 * s]
            }
            _ => vec![self.e1],
        }
    }
}

/// The unit vector spanning the null space of a rank-2 symmetric matrix: the longest
/// cross product of two of its rows.
fn null_vector(m: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let [r0, r1, r2] = [0, 1, 2].map(|i| m.row(i).transpose());
    [r0.cross(&r1), r0.cross(&r2), r1.cross(&r2)]
        .into_iter()
        .max_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))
        .and_then(|v| v.try_normalize(0.0))
        .filter(|v| v.iter().all(|c| c.is_finite()))
}

/// The directions in the plane through the origin with `normal` on which the quadric
/// `conic` is zero: none, one or two.
fn directions_in_plane(normal: &Vector3<f64>, conic: &Matrix3<f64>) -> Vec<Vector3<f64>> {
    let Some(n) = normal.try_normalize(0.0) else {
        return Vec::new();
    };
    // The coordinate axis most nearly in the plane gives the best-conditioned basis.
    let axis = Vector3::ith(n.iamin(), 1.0);
    let Some(p) = n.cross(&axis).try_normalize(0.0) else {
        return Vec::new();
    };
    let q = n.cross(&p);
    // In the plane, l = alpha p + beta q and the quadric reads
    // A alpha^2 + 2 B alpha beta + C beta^2.
    let a = p.dot(&(conic * p));
    let b = q.dot(&(conic * p));
    let c = q.dot(&(conic * q));
    let discriminant = b * b - a * c;
    // A tangent plane (a double solution) can come out slightly negative by rounding.
    if discriminant < -1e-12 * (b * b + (a * c).abs()) {
        return Vec::new();
    }
    let discriminant = discriminant.max(0.0);
    // With r = -B - sign(B) sqrt(disc), the zero directions are (r, A) and (C, r):
    // no cancellation, no division.
    let r = -b - b.signum() * discriminant.sqrt();
    let mut directions: Vec<_> = [p * r + q * a, p * c + q * r]
        .into_iter()
        .filter(|d| d.norm_squared() > 0.0)
        .collect();
    if discriminant == 0.0 {
        // Both are the one double direction (or one is zero).
        directions.truncate(1);
    }
    directions
}

/// The rotation nearest to `m` in the Frobenius norm; `None` if `m` is a reflection or
/// its decomposition fails.
fn nearest_rotation(m: &Matrix3<f64>) -> Option<Rotation3<f64>> {
    let svd = m.svd(true, true);
    let rotation = svd.u? * svd.v_t?;
    (rotation.determinant() > 0.0).then(|| Rotation3::from_matrix_unchecked(rotation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random pose and three well-spread points in front of it, inside a 100 degree
    /// field of view, with their rays at random lengths.
    fn random_problem(
        rng: &mut ChaCha8Rng,
    ) -> (Isometry3<f64>, [Point3<f64>; 3], [Vector3<f64>; 3]) {
        loop {
            let in_camera: [Point3<f64>; 3] = std::array::from_fn(|_| {
                let z = rng.random_range(0.3..8.0);
                Point3::new(
                    z * rng.random_range(-1.2..1.2),
                    z * rng.random_range(-1.2..1.2),
                    z,
                )
            });
            let d12 = in_camera[1] - in_camera[0];
            let d13 = in_camera[2] - in_camera[0];
            let spread = d12.cross(&d13).norm() / (d12.norm() * d13.norm());
            let rays_apart = PAIRS.iter().all(|&(i, j)| {
                in_camera[i]
                    .coords
                    .normalize()
                    .cross(&in_camera[j].coords.normalize())
                    .norm()
                    > 0.01
            });
            if spread < 0.05 || !rays_apart {
                continue;
            }
            let axis = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let rotation = UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_normalize(axis),
                rng.random_range(-3.1..3.1),
            );
            let translation = Vector3::new(
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
            );
            let truth = Isometry3::from_parts(Translation3::from(translation), rotation);
            let target = in_camera.map(|p| truth.inverse() * p);
            let rays = in_camera.map(|p| p.coords * rng.random_range(0.1..10.0));
            return (truth, target, rays);
        }
    }

    fn reprojection_error(pose: &Isometry3<f64>, point: &Point3<f64>, ray: &Vector3<f64>) -> f64 {
        let p = pose * point;
        ((p.coords.xy() / p.z) - (ray.xy() / ray.z)).norm()
    }

    #[test]
    fn finds_the_true_pose_among_few_exact_solutions() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut counts = [0usize; 5];
        for trial in 0..500 {
            let (truth, points, rays) = random_problem(&mut rng);
            let poses = lambda_twist(&points, &rays);
            assert!(poses.len() <= 4, "trial {trial}: {} poses", poses.len());
            counts[poses.len()] += 1;
            for pose in &poses {
                for (point, ray) in points.iter().zip(&rays) {
                    let p = pose * point;
                    assert!(p.z > 0.0, "trial {trial}: point behind the camera");
                    let error = reprojection_error(pose, point, ray);
                    assert!(error < 1e-9, "trial {trial}: reprojection error {error:e}");
                }
            }
            let found = poses.iter().any(|pose| {
                let rotation = (pose.rotation * truth.rotation.inverse()).angle();
                let translation = (pose.translation.vector - truth.translation.vector).norm()
                    / truth.translation.vector.norm();
                rotation < 1e-6 && translation < 1e-6
            });
            assert!(found, "trial {trial}: true pose missing among {poses:?}");
        }
        // The problems are generic: several have more than one solution.
        assert_eq!(counts[0], 0);
        assert!(counts[2] + counts[3] + counts[4] > 25, "{counts:?}");
    }

    #[test]
    fn accuracy_is_near_machine_precision() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut worst = 0.0f64;
        for _ in 0..300 {
            let (truth, points, rays) = random_problem(&mut rng);
            let best = lambda_twist(&points, &rays)
                .iter()
                .map(|pose| (pose.inverse() * truth).rotation.angle())
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(best);
        }
        assert!(worst < 1e-9, "worst rotation error {worst:e} rad");
    }

    #[test]
    fn refuses_degenerate_input() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (_, points, rays) = random_problem(&mut rng);
        assert!(!lambda_twist(&points, &rays).is_empty());

        let mut collinear = points;
        collinear[2] = points[0] + (points[1] - points[0]) * 2.5;
        assert!(lambda_twist(&collinear, &rays).is_empty());

        let mut coincident = points;
        coincident[1] = points[0];
        assert!(lambda_twist(&coincident, &rays).is_empty());

        let mut parallel = rays;
        parallel[2] = rays[0] * 3.0;
        assert!(lambda_twist(&points, &parallel).is_empty());

        let mut opposite = rays;
        opposite[1] = -rays[0];
        assert!(lambda_twist(&points, &opposite).is_empty());

        let mut zero = rays;
        zero[0] = Vector3::zeros();
        assert!(lambda_twist(&points, &zero).is_empty());

        let mut nan = points;
        nan[1].x = f64::NAN;
        assert!(lambda_twist(&nan, &rays).is_empty());

        let mut infinite = rays;
        infinite[2].z = f64::INFINITY;
        assert!(lambda_twist(&points, &infinite).is_empty());
    }

    #[test]
    fn cubic_root_is_a_root() {
        // (x - 1)(x - 2)(x + 3), a triple root, and a monotonic cubic.
        for (b, c, d) in [(0.0, -7.0, 6.0), (-3.0, 3.0, -1.0), (1.0, 5.0, -2.0)] {
            let x = steepest_real_root(b, c, d).unwrap();
            let value: f64 = ((x + b) * x + c) * x + d;
            assert!(value.abs() < 1e-12, "h({x}) = {value}");
        }
        assert_eq!(steepest_real_root(f64::NAN, 0.0, 0.0), None);
    }
}
