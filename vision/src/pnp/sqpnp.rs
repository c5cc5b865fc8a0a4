//! SQPnP (Terzakis and Lourakis 2020): globally optimal PnP for 3 or more points.
//!
//! From "A Consistently Fast and Globally Optimal Solution to the Perspective-n-Point
//! Problem" (ECCV 2020). Write the rotation `R` of `camera_from_target` as the 9-vector
//! `r` of its rows, so that `R M = A(M) r` with `A(M) = diag(M^T, M^T, M^T)`. For a
//! normalized image point `m = (x, y)` let `B(m) = [1 0 -x; 0 1 -y]` and
//! `Q(m) = B^T B`. The objective is
//!
//! `E(R, t) = sum_i || B(m_i) (R M_i + t) ||^2`,
//!
//! the squared distance on the `z = 1` plane between each observation and the
//! projection of its point, weighted by the point's squared depth. For a given `r` the
//! best translation is linear in it, `t = P r` with
//! `P = -(sum Q_i)^-1 sum Q_i A_i`, and then `E = r^T Omega r` with
//! `Omega = sum A_i^T Q_i A_i + (sum Q_i A_i)^T P`, a positive semi-definite 9x9
//! matrix. SQPnP minimizes `r^T Omega r` over rotations by sequential quadratic
//! programming (SQP) on the orthogonality constraints, started from the rotations
//! nearest to the eigenvectors of `Omega` spanning its null space (or of its least
//! eigenvalue), both signs; further eigenvectors are tried while the best error found
//! exceeds three times their eigenvalue. A planar target makes `Omega` rank deficient
//! (its null space holds every `r` that only changes the rotation's normal column):
//! every null vector is a start.
//!
//! Where this implementation goes beyond the paper, each for a failure seen on random
//! problems:
//! - the target points are centred on their centroid and scaled to unit RMS radius
//!   before `Omega` is built, so its conditioning and the rank test do not depend on
//!   the target frame's origin or units;
//! - `Omega` is decomposed by the symmetric eigensolver (nalgebra's SVD returned
//!   inaccurate null vectors for some);
//! - every SQP iterate is a rotation: the step is taken in the tangent space and
//!   mapped to the nearest rotation (in closed form), and a step that would raise the
//!   objective is retried with Levenberg-Marquardt damping; near a minimum the step
//!   uses the Hessian of the Lagrangian rather than `Omega` alone: with noisy, weakly
//!   constraining points the paper's iteration can cycle or diverge;
//! - a minimum with every point behind the camera is also restarted from its planar
//!   twin (half a turn about the target's thinnest direction), which for a planar
//!   target explains the image equally well with every point in front;
//! - with 3 points, where up to four exact poses are all global minima, SQP also
//!   starts from sums and differences of pairs and triples of null vectors, so that
//!   close-together exact poses are not missed (about 1 in 1000 random triples still
//!   loses one; the p3p module finds them all in closed form).

use nalgebra::{
    Isometry3, Matrix3, Point2, Point3, Rotation3, SMatrix, SVector, Translation3, UnitQuaternion,
    Vector3,
};

use super::{PnpError, check_solver_input};
use crate::rotation::nearest_rotation;

type Vector9 = SVector<f64, 9>;
type Matrix9 = SMatrix<f64, 9, 9>;
type Matrix3x9 = SMatrix<f64, 3, 9>;
type Matrix9x3 = SMatrix<f64, 9, 3>;

/// Fewest correspondences SQPnP accepts.
const MIN_POINTS: usize = 3;
/// Eigenvalues of `Omega` below this fraction of the largest count as zero (rounding
/// leaves about 1e-15): their eigenvectors span the null space, all of which are used
/// as starting points.
const RANK_TOLERANCE: f64 = 1e-10;
/// Largest null space of `Omega` a pose can be found from: a rotation has 3 degrees of
/// freedom, 9 entries and 6 constraints.
const MAX_NULL_SPACE: usize = 6;
/// `||E E^T - I||_F^2` below which a scaled null vector `E` is already a rotation (up to
/// sign) and only needs polishing by SQP, from one sign.
const ORTHOGONALITY_TOLERANCE: f64 = 1e-8;
/// SQP has converged once a step's squared norm falls below this (the 9-vector of a
/// rotation has norm sqrt(3)).
const SQP_STEP_TOLERANCE: f64 = 1e-20;
/// Squared step norm below which SQP has converged as far as rounding allows once steps
/// stop shrinking (the reference implementation's only criterion).
const SQP_LOOSE_TOLERANCE: f64 = 1e-10;
/// SQP runs still moving after this many steps are abandoned (a handful is typical;
/// nearly degenerate data needs tens).
const SQP_MAX_ITERATIONS: usize = 100;
/// Longest step along the constraints' null space, in 9-vector norm (about 0.7 rad of
/// rotation): Newton steps from a nearly singular model are cut to this.
const SQP_MAX_TANGENT_STEP: f64 = 1.0;
/// First Levenberg-Marquardt damping of a refused step, relative to the scale of
/// `Omega` (see [`Sqp`]); each further refusal multiplies it by ten.
const SQP_INITIAL_DAMPING: f64 = 1e-9;
/// Refused steps in a row after which the run is abandoned.
const SQP_MAX_REFUSALS: usize = 30;
/// Rise of `r^T Omega r` a step may cause, relative to the scale of `Omega`: rounding,
/// so that converged iterations are not stopped by noise.
const SQP_OBJECTIVE_SLACK: f64 = 1e-12;
/// Two minima whose rotation matrices differ by less than this (squared Frobenius norm,
/// about 1e-4 rad) are the same minimum.
const SAME_ROTATION_TOLERANCE: f64 = 1e-8;
/// Target points whose spread across their main axis is below this fraction of their
/// spread along it lie on one line.
const COLLINEARITY_TOLERANCE: f64 = 1e-6;
/// Target points whose RMS distance to their centroid is below this fraction of the
/// centroid's distance to the origin coincide (to rounding).
const COINCIDENCE_TOLERANCE: f64 = 1e-10;
/// Image points whose RMS distance to their mean is below this (normalized units, a
/// thousandth of a pixel at a focal length of 1000 px) coincide.
const IMAGE_SPREAD_TOLERANCE: f64 = 1e-6;
/// Inverse iterations for `Omega`'s least eigenvector before the full decomposition
/// takes over: each gains the ratio of the two least eigenvalues, about a thousandth
/// on noisy points, so a handful is typical.
const INVERSE_ITERATIONS: usize = 20;
/// Residual `|Omega x - (x^T Omega x) x|` below which inverse iteration's `x` is an
/// eigenvector to rounding, relative to the trace of `Omega`.
const EIGENVECTOR_RESIDUAL: f64 = 1e-14;
/// Iteration cap of the SVD and eigen-decompositions.
const DECOMPOSITION_MAX_ITERATIONS: usize = 1000;

/// One local minimum SQPnP found.
#[derive(Clone, Debug, PartialEq)]
pub struct SqpnpSolution {
    /// The pose, mapping target points (target frame, metres) to the camera frame (x
    /// right, y down, z forward, metres). Every target point is in front of the camera.
    pub camera_from_target: Isometry3<f64>,
    /// SQPnP's objective at this pose, square metres:
    /// `sum_i (X_i - x_i Z_i)^2 + (Y_i - y_i Z_i)^2` where `(X_i, Y_i, Z_i)` is target
    /// point `i` in the camera frame and `(x_i, y_i)` its normalized image point. Each
    /// term is the squared distance on the `z = 1` plane between the observation and
    /// the projection `(X_i / Z_i, Y_i / Z_i)`, times `Z_i^2`: the paper's
    /// `r^T Omega r`. It is zero for an exact fit.
    pub squared_error: f64,
}

/// All minima found, best (least squared_error) first; target points in any
/// configuration (planar or not), n >= 3.
///
/// `target_points` are in the target frame (metres); `normalized[i]` is the undistorted
/// normalized image point `(X/Z, Y/Z)` of `target_points[i]` (see
/// [`super::Correspondences`]). Each returned pose is a local minimum of the objective
/// described at [`SqpnpSolution::squared_error`], with every point in front of the
/// camera; the first is the least found, which SQPnP's search makes the global minimum
/// of that objective. Duplicates are merged; with 3 points several exact poses may be
/// returned.
///
/// Cost: a fraction of a millisecond for 4 or more points; about 10 ms for 3 points,
/// which get many more SQP starts (see the module documentation).
///
/// Errors: [`PnpError::MismatchedLengths`], [`PnpError::TooFewPoints`] (fewer than 3),
/// [`PnpError::NonFinite`], [`PnpError::Degenerate`] when the target points coincide or
/// lie on one line, the image points coincide, or the points leave the pose undetermined
/// (a target seen edge-on), [`PnpError::BehindCamera`] when every
/// minimum found puts points behind the camera (counted for the best of them),
/// [`PnpError::NoSolution`] on numerical failure.
pub fn sqpnp(
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
) -> Result<Vec<SqpnpSolution>, PnpError> {
    check_solver_input(target_points, normalized, MIN_POINTS)?;
    let frame = TargetFrame::fit(target_points)?;
    let local: Vec<Point3<f64>> = target_points.iter().map(|p| frame.to_local(p)).collect();
    let problem = Problem::new(&local, normalized)?;
    let search = Search::run(&problem, &frame.thinnest)?;
    let mut solutions: Vec<SqpnpSolution> = search
        .minima
        .iter()
        .filter_map(|minimum| frame.solution(minimum, target_points, normalized))
        .collect();
    if solutions.is_empty() {
        return Err(search.refusal(target_points.len()));
    }
    solutions.sort_by(|a, b| a.squared_error.total_cmp(&b.squared_error));
    Ok(solutions)
}

/// The similarity that centres the target points on their centroid and scales them to
/// unit RMS radius: `local = (target - centroid) / scale`.
struct TargetFrame {
    centroid: Vector3<f64>,
    scale: f64,
    /// Unit direction of least spread of the target points: a planar target's normal.
    thinnest: Vector3<f64>,
}

impl TargetFrame {
    /// Fits the frame, refusing coincident and collinear target points.
    fn fit(points: &[Point3<f64>]) -> Result<Self, PnpError> {
        let n = points.len() as f64;
        let centroid = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
        let scatter = points
            .iter()
            .map(|p| {
                let d = p.coords - centroid;
                d * d.transpose()
            })
            .sum::<Matrix3<f64>>()
            / n;
        let scale = scatter.trace().sqrt();
        if !(centroid.iter().all(|v| v.is_finite()) && scale.is_finite()) {
            return Err(PnpError::NoSolution(
                "target coordinates too large to compute with".into(),
            ));
        }
        if scale <= COINCIDENCE_TOLERANCE * centroid.norm() {
            return Err(PnpError::Degenerate("all target points coincide".into()));
        }
        let eigen = (scatter / (scale * scale))
            .try_symmetric_eigen(f64::EPSILON, DECOMPOSITION_MAX_ITERATIONS)
            .ok_or_else(|| PnpError::NoSolution("target point spread not computed".into()))?;
        let mut order = [0, 1, 2];
        order.sort_by(|&i, &j| eigen.eigenvalues[j].total_cmp(&eigen.eigenvalues[i]));
        let [along, across, _] = order.map(|i| eigen.eigenvalues[i]);
        if across.max(0.0).sqrt() <= COLLINEARITY_TOLERANCE * along.sqrt() {
            return Err(PnpError::Degenerate("all target points on one line".into()));
        }
        Ok(Self {
            centroid,
            scale,
            thinnest: eigen.eigenvectors.column(order[2]).normalize(),
        })
    }

    fn to_local(&self, point: &Point3<f64>) -> Point3<f64> {
        Point3::from((point.coords - self.centroid) / self.scale)
    }

    /// The pose in the original target frame of a minimum found in the local frame, if
    /// it is finite and puts every original point in front of the camera.
    fn solution(
        &self,
        minimum: &Minimum,
        target_points: &[Point3<f64>],
        normalized: &[Point2<f64>],
    ) -> Option<SqpnpSolution> {
        let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            minimum.rotation,
        ));
        // camera point = scale * (R local + t_local) and local = (target - centroid) / scale.
        let translation = minimum.translation * self.scale - rotation * self.centroid;
        let camera_from_target = Isometry3::from_parts(Translation3::from(translation), rotation);
        let mut squared_error = 0.0;
        for (point, image) in target_points.iter().zip(normalized) {
            let c = camera_from_target * point;
            if !in_front(&c.coords) {
                return None;
            }
            squared_error += point_error(&c.coords, image);
        }
        let finite = squared_error.is_finite()
            && camera_from_target
                .translation
                .vector
                .iter()
                .all(|v| v.is_finite())
            && camera_from_target
                .rotation
                .coords
                .iter()
                .all(|v| v.is_finite());
        finite.then_some(SqpnpSolution {
            camera_from_target,
            squared_error,
        })
    }
}

/// Whether a point in the camera frame is in front of the camera (false for NaN).
fn in_front(c: &Vector3<f64>) -> bool {
    c.z > 0.0
}

/// The objective's term for one point: `||B(m) c||^2` for the point `c` in the camera
/// frame and its normalized image point `m`.
fn point_error(c: &Vector3<f64>, m: &Point2<f64>) -> f64 {
    (c.x - m.x * c.z).powi(2) + (c.y - m.y * c.z).powi(2)
}

/// `Q(m) = B(m)^T B(m) = [1 0 -x; 0 1 -y; -x -y x^2+y^2]` for `B(m) = [1 0 -x; 0 1 -y]`
/// has entries `0` or `+-w_k` with the weights `w = (1, x, y, x^2 + y^2)`: entry
/// `(a, b)` as `(sign, k)`, sign 0 for the zeros.
fn metric_entry(a: usize, b: usize) -> (f64, usize) {
    match (a.min(b), a.max(b)) {
        (0, 0) | (1, 1) => (1.0, 0),
        (0, 2) => (-1.0, 1),
        (1, 2) => (-1.0, 2),
        (2, 2) => (1.0, 3),
        _ => (0.0, 0),
    }
}

/// The row-major 9-vector of a 3x3 matrix.
fn to_vector(m: &Matrix3<f64>) -> Vector9 {
    Vector9::from_column_slice(m.transpose().as_slice())
}

/// The 3x3 matrix of a row-major 9-vector.
fn to_matrix(r: &Vector9) -> Matrix3<f64> {
    Matrix3::from_row_slice(r.as_slice())
}

/// The quadratic problem in the local target frame: `Omega` and `P`.
struct Problem<'a> {
    points: &'a [Point3<f64>],
    image: &'a [Point2<f64>],
    omega: Matrix9,
    p: Matrix3x9,
}

impl<'a> Problem<'a> {
    /// With `A(M)` the 3x9 matrix such that `A(M) r = R M`, the 3x3 block `(a, b)` of
    /// `A^T Q A` is `Q_ab M M^T` and that of `Q A` is `Q_ab M^T`: the sums over the
    /// points reduce to sums of `w_k`, `w_k M` and `w_k M M^T` for the four weights of
    /// [`metric_entry`].
    fn new(points: &'a [Point3<f64>], image: &'a [Point2<f64>]) -> Result<Self, PnpError> {
        check_image_spread(image)?;
        let mut weights = [0.0; 4];
        let mut first = [Vector3::zeros(); 4];
        let mut second = [Matrix3::zeros(); 4];
        for (point, m) in points.iter().zip(image) {
            let w = [1.0, m.x, m.y, m.x * m.x + m.y * m.y];
            let outer = point.coords * point.coords.transpose();
            for k in 0..4 {
                weights[k] += w[k];
                first[k] += point.coords * w[k];
                second[k] += outer * w[k];
            }
        }
        let q_sum = Matrix3::from_fn(|a, b| {
            let (sign, k) = metric_entry(a, b);
            sign * weights[k]
        });
        let qa_sum = Matrix3x9::from_fn(|a, col| {
            let (sign, k) = metric_entry(a, col / 3);
            sign * first[k][col % 3]
        });
        let mut omega = Matrix9::from_fn(|row, col| {
            let (sign, k) = metric_entry(row / 3, col / 3);
            sign * second[k][(row % 3, col % 3)]
        });
        let q_inverse = q_sum.cholesky().map(|c| c.inverse()).ok_or_else(|| {
            PnpError::NoSolution("the image points' normal matrix is not invertible".into())
        })?;
        let p = -q_inverse * qa_sum;
        omega += qa_sum.transpose() * p;
        // Rounding leaves Omega slightly asymmetric; its eigenvectors must be orthogonal.
        omega = (omega + omega.transpose()) * 0.5;
        if !(omega.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            return Err(PnpError::NoSolution(
                "image coordinates too large to compute with".into(),
            ));
        }
        Ok(Self {
            points,
            image,
            omega,
            p,
        })
    }

    /// Eigenvectors (columns) and eigenvalues of `Omega`, largest eigenvalue first.
    fn eigen(&self) -> Result<(Matrix9, Vector9), PnpError> {
        // The symmetric eigensolver: nalgebra's SVD of some such Omegas returns a last
        // singular vector far less accurate than its singular value suggests.
        let eigen = self
            .omega
            .try_symmetric_eigen(f64::EPSILON, DECOMPOSITION_MAX_ITERATIONS)
            .ok_or_else(|| PnpError::NoSolution("decomposition of Omega failed".into()))?;
        let mut order: [usize; 9] = std::array::from_fn(|i| i);
        order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
        let vectors = Matrix9::from_fn(|row, col| eigen.eigenvectors[(row, order[col])]);
        let values = Vector9::from_fn(|i, _| eigen.eigenvalues[order[i]]);
        Ok((vectors, values))
    }

    /// The unit eigenvector of `Omega`'s least eigenvalue, by inverse iteration, when
    /// `Omega` has no null space by a margin (`Omega - RANK_TOLERANCE tr(Omega) I` is
    /// positive definite, so every eigenvalue is above [`RANK_TOLERANCE`] times the
    /// largest) and the iteration converges to a backward-stable eigenvector (residual
    /// within [`EIGENVECTOR_RESIDUAL`] of the trace); `None` otherwise, and the full
    /// decomposition decides.
    fn least_eigenvector(&self) -> Option<Vector9> {
        let trace = self.omega.trace();
        // The shifted matrix has the same eigenvectors, and its factor serves as both
        // the test and the inverse iteration's solver.
        let factor = (self.omega - Matrix9::identity() * (RANK_TOLERANCE * trace)).cholesky()?;
        let mut x = Vector9::repeat(1.0 / 3.0);
        for _ in 0..INVERSE_ITERATIONS {
            x = factor.solve(&x);
            let norm = x.norm();
            if !(norm.is_finite() && norm > 0.0) {
                return None;
            }
            x /= norm;
            let omega_x = self.omega * x;
            let residual = omega_x - x * x.dot(&omega_x);
            if residual.norm() <= EIGENVECTOR_RESIDUAL * trace {
                return Some(x);
            }
        }
        None
    }

    /// Whether every eigenvalue of `Omega` but the least (of the unit eigenvector
    /// `least`) exceeds `bound`: by Sylvester's law of inertia, exactly when `Omega`
    /// with `least`'s eigenvalue lifted above `bound`, minus `bound`, is positive
    /// definite.
    fn others_exceed(&self, least: &Vector9, bound: f64) -> bool {
        if !bound.is_finite() {
            return false;
        }
        let lift = self.omega.trace() + bound.abs();
        (self.omega + least * least.transpose() * lift - Matrix9::identity() * bound)
            .cholesky()
            .is_some()
    }

    /// Translation, objective and points behind the camera of a rotation, local frame.
    fn evaluate(&self, rotation: &Matrix3<f64>) -> Evaluation {
        let translation = self.p * to_vector(rotation);
        let mut error = 0.0;
        let mut behind = 0;
        for (point, m) in self.points.iter().zip(self.image) {
            let c = rotation * point.coords + translation;
            error += point_error(&c, m);
            if !in_front(&c) {
                behind += 1;
            }
        }
        Evaluation {
            translation,
            error,
            behind,
        }
    }
}

/// Refuses image points that all coincide: they leave the translation undetermined
/// (the normal matrix `sum Q_i` is singular).
fn check_image_spread(image: &[Point2<f64>]) -> Result<(), PnpError> {
    let n = image.len() as f64;
    let mean = image
        .iter()
        .map(|m| m.coords)
        .sum::<nalgebra::Vector2<f64>>()
        / n;
    let variance = image
        .iter()
        .map(|m| (m.coords - mean).norm_squared())
        .sum::<f64>()
        / n;
    // A NaN (overflow) passes on to the check of Omega.
    if variance.sqrt() <= IMAGE_SPREAD_TOLERANCE {
        return Err(PnpError::Degenerate("all image points coincide".into()));
    }
    Ok(())
}

/// A rotation's translation `P r`, objective and count of points behind the camera.
struct Evaluation {
    translation: Vector3<f64>,
    error: f64,
    behind: usize,
}

/// A minimum found by the search, in the local target frame.
struct Minimum {
    rotation: Matrix3<f64>,
    translation: Vector3<f64>,
    error: f64,
}

/// The SQP runs from the eigenvectors of `Omega` and what they found.
struct Search<'p, 'a> {
    problem: &'p Problem<'a>,
    sqp: Sqp<'p>,
    /// Least objective over the minima in front of the camera so far.
    best_error: f64,
    /// Distinct minima with every point in front of the camera.
    minima: Vec<Minimum>,
    /// Least objective, and its count of points behind the camera, over the finite
    /// minima refused for cheirality.
    best_refused: Option<(f64, usize)>,
    /// Every rotation a run converged to, kept or refused: a later run that comes this
    /// close is stopped, as it would only find it again.
    reached: Vec<Matrix3<f64>>,
    /// Rotation by half a turn about the target's thinnest direction.
    half_turn: Matrix3<f64>,
}

impl<'p, 'a> Search<'p, 'a> {
    /// Searches the minima of `problem`, whose target points spread least along the
    /// unit vector `thinnest`.
    fn run(problem: &'p Problem<'a>, thinnest: &Vector3<f64>) -> Result<Self, PnpError> {
        let mut search = Self {
            problem,
            sqp: Sqp {
                omega: &problem.omega,
                scale: problem.omega.trace(),
            },
            best_error: f64::INFINITY,
            minima: Vec::new(),
            best_refused: None,
            reached: Vec::new(),
            half_turn: thinnest * thinnest.transpose() * 2.0 - Matrix3::identity(),
        };
        // Without a null space the eigenvector of the least eigenvalue stands in for it.
        // When Omega is positive definite well above rounding, that eigenvector comes
        // from inverse iteration, and the full decomposition is only needed if a further
        // eigenvector might improve on the minimum found (see below).
        let least = problem.least_eigenvector();
        if let Some(e) = &least {
            search.start_from_null_vector(&(e * 3f64.sqrt()));
            if problem.others_exceed(e, search.best_error / 3.0) {
                return Ok(search);
            }
        }
        let (u, s) = problem.eigen()?;
        let largest = s[0];
        search.sqp.scale = largest;
        let null_dimension = s.iter().filter(|&&v| v <= RANK_TOLERANCE * largest).count();
        if null_dimension > MAX_NULL_SPACE {
            return Err(PnpError::Degenerate(format!(
                "the image points do not determine a pose: Omega has a null space of \
                 dimension {null_dimension}, at most {MAX_NULL_SPACE} allowed (a target \
                 seen edge-on?)"
            )));
        }
        let first_null = 9 - null_dimension.max(1);
        if least.is_none() {
            let null_vectors: Vec<Vector9> =
                (first_null..9).map(|i| u.column(i) * 3f64.sqrt()).collect();
            for e in &null_vectors {
                search.start_from_null_vector(e);
            }
            if null_dimension == MAX_NULL_SPACE {
                search.start_from_null_space_combinations(&null_vectors);
            }
        }
        // A rotation's 9-vector has squared norm 3, so a minimum near the eigenvector of
        // eigenvalue s costs at least about 3 s: further eigenvectors can only improve on
        // the best error while it exceeds that.
        for index in (1..first_null).rev() {
            if search.best_error <= 3.0 * s[index] {
                break;
            }
            search.start_from_eigenvector(&u.column(index).into_owned());
        }
        Ok(search)
    }

    /// A null vector scaled to the norm of a rotation's 9-vector: when it already is an
    /// orthogonal matrix, its sign with positive determinant is (nearly) a minimum and
    /// only needs polishing; otherwise SQP starts from both signs.
    fn start_from_null_vector(&mut self, e: &Vector9) {
        if orthogonality_error(e) < ORTHOGONALITY_TOLERANCE {
            let m = to_matrix(e);
            let proper = if m.determinant() < 0.0 { -m } else { m };
            self.run_from(&proper);
        } else {
            self.start_from_eigenvector(e);
        }
    }

    /// With three points every exact pose (up to four) is a global minimum, and the
    /// null vectors alone may start SQP in the basins of only some of them when they lie
    /// close together: SQP also starts from the sums and differences of every pair and
    /// every triple of null vectors.
    fn start_from_null_space_combinations(&mut self, null_vectors: &[Vector9]) {
        for (a, first) in null_vectors.iter().enumerate() {
            for (b, second) in null_vectors.iter().enumerate().skip(a + 1) {
                for pair in [first + second, first - second] {
                    self.start_from_eigenvector(&pair);
                    for third in null_vectors.iter().skip(b + 1) {
                        self.start_from_eigenvector(&(pair + third));
                        self.start_from_eigenvector(&(pair - third));
                    }
                }
            }
        }
    }

    /// SQP from the rotations nearest to `e` and to `-e`.
    fn start_from_eigenvector(&mut self, e: &Vector9) {
        for start in [*e, -e] {
            self.run_from(&to_matrix(&start));
        }
    }

    /// SQP from the rotation nearest to `m`.
    fn run_from(&mut self, m: &Matrix3<f64>) {
        if let Some(end) =
            nearest_rotation(m).and_then(|start| self.sqp.run_until(&start, &self.reached))
        {
            self.consider(&end, true);
        }
    }

    /// Keeps the rotation a run ended at as a minimum when it puts every point in
    /// front of the camera.
    ///
    /// A planar target seen with every point behind the camera has a twin that explains
    /// the image equally well with every point in front: the rotation composed with half
    /// a turn about the target's normal maps each point `M` to `-R M`, and the
    /// translation `P r` changes sign with it. SQP then also runs from that twin
    /// (exact for a planar target, a nearby start for a nearly planar one).
    fn consider(&mut self, rotation: &Matrix3<f64>, try_twin: bool) {
        let rotation = *rotation;
        let evaluation = self.problem.evaluate(&rotation);
        if !(evaluation.error.is_finite() && evaluation.translation.iter().all(|v| v.is_finite())) {
            return;
        }
        self.reached.push(rotation);
        if evaluation.behind > 0 {
            if self
                .best_refused
                .is_none_or(|(error, _)| evaluation.error < error)
            {
                self.best_refused = Some((evaluation.error, evaluation.behind));
            }
            if try_twin
                && evaluation.behind == self.problem.points.len()
                && let Some(end) = self
                    .sqp
                    .run_until(&(rotation * self.half_turn), &self.reached)
            {
                self.consider(&end, false);
            }
            return;
        }
        self.best_error = self.best_error.min(evaluation.error);
        let minimum = Minimum {
            rotation,
            translation: evaluation.translation,
            error: evaluation.error,
        };
        match self.minima.iter_mut().find(|known| {
            (known.rotation - minimum.rotation).norm_squared() < SAME_ROTATION_TOLERANCE
        }) {
            Some(known) if minimum.error < known.error => *known = minimum,
            Some(_) => {}
            None => self.minima.push(minimum),
        }
    }

    /// Why no pose is returned.
    fn refusal(&self, total: usize) -> PnpError {
        match self.best_refused {
            Some((_, count)) => PnpError::BehindCamera { count, total },
            None => PnpError::NoSolution("no SQP run ended at a finite rotation".into()),
        }
    }
}

/// `||E E^T - I||_F^2` for the 3x3 matrix `E` of `e`.
fn orthogonality_error(e: &Vector9) -> f64 {
    let m = to_matrix(e);
    (m * m.transpose() - Matrix3::identity()).norm_squared()
}

/// The SQP iteration on `r^T Omega r` over rotations.
///
/// Every iterate is a rotation, where the constraints' Jacobian has a closed-form null
/// space, the tangent space `{[w]x R}`: a step is a 3-vector `w`, and the nearest
/// rotation to `R + [w]x R` is `R` turned about `w` by `atan |w|`. No decomposition is
/// needed inside the iteration.
struct Sqp<'o> {
    omega: &'o Matrix9,
    /// The scale of the objective and its Hessian: the largest eigenvalue of `Omega`,
    /// or its trace (at most nine times that) where only the least eigenvector was
    /// computed.
    scale: f64,
}

/// An SQP iterate: a rotation and what the next step needs of it.
struct Iterate {
    rotation: Matrix3<f64>,
    /// `Omega r`: half the objective's gradient.
    gradient: Vector9,
    /// The objective `r^T Omega r`.
    error: f64,
}

impl Sqp<'_> {
    fn iterate(&self, rotation: Matrix3<f64>) -> Iterate {
        let r = to_vector(&rotation);
        let gradient = self.omega * r;
        Iterate {
            rotation,
            gradient,
            error: r.dot(&gradient),
        }
    }

    /// SQP from the rotation `start` until a step becomes negligible: the rotation it
    /// converges to, or `None` when it does not converge within the iteration cap.
    #[cfg(test)]
    fn run(&self, start: &Matrix3<f64>) -> Option<Matrix3<f64>> {
        self.run_until(start, &[])
    }

    /// SQP from the rotation `start` until a step becomes negligible: the rotation it
    /// converges to, or `None` when it does not converge within the iteration cap or
    /// comes within [`SAME_ROTATION_TOLERANCE`] of a rotation of `known`.
    ///
    /// A step that would raise the objective is refused and retried with
    /// Levenberg-Marquardt damping: the objective never rises, so the iteration cannot
    /// cycle or diverge. When only a damped step is accepted and it gains nothing
    /// measurable, the iterate is a minimum as far as the objective can tell (a flat
    /// valley of nearly degenerate data).
    fn run_until(&self, start: &Matrix3<f64>, known: &[Matrix3<f64>]) -> Option<Matrix3<f64>> {
        let is_known = |rotation: &Matrix3<f64>| {
            known
                .iter()
                .any(|k| (k - rotation).norm_squared() < SAME_ROTATION_TOLERANCE)
        };
        let mut iterate = self.iterate(*start);
        let mut damping = 0.0;
        let mut previous = f64::INFINITY;
        for _ in 0..SQP_MAX_ITERATIONS {
            if is_known(&iterate.rotation) {
                return None;
            }
            let model = TangentModel::at(self.omega, &iterate);
            let descent = self.descend(&iterate, &model, &mut damping)?;
            let size = (descent.iterate.rotation - iterate.rotation).norm_squared();
            let stalled = descent.damped && iterate.error - descent.iterate.error <= self.slack();
            iterate = descent.iterate;
            // Below the loose tolerance, steps that stop shrinking are rounding noise.
            if size <= SQP_STEP_TOLERANCE
                || (size <= SQP_LOOSE_TOLERANCE && size > 0.25 * previous)
                || stalled
            {
                return Some(iterate.rotation);
            }
            previous = size;
        }
        (previous <= SQP_LOOSE_TOLERANCE).then_some(iterate.rotation)
    }

    fn slack(&self) -> f64 {
        SQP_OBJECTIVE_SLACK * self.scale
    }

    /// The first step from `iterate`, damped more at each refusal, whose rotation does
    /// not raise the objective (up to rounding). `damping` carries over between
    /// iterations: a tenth of it after an accepted step.
    fn descend(
        &self,
        iterate: &Iterate,
        model: &TangentModel,
        damping: &mut f64,
    ) -> Option<Descent> {
        for _ in 0..SQP_MAX_REFUSALS {
            let candidate = model
                .step(*damping)
                .map(|w| self.iterate(turned(&iterate.rotation, &w)))
                .filter(|candidate| candidate.error <= iterate.error + self.slack());
            if let Some(candidate) = candidate {
                let damped = *damping > 0.0;
                *damping = if *damping > 10.0 * SQP_INITIAL_DAMPING * self.scale {
                    *damping / 10.0
                } else {
                    0.0
                };
                return Some(Descent {
                    iterate: candidate,
                    damped,
                });
            }
            *damping = if *damping > 0.0 {
                *damping * 10.0
            } else {
                SQP_INITIAL_DAMPING * self.scale
            };
        }
        None
    }
}

/// Where an accepted step of [`Sqp::descend`] lands.
struct Descent {
    iterate: Iterate,
    /// Whether the step was damped.
    damped: bool,
}

/// The rotation nearest to `R + [w]x R`: `R` turned about `w` by `atan |w|` (the
/// orthogonal polar factor of `I + [w]x`), by Rodrigues' formula with
/// `cos = c = 1 / sqrt(1 + |w|^2)`, `sin = c |w|`, so `1 - cos = c^2 |w|^2 / (1 + c)`.
fn turned(rotation: &Matrix3<f64>, w: &Vector3<f64>) -> Matrix3<f64> {
    let c = (1.0 + w.norm_squared()).sqrt().recip();
    let k = w.cross_matrix();
    (Matrix3::identity() + k * c + k * k * (c * c / (1.0 + c))) * rotation
}

/// The quadratic model of one SQP step at a rotation `R` (9-vector `r`) for
/// `min r^T Omega r` subject to `R R^T = I`. At a rotation the constraints hold, so the
/// step lies in their Jacobian's null space, the tangent space spanned by the
/// orthonormal `N = [n_1 n_2 n_3]`, `n_k = vec([e_k]x R) / sqrt 2`: the step `N y`
/// minimizes the model `y^T W y / 2 + y^T N^T Omega r`, and `N y = vec([w]x R)` with
/// `w = y / sqrt 2`.
///
/// The model's Hessian `W` is the reduced Hessian of the Lagrangian,
/// `N^T Omega N - N^T (T (x) I) N` with the least-squares multipliers `T`, where it is
/// positive definite (near a minimum), and the paper's `N^T Omega N` elsewhere. The
/// paper's is exact at an exact fit; where the objective's gradient across the
/// constraints is large against its curvature along them (noisy points that hardly fix
/// the pose) it alone makes SQP cycle or diverge near the minimum, the Lagrangian's does
/// not.
struct TangentModel {
    /// `W`.
    hessian: Matrix3<f64>,
    /// `N^T Omega r`.
    gradient: Vector3<f64>,
}

impl TangentModel {
    fn at(omega: &Matrix9, iterate: &Iterate) -> Self {
        let rotation = &iterate.rotation;
        // With G the 3x3 matrix of Omega r, G R^T splits into a skew part, the gradient
        // along the tangent space (n_k^T Omega r = <[e_k]x, G R^T> / sqrt 2), and a
        // symmetric part T, the least-squares multipliers (T R = G). The constraints'
        // curvature along the tangent space is then (tr(T) I - T) / 2.
        let g_rt = to_matrix(&iterate.gradient) * rotation.transpose();
        let gradient = Vector3::new(
            g_rt[(2, 1)] - g_rt[(1, 2)],
            g_rt[(0, 2)] - g_rt[(2, 0)],
            g_rt[(1, 0)] - g_rt[(0, 1)],
        ) * std::f64::consts::FRAC_1_SQRT_2;
        let t = (g_rt + g_rt.transpose()) * 0.5;
        let omega_hessian = tangent_hessian(omega, rotation);
        let lagrangian = omega_hessian - (Matrix3::identity() * t.trace() - t) * 0.5;
        let hessian = if is_positive_definite(&lagrangian) {
            lagrangian
        } else {
            omega_hessian
        };
        Self { hessian, gradient }
    }

    /// The rotation vector `w` of the step minimizing the model damped by
    /// `damping * |y|^2 / 2`, its length in 9-vector norm cut to
    /// [`SQP_MAX_TANGENT_STEP`]; `None` when the damped `W` is not positive definite.
    fn step(&self, damping: f64) -> Option<Vector3<f64>> {
        let damped = self.hessian + Matrix3::identity() * damping;
        let mut y = -solve_positive_definite(&damped, &self.gradient)?;
        let length = y.norm();
        if length > SQP_MAX_TANGENT_STEP {
            y *= SQP_MAX_TANGENT_STEP / length;
        }
        let w = y * std::f64::consts::FRAC_1_SQRT_2;
        w.iter().all(|v| v.is_finite()).then_some(w)
    }
}

/// `N^T Omega N` at the rotation `R`, for the tangent basis `n_k = vec([e_k]x R) / sqrt 2`:
/// with `a`, `b`, `c` the rows of `R`, `n_1 = (0; -c; b)`, `n_2 = (c; 0; -a)` and
/// `n_3 = (-b; a; 0)` (over `sqrt 2`), so that each `Omega n_k` takes two column blocks
/// of `Omega`, and each `n_k^T` two row blocks of `Omega N`.
fn tangent_hessian(omega: &Matrix9, rotation: &Matrix3<f64>) -> Matrix3<f64> {
    let row = |k: usize| rotation.row(k).transpose() * std::f64::consts::FRAC_1_SQRT_2;
    let (a, b, c) = (row(0), row(1), row(2));
    let column_block = |k: usize| omega.fixed_columns::<3>(3 * k);
    let omega_n = Matrix9x3::from_columns(&[
        column_block(2) * b - column_block(1) * c,
        column_block(0) * c - column_block(2) * a,
        column_block(1) * a - column_block(0) * b,
    ]);
    let row_block = |k: usize| omega_n.fixed_rows::<3>(3 * k);
    Matrix3::from_rows(&[
        b.tr_mul(&row_block(2)) - c.tr_mul(&row_block(1)),
        c.tr_mul(&row_block(0)) - a.tr_mul(&row_block(2)),
        a.tr_mul(&row_block(1)) - b.tr_mul(&row_block(0)),
    ])
}

/// The adjugate (its rows, equal to its columns) and the determinant of a symmetric
/// 3x3 matrix, if it is positive definite: by Sylvester's criterion, when its leading
/// principal minors `a_00`, the upper-left 2x2 one and the determinant are positive.
fn positive_definite_adjugate(a: &Matrix3<f64>) -> Option<([Vector3<f64>; 3], f64)> {
    let (c0, c1, c2) = (a.column(0), a.column(1), a.column(2));
    let rows = [c1.cross(&c2), c2.cross(&c0), c0.cross(&c1)];
    let determinant = c0.dot(&rows[0]);
    (a[(0, 0)] > 0.0 && rows[2].z > 0.0 && determinant > 0.0).then_some((rows, determinant))
}

/// Whether a symmetric 3x3 matrix is positive definite.
fn is_positive_definite(a: &Matrix3<f64>) -> bool {
    positive_definite_adjugate(a).is_some()
}

/// The solution of `a x = b` for a symmetric 3x3 `a` by its adjugate; `None` unless `a`
/// is positive definite. In the SQP's inner loop this costs one division, a Cholesky
/// factorization a chain of three square roots and several divisions.
fn solve_positive_definite(a: &Matrix3<f64>, b: &Vector3<f64>) -> Option<Vector3<f64>> {
    let (adjugate, determinant) = positive_definite_adjugate(a)?;
    Some(Vector3::from_fn(|i, _| adjugate[i].dot(b)) / determinant)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraModel, Distortion, Intrinsics};
    use crate::pnp::{Correspondences, refine};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Focal length of the test camera, pixels.
    const FOCAL: f64 = 800.0;
    /// Standard deviation of the pixel noise of the noisy problems, pixels.
    const NOISE_PX: f64 = 0.5;
    /// Point counts of the random problems.
    const COUNTS: [usize; 12] = [3, 4, 5, 6, 7, 8, 10, 15, 20, 35, 60, 100];

    fn camera() -> CameraModel {
        CameraModel {
            width: 1600,
            height: 1200,
            intrinsics: Intrinsics {
                fx: FOCAL,
                fy: FOCAL,
                cx: 800.0,
                cy: 600.0,
            },
            distortion: Distortion::none(),
        }
    }

    fn unit_vector(rng: &mut ChaCha8Rng) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let norm = v.norm();
            if norm > 0.1 && norm <= 1.0 {
                return v / norm;
            }
        }
    }

    fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
        let u: f64 = rng.random_range(f64::EPSILON..1.0);
        let v: f64 = rng.random_range(0.0..1.0);
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }

    struct Synthetic {
        truth: Isometry3<f64>,
        points: Vec<Point3<f64>>,
        pixels: Vec<Point2<f64>>,
    }

    impl Synthetic {
        fn normalized(&self) -> Vec<Point2<f64>> {
            self.correspondences().normalized
        }

        fn correspondences(&self) -> Correspondences {
            Correspondences::new(&camera(), &self.points, &self.pixels).unwrap()
        }
    }

    /// A random pose seeing `n` random target points 2 to 5 m away, off the target
    /// frame's origin: in a cube, or on the plane z = 0 seen at most 60 degrees from
    /// its normal (from either side). Pixels exact or with Gaussian noise.
    fn random_problem(rng: &mut ChaCha8Rng, n: usize, planar: bool, noise_px: f64) -> Synthetic {
        let offset = Vector3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            if planar {
                0.0
            } else {
                rng.random_range(-2.0..2.0)
            },
        );
        let points: Vec<Point3<f64>> = (0..n)
            .map(|_| {
                let z = if planar {
                    0.0
                } else {
                    rng.random_range(-0.5..0.5)
                };
                Point3::from(
                    offset
                        + Vector3::new(rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5), z),
                )
            })
            .collect();
        let rotation = if planar {
            let spin = UnitQuaternion::from_scaled_axis(
                Vector3::z() * rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
            );
            let axis = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                0.0,
            );
            let tilt =
                UnitQuaternion::from_scaled_axis(axis.normalize() * rng.random_range(0.0..1.05));
            let side = if rng.random_range(0.0..1.0) < 0.5 {
                UnitQuaternion::identity()
            } else {
                UnitQuaternion::from_scaled_axis(Vector3::x() * std::f64::consts::PI)
            };
            tilt * side * spin
        } else {
            UnitQuaternion::from_scaled_axis(
                unit_vector(rng) * rng.random_range(0.0..std::f64::consts::PI),
            )
        };
        let centroid = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n as f64;
        let seen_at = Vector3::new(
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.5..0.5),
            rng.random_range(2.0..5.0),
        );
        let truth =
            Isometry3::from_parts(Translation3::from(seen_at - rotation * centroid), rotation);
        let camera = camera();
        let pixels = points
            .iter()
            .map(|p| {
                let pixel = camera.project(&(truth * p)).unwrap();
                pixel + nalgebra::Vector2::new(gaussian(rng), gaussian(rng)) * noise_px
            })
            .collect();
        Synthetic {
            truth,
            points,
            pixels,
        }
    }

    /// Rotation angle (radians) and relative translation error of `pose` from `truth`.
    fn pose_error(pose: &Isometry3<f64>, truth: &Isometry3<f64>) -> (f64, f64) {
        let angle = pose.rotation.angle_to(&truth.rotation);
        let translation = (pose.translation.vector - truth.translation.vector).norm()
            / truth.translation.vector.norm();
        (angle, translation)
    }

    /// SQPnP's objective of a pose.
    fn objective(pose: &Isometry3<f64>, points: &[Point3<f64>], normalized: &[Point2<f64>]) -> f64 {
        points
            .iter()
            .zip(normalized)
            .map(|(p, m)| point_error(&(pose * p).coords, m))
            .sum()
    }

    /// The objective at the local minimum SQP reaches from the true rotation.
    fn local_minimum_from_truth(problem: &Synthetic) -> f64 {
        let normalized = problem.normalized();
        let frame = TargetFrame::fit(&problem.points).unwrap();
        let local: Vec<_> = problem.points.iter().map(|p| frame.to_local(p)).collect();
        let quadratic = Problem::new(&local, &normalized).unwrap();
        let (_, eigenvalues) = quadratic.eigen().unwrap();
        let sqp = Sqp {
            omega: &quadratic.omega,
            scale: eigenvalues[0],
        };
        let start = problem.truth.rotation.to_rotation_matrix().into_inner();
        let end = sqp.run(&start).unwrap();
        quadratic.evaluate(&end).error * frame.scale * frame.scale
    }

    fn assert_valid(solutions: &[SqpnpSolution], points: &[Point3<f64>]) {
        assert!(!solutions.is_empty());
        for pair in solutions.windows(2) {
            assert!(pair[0].squared_error <= pair[1].squared_error);
        }
        for solution in solutions {
            let pose = &solution.camera_from_target;
            assert!(solution.squared_error.is_finite() && solution.squared_error >= 0.0);
            assert!(pose.translation.vector.iter().all(|v| v.is_finite()));
            assert!((pose.rotation.norm() - 1.0).abs() < 1e-12);
            assert!(points.iter().all(|p| (pose * p).z > 0.0));
        }
    }

    fn check_exact(planar: bool, seed: u64) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for n in COUNTS {
            for _ in 0..12 {
                let problem = random_problem(&mut rng, n, planar, 0.0);
                let solutions = sqpnp(&problem.points, &problem.normalized()).unwrap();
                assert_valid(&solutions, &problem.points);
                // Three points have up to four exact poses: the truth is one of them.
                let candidates = if n == 3 {
                    &solutions[..]
                } else {
                    &solutions[..1]
                };
                let (angle, translation) = candidates
                    .iter()
                    .map(|s| pose_error(&s.camera_from_target, &problem.truth))
                    .min_by(|a, b| (a.0 + a.1).total_cmp(&(b.0 + b.1)))
                    .unwrap();
                assert!(
                    angle < 1e-8 && translation < 1e-8,
                    "n {n}: rotation {angle:e} rad, translation {translation:e}"
                );
                assert!(
                    solutions[0].squared_error < 1e-15,
                    "n {n}: {:e}",
                    solutions[0].squared_error
                );
            }
        }
    }

    #[test]
    fn recovers_exact_non_planar_poses() {
        check_exact(false, 1);
    }

    #[test]
    fn recovers_exact_planar_poses() {
        check_exact(true, 2);
    }

    fn check_noisy(planar: bool, seed: u64) {
        let camera = camera();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for n in COUNTS {
            for trial in 0..10 {
                let problem = random_problem(&mut rng, n, planar, NOISE_PX);
                let correspondences = problem.correspondences();
                let normalized = &correspondences.normalized;
                let solutions = sqpnp(&problem.points, normalized)
                    .unwrap_or_else(|e| panic!("n {n}, trial {trial}: {e}"));
                assert_valid(&solutions, &problem.points);
                let best = &solutions[0];
                let recomputed = objective(&best.camera_from_target, &problem.points, normalized);
                assert!((best.squared_error - recomputed).abs() <= 1e-12 * recomputed);

                // Global optimality in SQPnP's own objective: no pose near the truth does
                // better, whether the truth, its pixel refinement, or the objective's local
                // minimum next to it.
                let refined_truth = refine(&camera, &correspondences, &problem.truth).unwrap();
                let rivals = [
                    objective(&problem.truth, &problem.points, normalized),
                    objective(
                        &refined_truth.camera_from_target,
                        &problem.points,
                        normalized,
                    ),
                    local_minimum_from_truth(&problem),
                ];
                for rival in rivals {
                    assert!(
                        best.squared_error <= rival * (1.0 + 1e-9) + 1e-15,
                        "n {n}: best {:e} above {rival:e}",
                        best.squared_error
                    );
                }

                // And on the pixels: refined, one of the minima reaches the pixel error
                // of the refined truth. SQPnP's objective weights each point by its
                // squared depth, so with 3 or 4 points its minima need not lie in the
                // basin of the best pixel fit: there only its own objective is checked.
                if n >= 5 {
                    let refined_rms = solutions
                        .iter()
                        .map(|s| {
                            refine(&camera, &correspondences, &s.camera_from_target)
                                .unwrap()
                                .rms_px
                        })
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        refined_rms <= refined_truth.rms_px + 1e-9,
                        "n {n}: {refined_rms} px against {} px",
                        refined_truth.rms_px
                    );
                }
            }
        }
    }

    #[test]
    fn finds_the_global_minimum_of_noisy_non_planar_problems() {
        check_noisy(false, 3);
    }

    #[test]
    fn finds_the_global_minimum_of_noisy_planar_problems() {
        check_noisy(true, 4);
    }

    #[test]
    fn solves_a_fronto_parallel_board() {
        let board: Vec<Point3<f64>> = (0..6)
            .flat_map(|r| (0..9).map(move |c| Point3::new(c as f64 * 0.03, r as f64 * 0.03, 0.0)))
            .collect();
        for spin in [0.0, 0.5, std::f64::consts::FRAC_PI_2, std::f64::consts::PI] {
            let rotation = UnitQuaternion::from_scaled_axis(Vector3::z() * spin);
            let truth = Isometry3::from_parts(
                Translation3::from(
                    Vector3::new(0.0, 0.0, 0.6) - rotation * Vector3::new(0.12, 0.075, 0.0),
                ),
                rotation,
            );
            let normalized: Vec<Point2<f64>> = board
                .iter()
                .map(|p| {
                    let c = truth * p;
                    Point2::new(c.x / c.z, c.y / c.z)
                })
                .collect();
            let solutions = sqpnp(&board, &normalized).unwrap();
            assert_valid(&solutions, &board);
            let (angle, translation) = pose_error(&solutions[0].camera_from_target, &truth);
            assert!(
                angle < 1e-9 && translation < 1e-9,
                "spin {spin}: {angle:e}, {translation:e}"
            );
        }
    }

    #[test]
    fn solves_a_planar_target_off_the_plane_z_0() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..20 {
            let flat = random_problem(&mut rng, 12, true, 0.0);
            // The same problem with the target frame moved: the plane is now arbitrary.
            let moved = Isometry3::from_parts(
                Translation3::new(0.3, -1.0, 2.0),
                UnitQuaternion::from_scaled_axis(unit_vector(&mut rng) * 1.3),
            );
            let points: Vec<_> = flat.points.iter().map(|p| moved * p).collect();
            let truth = flat.truth * moved.inverse();
            let solutions = sqpnp(&points, &flat.normalized()).unwrap();
            assert_valid(&solutions, &points);
            let (angle, translation) = pose_error(&solutions[0].camera_from_target, &truth);
            assert!(
                angle < 1e-8 && translation < 1e-8,
                "{angle:e}, {translation:e}"
            );
        }
    }

    #[test]
    fn does_not_depend_on_the_target_units() {
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let problem = random_problem(&mut rng, 20, false, NOISE_PX);
        let normalized = problem.normalized();
        let metres = sqpnp(&problem.points, &normalized).unwrap();
        let millimetres: Vec<_> = problem.points.iter().map(|p| p * 1000.0).collect();
        let scaled = sqpnp(&millimetres, &normalized).unwrap();
        let a = &metres[0].camera_from_target;
        let b = &scaled[0].camera_from_target;
        assert!(a.rotation.angle_to(&b.rotation) < 1e-9);
        assert!((a.translation.vector * 1000.0 - b.translation.vector).norm() < 1e-6);
        let ratio = scaled[0].squared_error / metres[0].squared_error;
        assert!((ratio - 1e6).abs() < 1e-3, "{ratio}");
    }

    #[test]
    fn returns_only_poses_in_front_of_the_camera() {
        // Points behind the camera: their image is that of the mirrored target in front,
        // which no rotation reaches. Whatever is returned must still be valid.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for n in [3, 4, 6, 10, 30] {
            for _ in 0..10 {
                let problem = random_problem(&mut rng, n, false, 0.0);
                let flip = Isometry3::from_parts(
                    Translation3::identity(),
                    UnitQuaternion::from_scaled_axis(Vector3::y() * std::f64::consts::PI),
                );
                let behind = flip * problem.truth;
                let normalized: Vec<_> = problem
                    .points
                    .iter()
                    .map(|p| {
                        let c = behind * p;
                        assert!(c.z < 0.0);
                        Point2::new(c.x / c.z, c.y / c.z)
                    })
                    .collect();
                match sqpnp(&problem.points, &normalized) {
                    Ok(solutions) => assert_valid(&solutions, &problem.points),
                    Err(PnpError::BehindCamera { count, total }) => {
                        assert!(count > 0 && count <= total && total == n)
                    }
                    Err(other) => panic!("unexpected {other:?}"),
                }
            }
        }
    }

    #[test]
    fn finds_the_front_twin_of_a_planar_target_seen_behind_the_camera() {
        // A planar target with every point behind the camera images like its half-turn
        // twin in front: (R Rz(pi), -t) maps each point M of the plane z = 0 to -(R M + t).
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        for n in [4, 5, 8, 20, 60] {
            for _ in 0..8 {
                let problem = random_problem(&mut rng, n, true, 0.0);
                let behind = Isometry3::from_parts(
                    Translation3::from(-problem.truth.translation.vector),
                    problem.truth.rotation
                        * UnitQuaternion::from_scaled_axis(Vector3::z() * std::f64::consts::PI),
                );
                let normalized: Vec<_> = problem
                    .points
                    .iter()
                    .map(|p| {
                        let c = behind * p;
                        assert!(c.z < 0.0);
                        Point2::new(c.x / c.z, c.y / c.z)
                    })
                    .collect();
                let solutions = sqpnp(&problem.points, &normalized).unwrap();
                assert_valid(&solutions, &problem.points);
                let (angle, translation) =
                    pose_error(&solutions[0].camera_from_target, &problem.truth);
                assert!(
                    angle < 1e-8 && translation < 1e-8,
                    "n {n}: {angle:e}, {translation:e}"
                );
            }
        }
    }

    fn image_of(points: &[Point3<f64>]) -> Vec<Point2<f64>> {
        points
            .iter()
            .map(|p| {
                let c = Isometry3::translation(0.1, 0.0, 3.0) * p;
                Point2::new(c.x / c.z, c.y / c.z)
            })
            .collect()
    }

    #[test]
    fn refuses_collinear_target_points() {
        let points: Vec<_> = (0..8)
            .map(|k| Point3::new(0.2, -0.1, 0.3) + Vector3::new(0.1, 0.07, -0.03) * k as f64)
            .collect();
        match sqpnp(&points, &image_of(&points)) {
            Err(PnpError::Degenerate(reason)) => assert!(reason.contains("one line"), "{reason}"),
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn refuses_coincident_target_points() {
        let points = vec![Point3::new(0.2, -0.1, 0.3); 5];
        let normalized: Vec<_> = (0..5).map(|k| Point2::new(0.01 * k as f64, 0.0)).collect();
        match sqpnp(&points, &normalized) {
            Err(PnpError::Degenerate(reason)) => assert!(reason.contains("coincide"), "{reason}"),
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn refuses_coincident_image_points() {
        let points = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.1, 0.0, 0.0),
            Point3::new(0.0, 0.1, 0.0),
            Point3::new(0.1, 0.1, 0.05),
        ];
        let normalized = vec![Point2::new(0.1, -0.2); 4];
        match sqpnp(&points, &normalized) {
            Err(PnpError::Degenerate(reason)) => {
                assert!(reason.contains("image points coincide"), "{reason}")
            }
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn refuses_too_few_mismatched_and_non_finite_inputs() {
        let points = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.1, 0.0, 0.0),
            Point3::new(0.0, 0.1, 0.0),
        ];
        let normalized = image_of(&points);
        assert_eq!(
            sqpnp(&points[..2], &normalized[..2]),
            Err(PnpError::TooFewPoints { needed: 3, got: 2 })
        );
        assert_eq!(
            sqpnp(&points, &normalized[..2]),
            Err(PnpError::MismatchedLengths {
                target_points: 3,
                image_points: 2
            })
        );
        let mut bad_points = points.clone();
        bad_points[1].y = f64::NAN;
        assert_eq!(
            sqpnp(&bad_points, &normalized),
            Err(PnpError::NonFinite("target points"))
        );
        let mut bad_image = normalized.clone();
        bad_image[2].x = f64::INFINITY;
        assert_eq!(
            sqpnp(&points, &bad_image),
            Err(PnpError::NonFinite("image points"))
        );
        assert!(sqpnp(&points, &normalized).is_ok());
    }

    #[test]
    fn refuses_overflowing_coordinates_without_nan() {
        let points = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.1, 0.0, 0.0),
            Point3::new(0.0, 0.1, 0.0),
            Point3::new(0.1, 0.1, 0.05),
        ];
        let normalized = vec![
            Point2::new(1e200, 0.0),
            Point2::new(0.0, 1e200),
            Point2::new(-1e200, 0.0),
            Point2::new(0.0, 0.0),
        ];
        assert!(matches!(
            sqpnp(&points, &normalized),
            Err(PnpError::NoSolution(_))
        ));
    }

    #[test]
    fn inverse_iteration_finds_the_least_eigenvector_and_inertia_bounds_the_others() {
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        let mut fast = 0;
        for n in [6, 20, 54] {
            for _ in 0..40 {
                let problem = random_problem(&mut rng, n, false, 0.3);
                let normalized = problem.normalized();
                let frame = TargetFrame::fit(&problem.points).unwrap();
                let local: Vec<_> = problem.points.iter().map(|p| frame.to_local(p)).collect();
                let quadratic = Problem::new(&local, &normalized).unwrap();
                let (u, s) = quadratic.eigen().unwrap();
                let Some(least) = quadratic.least_eigenvector() else {
                    continue;
                };
                fast += 1;
                // The same direction as the decomposition's, to its accuracy.
                let alignment = least.dot(&u.column(8)).abs();
                assert!(1.0 - alignment < 1e-10, "n {n}: alignment {alignment}");
                // Inertia: the others all exceed a bound exactly when the second least does.
                for bound in [s[7] * 0.999, s[7] * 1.001, s[8], s[0] * 2.0] {
                    assert_eq!(
                        quadratic.others_exceed(&least, bound),
                        s[7] > bound,
                        "n {n}: bound {bound:e}, eigenvalues {s:?}"
                    );
                }
            }
        }
        // Noisy points spread in depth leave Omega positive definite: the fast path.
        assert!(fast >= 100, "{fast} of 120 by inverse iteration");
    }

    #[test]
    fn a_planar_target_has_a_null_space_and_is_decomposed_in_full() {
        let mut rng = ChaCha8Rng::seed_from_u64(43);
        let problem = random_problem(&mut rng, 20, true, 0.0);
        let normalized = problem.normalized();
        let frame = TargetFrame::fit(&problem.points).unwrap();
        let local: Vec<_> = problem.points.iter().map(|p| frame.to_local(p)).collect();
        let quadratic = Problem::new(&local, &normalized).unwrap();
        assert!(quadratic.least_eigenvector().is_none());
    }
}
