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
    /// `[omega; tau]` (see [`crate::camera::retract_pose`]), at the refined pose: the
    /// pose's information matrix for unit pixel noise.
    pub information: Matrix6<f64>,
    /// Levenberg-Marquardt iterations taken.
    pub iterations: usize,
}

/// The squared error, `J^T J` and `J^T r` of a pose; `None` when a point is not in
/// front of the camera.
struct Linearization {
    residuals: Vec<Vector2<f64>>,
    cost: f64,
    jtj: Matrix6<f64>,
    jtr: Vector6<f64>,
}

fn linearize(
    camera: &CameraModel,
    correspondences: &Correspondences,
    camera_from_target: &Isometry3<f64>,
) -> Option<Linearization> {
    let mut lin = Linearization {
        residuals: Vec::with_capacity(correspondences.len()),
        cost: 0.0,
        jtj: Matrix6::zeros(),
        jtr: Vector6::zeros(),
    };
    let rotation = camera_from_target.rotation.to_rotation_matrix();
    let translation = camera_from_target.translation.vector;
    for (point, pixel) in correspondences
        .target_points
        .iter()
        .zip(&correspondences.pixels)
    {
        let in_camera = Point3::from(rotation * point.coords + translation);
        let (projected, j) = camera.project_with_pose_jacobian(&in_camera)?;
        let r = projected - pixel;
        lin.jtj += j.transpose() * j;
        lin.jtr += j.transpose() * r;
        lin.cost += r.norm_squared();
        lin.residuals.push(r);
    }
    Some(lin)
}

/// Refines `initial` to the nearest minimum of the squared pixel reprojection error
/// through `camera` (distortion included). Steps that would put a point behind the
/// camera are refused, so the result keeps every point in front.
///
/// Errors: [`PnpError::BehindCamera`] when `initial` already puts points behind the
/// camera, [`PnpError::TooFewPoints`] with fewer than 3 correspondences.
pub fn refine(
    camera: &CameraModel,
    correspondences: &Correspondences,
    initial: &Isometry3<f64>,
) -> Result<Refined, PnpError> {
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
    let mut lin = linearize(camera, correspondences, &pose).ok_or(PnpError::BehindCamera {
        count: behind(&pose),
        total: correspondences.len(),
    })?;
    let mut lambda = 1e-3;
    let mut iterations = 0;
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
            break;
        }
        let candidate = retract_pose(&pose, &step);
        match linearize(camera, correspondences, &candidate) {
            Some(next) if next.cost <= lin.cost => {
                let decrease = lin.cost - next.cost;
                pose = candidate;
                lin = next;
                // Damping never vanishes: far from the minimum, a pure Gauss-Newton step
                // overshoots and several refused steps would follow.
                lambda = (lambda / 10.0).max(1e-6);
                if decrease <= RELATIVE_TOLERANCE * lin.cost {
                    break;
                }
            }
            // A step that changes the error by no more than rounding: at the minimum.
            Some(next) if next.cost - lin.cost <= RELATIVE_TOLERANCE * lin.cost => break,
            _ => {
                lambda *= 10.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
    }
    let rms_px = (lin.cost / correspondences.len() as f64).sqrt();
    Ok(Refined {
        camera_from_target: pose,
        residuals: lin.residuals,
        rms_px,
        information: lin.jtj,
        iterations,
    })
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
}
