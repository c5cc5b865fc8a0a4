//! Levenberg-Marquardt refinement of a pose on the pixel reprojection error, through
//! the full camera model (distortion included).

use nalgebra::{Isometry3, Matrix6, Point3, Vector2, Vector6};

use super::{Correspondences, PnpError};
use crate::camera::{CameraModel, retract_pose};

/// Iterations after which refinement stops even if still improving.
const MAX_ITERATIONS: usize = 100;
/// Relative decrease of the squared error below which refinement has converged.
const RELATIVE_TOLERANCE: f64 = 1e-12;
/// Step (radians and metres) below which refinement has converged.
const STEP_TOLERANCE: f64 = 1e-12;
/// The largest ratio of a step's predicted decrease to the last accepted step's at which
/// convergence counts as fast enough to extrapolate: the step after this one would then
/// gain about this step's predicted decrease times that ratio (Gauss-Newton near a
/// minimum with small residuals shrinks it about a millionth per step on noisy
/// corners).
const MAX_TAIL_RATIO: f64 = 1e-2;
/// Levenberg-Marquardt damping of the first step, relative to the diagonal of `J^T J`:
/// starts come from solvers that are already close, where Gauss-Newton's step is the
/// right one.
const INITIAL_DAMPING: f64 = 1e-6;
/// The least damping. A distant target leaves `J^T J` ill-conditioned (depth against
/// tilt); damping above its smallest eigenvalue would shorten every step along that
/// valley and make convergence linear.
const MIN_DAMPING: f64 = 1e-12;
/// [`refine_excess`]: the fraction of the error's excess over the floor to which the
/// error is located.
const EXCESS_PRECISION: f64 = 1e-3;
/// [`refine_excess`]: decreases must shrink at least this fast from one step to the
/// next for their geometric tail to be trusted as what is left to gain.
const MAX_CONVERGENCE_RATIO: f64 = 0.5;

/// A refined pose and how well it explains the pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Refined {
    /// The pose, mapping target points to the camera frame.
    pub camera_from_target: Isometry3<f64>,
    /// Reprojection residual of each point, `projected - observed`, pixels.
    pub residuals: Vec<Vector2<f64>>,
    /// Root mean square of the residuals' lengths, pixels.
    pub rms_px: f64,
    /// `J^T J` of the pixel residuals with respect to the left pose perturbation
    /// `[omega; tau]` (see [`crate::camera::retract_pose`]): the pose's information
    /// matrix for unit pixel noise. It is taken at the refined pose, or one step before
    /// it when that last step was known to be the last that changes the error
    /// measurably (see [`refine`]): a step of about a millionth of the pose on noisy
    /// corners, which changes `J^T J` about as much.
    pub information: Matrix6<f64>,
    /// Levenberg-Marquardt iterations taken.
    pub iterations: usize,
}

/// The squared error, `J^T J` and `J^T r` of a pose.
struct Linearization {
    residuals: Vec<Vector2<f64>>,
    cost: f64,
    jtj: Matrix6<f64>,
    jtr: Vector6<f64>,
}

/// The Jacobian's columns and the residuals of one pose, stored column by column (six
/// columns of `J`, then `r`, each with a row per pixel coordinate): `J^T J` and `J^T r`
/// are then 27 dot products of contiguous columns. Kept between iterations.
struct Columns {
    rows: usize,
    data: Vec<f64>,
}

impl Columns {
    fn new(points: usize) -> Self {
        Self {
            rows: 2 * points,
            data: vec![0.0; 7 * 2 * points],
        }
    }

    fn column(&self, c: usize) -> &[f64] {
        &self.data[c * self.rows..(c + 1) * self.rows]
    }
}

/// `a . b`, in four independent sums so that the compiler can keep them in vector
/// registers.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [0.0; 4];
    let (a_chunks, b_chunks) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a_chunks
        .remainder()
        .iter()
        .zip(b_chunks.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a_chunks.zip(b_chunks) {
        for k in 0..4 {
            sums[k] += x[k] * y[k];
        }
    }
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail
}

/// The residuals and squared error at `camera_from_target`, without the Jacobian;
/// `None` when a point is not in front of the camera.
fn residuals_at(
    camera: &CameraModel,
    correspondences: &Correspondences,
    camera_from_target: &Isometry3<f64>,
) -> Option<(Vec<Vector2<f64>>, f64)> {
    let rotation = camera_from_target.rotation.to_rotation_matrix();
    let translation = camera_from_target.translation.vector;
    let residuals = correspondences
        .target_points
        .iter()
        .zip(&correspondences.pixels)
        .map(|(point, pixel)| {
            camera
                .project(&Point3::from(rotation * point.coords + translation))
                .map(|projected| projected - pixel)
        })
        .collect::<Option<Vec<_>>>()?;
    let cost = residuals.iter().map(|r| r.norm_squared()).sum();
    Some((residuals, cost))
}

/// Linearizes the pixel error at `camera_from_target`; `None` when a point is not in
/// front of the camera.
fn linearize(
    camera: &CameraModel,
    correspondences: &Correspondences,
    camera_from_target: &Isometry3<f64>,
    columns: &mut Columns,
) -> Option<Linearization> {
    let rows = columns.rows;
    let rotation = camera_from_target.rotation.to_rotation_matrix();
    let translation = camera_from_target.translation.vector;
    let mut residuals = Vec::with_capacity(correspondences.len());
    for (i, (point, pixel)) in correspondences
        .target_points
        .iter()
        .zip(&correspondences.pixels)
        .enumerate()
    {
        let in_camera = Point3::from(rotation * point.coords + translation);
        let (projected, j) = camera.project_with_pose_jacobian(&in_camera)?;
        let r = projected - pixel;
        for c in 0..6 {
            columns.data[c * rows + 2 * i] = j[(0, c)];
            columns.data[c * rows + 2 * i + 1] = j[(1, c)];
        }
        columns.data[6 * rows + 2 * i] = r.x;
        columns.data[6 * rows + 2 * i + 1] = r.y;
        residuals.push(r);
    }
    let residual = columns.column(6);
    let mut jtj = Matrix6::zeros();
    let mut jtr = Vector6::zeros();
    for a in 0..6 {
        let column = columns.column(a);
        for b in a..6 {
            let value = dot(column, columns.column(b));
            jtj[(a, b)] = value;
            jtj[(b, a)] = value;
        }
        jtr[a] = dot(column, residual);
    }
    Some(Linearization {
        residuals,
        cost: dot(residual, residual),
        jtj,
        jtr,
    })
}

/// Refines `initial` to the nearest minimum of the squared pixel reprojection error
/// through `camera` (distortion included). Steps that would put a point behind the
/// camera are refused, so the result keeps every point in front.
///
/// Converged means the next Gauss-Newton step would lower the squared error by no
/// more than a 1e-12th. Near a minimum the decreases shrink geometrically; once the
/// rate shows that the step after the current one would gain no more than that, the
/// current step is checked on its residuals alone and is the last.
///
/// Errors: [`PnpError::BehindCamera`] when `initial` already puts points behind the
/// camera, [`PnpError::TooFewPoints`] with fewer than 3 correspondences.
pub fn refine(
    camera: &CameraModel,
    correspondences: &Correspondences,
    initial: &Isometry3<f64>,
) -> Result<Refined, PnpError> {
    refine_to(camera, correspondences, initial, None).map(|(refined, _)| refined)
}

/// [`refine`] for a pose that only has to be told from a better one whose squared error
/// is `floor`: it stops once the squared error's excess over `floor` is at least
/// `margin` and known to a thousandth. A large-residual minimum (the wrong pose of a
/// planar target) is approached by Gauss-Newton only linearly, and its last digits
/// would cost most of the iterations. Returns whether the minimum was reached in full;
/// it always is when the excess stays below `margin`.
pub(crate) fn refine_excess(
    camera: &CameraModel,
    correspondences: &Correspondences,
    initial: &Isometry3<f64>,
    floor: f64,
    margin: f64,
) -> Result<(Refined, bool), PnpError> {
    refine_to(camera, correspondences, initial, Some((floor, margin)))
}

fn refine_to(
    camera: &CameraModel,
    correspondences: &Correspondences,
    initial: &Isometry3<f64>,
    floor: Option<(f64, f64)>,
) -> Result<(Refined, bool), PnpError> {
    if correspondences.len() < 3 {
        return Err(PnpError::TooFewPoints {
            needed: 3,
            got: correspondences.len(),
        });
    }
    let behind = |pose: &Isometry3<f64>| {
        correspondences
            .target_points
            .iter()
            .filter(|p| (pose * *p).z <= 0.0)
            .count()
    };
    let mut pose = *initial;
    let mut columns = Columns::new(correspondences.len());
    let mut lin =
        linearize(camera, correspondences, &pose, &mut columns).ok_or(PnpError::BehindCamera {
            count: behind(&pose),
            total: correspondences.len(),
        })?;
    let mut lambda = INITIAL_DAMPING;
    // Nielsen's rule: the damping falls or rises with how well the model predicted the
    // last accepted step, and grows ever faster over consecutive refusals.
    let mut refusal_growth = 2.0;
    let mut iterations = 0;
    // The two decreases before the last accepted step, latest first.
    let mut earlier = [f64::NAN; 2];
    // Gauss-Newton's predicted decrease for the last accepted step.
    let mut last_predicted = f64::NAN;
    let mut converged = false;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let mut damped = lin.jtj;
        for i in 0..6 {
            damped[(i, i)] += lambda * lin.jtj[(i, i)].max(1e-12);
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&-lin.jtr)) else {
            lambda *= 10.0;
            continue;
        };
        // Gauss-Newton's predicted decrease: nothing left to gain means converged.
        let predicted = -(lin.jtr.dot(&step)) - 0.5 * step.dot(&(lin.jtj * step));
        if predicted <= RELATIVE_TOLERANCE * lin.cost || step.norm() < STEP_TOLERANCE {
            converged = true;
            break;
        }
        let candidate = retract_pose(&pose, &step);
        let ratio = predicted / last_predicted;
        if ratio <= MAX_TAIL_RATIO
            && predicted * ratio <= RELATIVE_TOLERANCE * lin.cost
            && let Some((residuals, cost)) = residuals_at(camera, correspondences, &candidate)
            && cost <= lin.cost
        {
            pose = candidate;
            lin.residuals = residuals;
            lin.cost = cost;
            converged = true;
            break;
        }
        match linearize(camera, correspondences, &candidate, &mut columns) {
            Some(next) if next.cost <= lin.cost => {
                let decrease = lin.cost - next.cost;
                last_predicted = predicted;
                pose = candidate;
                lin = next;
                let gain = decrease / predicted;
                lambda =
                    (lambda * (1.0 - (2.0 * gain - 1.0).powi(3)).max(1.0 / 3.0)).max(MIN_DAMPING);
                refusal_growth = 2.0;
                if decrease <= RELATIVE_TOLERANCE * lin.cost {
                    converged = true;
                    break;
                }
                if let Some((floor, margin)) = floor
                    && lin.cost - floor >= margin
                    && excess_known([decrease, earlier[0], earlier[1]], lin.cost - floor)
                {
                    break;
                }
                earlier = [decrease, earlier[0]];
            }
            // A step that changes the error by no more than rounding: at the minimum.
            Some(next) if next.cost - lin.cost <= RELATIVE_TOLERANCE * lin.cost => {
                converged = true;
                break;
            }
            _ => {
                lambda *= refusal_growth;
                refusal_growth *= 2.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
    }
    let rms_px = (lin.cost / correspondences.len() as f64).sqrt();
    let refined = Refined {
        camera_from_target: pose,
        residuals: lin.residuals,
        rms_px,
        information: lin.jtj,
        iterations,
    };
    Ok((refined, converged))
}

/// Whether what is left to gain is within [`EXCESS_PRECISION`] of `excess`, from the
/// last three decreases (latest first): when each shrank from the one before by at most
/// [`MAX_CONVERGENCE_RATIO`], what is left is estimated as the geometric tail of the
/// larger of the two ratios.
fn excess_known(decreases: [f64; 3], excess: f64) -> bool {
    if decreases.iter().any(|d| d.is_nan()) {
        return false;
    }
    let ratio = (decreases[0] / decreases[1]).max(decreases[1] / decreases[2]);
    excess > 0.0
        && ratio <= MAX_CONVERGENCE_RATIO
        && decreases[0] * ratio / (1.0 - ratio) <= EXCESS_PRECISION * excess
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pnp::test_camera as camera;
    use nalgebra::{Point2, Translation3, UnitQuaternion, Vector3};

    fn board() -> Vec<Point3<f64>> {
        (0..6)
            .flat_map(|r| (0..9).map(move |c| Point3::new(c as f64 * 0.03, r as f64 * 0.03, 0.0)))
            .collect()
    }

    #[test]
    fn recovers_the_exact_pose_through_distortion() {
        let camera = camera();
        let truth = Isometry3::from_parts(
            Translation3::new(-0.1, -0.05, 0.6),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.4, 0.1)),
        );
        let points = board();
        let pixels: Vec<_> = points
            .iter()
            .map(|p| camera.project(&(truth * p)).unwrap())
            .collect();
        let c = Correspondences::new(&camera, &points, &pixels).unwrap();
        let start = Isometry3::from_parts(
            Translation3::new(-0.08, -0.04, 0.65),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.25, -0.35, 0.12)),
        );
        let refined = refine(&camera, &c, &start).unwrap();
        assert!(refined.rms_px < 1e-9, "rms {}", refined.rms_px);
        let error = refined.camera_from_target.inverse() * truth;
        assert!(error.translation.vector.norm() < 1e-10);
        assert!(error.rotation.angle() < 1e-10);
    }

    #[test]
    fn refuses_a_start_behind_the_camera() {
        let camera = camera();
        let points = board();
        let pixels = vec![Point2::new(500.0, 400.0); points.len()];
        let c = Correspondences::new(&camera, &points, &pixels).unwrap();
        let behind = Isometry3::translation(0.0, 0.0, -1.0);
        assert!(matches!(
            refine(&camera, &c, &behind),
            Err(PnpError::BehindCamera {
                count: 54,
                total: 54
            })
        ));
    }

    #[test]
    fn a_step_known_to_be_the_last_leaves_the_minimum_reached() {
        let camera = camera();
        let truth = Isometry3::from_parts(
            Translation3::new(0.05, -0.02, 0.8),
            UnitQuaternion::from_scaled_axis(Vector3::new(2.8, 0.3, -0.2)),
        );
        let points: Vec<_> = board()
            .iter()
            .enumerate()
            .map(|(i, p)| Point3::new(p.x, p.y, 0.01 * ((i * 7) % 5) as f64))
            .collect();
        // Fixed pseudo-noise of about 0.3 px.
        let pixels: Vec<_> = points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let noise = Vector2::new(((i * 13) % 7) as f64 - 3.0, ((i * 5) % 7) as f64 - 3.0);
                camera.project(&(truth * p)).unwrap() + noise * 0.15
            })
            .collect();
        let c = Correspondences::new(&camera, &points, &pixels).unwrap();
        let start = Isometry3::from_parts(
            Translation3::new(0.06, -0.03, 0.78),
            UnitQuaternion::from_scaled_axis(Vector3::new(2.78, 0.31, -0.21)),
        );
        let refined = refine(&camera, &c, &start).unwrap();
        // Refining again does not move the pose measurably, and the information matrix
        // is the one at the pose returned, to the relative size of the last step (here
        // about a millionth).
        let again = refine(&camera, &c, &refined.camera_from_target).unwrap();
        let moved = refined.camera_from_target.inverse() * again.camera_from_target;
        assert!(moved.rotation.angle() < 1e-9, "{}", moved.rotation.angle());
        assert!(moved.translation.vector.norm() < 1e-9);
        assert!((again.rms_px - refined.rms_px).abs() < 1e-12 * refined.rms_px);
        let mut columns = Columns::new(c.len());
        let at_pose = linearize(&camera, &c, &refined.camera_from_target, &mut columns).unwrap();
        let difference = (at_pose.jtj - refined.information).norm() / at_pose.jtj.norm();
        assert!(difference < 1e-5, "information differs by {difference:e}");
        for (a, b) in at_pose.residuals.iter().zip(&refined.residuals) {
            assert!((a - b).norm() < 1e-9, "residual {a} against {b}");
        }
    }
}
