//! The joint refinement: the hand-eye transform, the target's pose and every robot pose
//! at once, on the pixels of the target's points over all samples (after Koide and
//! Menegatti 2019, "General hand-eye calibration based on reprojection error
//! minimization").
//!
//! Unknowns: `mount_from_camera` (X) and `anchor_from_target` (W), each perturbed on
//! the left (see [`crate::camera::retract_pose`]), and a correction `E_i` of each robot
//! pose, `base_from_tool_i = measured_i * E_i` (a perturbation in the tool frame).
//! Residuals: every point's pixel error over the pixel noise, and each correction over
//! the robot's noise (rotation vector over its rotation noise, translation over its
//! translation noise): the robot's poses are measurements, not truths.

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Matrix6, Point2, Point3, SymmetricEigen, Vector6,
};

use super::{HandEye, HandEyeError, Sample, Setup};
use crate::camera::{CameraModel, retract_pose};

/// Iterations after which refinement stops.
const MAX_ITERATIONS: usize = 100;
/// Relative decrease of the cost below which refinement has converged.
const RELATIVE_TOLERANCE: f64 = 1e-12;

/// The target's points and their pixels in one sample's image.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetObservation {
    /// Points in the target frame, metres.
    pub target_points: Vec<Point3<f64>>,
    /// Their pixels, pixel centres at integer coordinates.
    pub pixels: Vec<Point2<f64>>,
}

/// The noise the refinement weighs the measurements by.
#[derive(Clone, Debug, PartialEq)]
pub struct RefineOptions {
    /// Standard deviation of a detected point, pixels.
    pub pixel_noise_px: f64,
    /// Standard deviation of the robot's reported rotation, radians.
    pub robot_rotation_noise_rad: f64,
    /// Standard deviation of the robot's reported position, metres.
    pub robot_translation_noise_m: f64,
}

impl Default for RefineOptions {
    /// 0.2 px, 0.05 degree and 0.3 mm: a sharp detection and an industrial arm.
    fn default() -> Self {
        Self {
            pixel_noise_px: 0.2,
            robot_rotation_noise_rad: 0.05_f64.to_radians(),
            robot_translation_noise_m: 0.3e-3,
        }
    }
}

/// How well the refined hand-eye transform is known: one standard deviation along its
/// least certain direction, from the refinement's covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Uncertainty {
    /// Rotation, degrees.
    pub rotation_deg: f64,
    /// Position of the camera, millimetres.
    pub translation_mm: f64,
}

/// The refined calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct RefinedHandEye {
    /// The transforms.
    pub hand_eye: HandEye,
    /// The robot poses the refinement settled on, in sample order.
    pub base_from_tool: Vec<Isometry3<f64>>,
    /// RMS pixel error over every point of every sample.
    pub rms_px: f64,
    /// RMS pixel error of each sample's points, in sample order.
    pub sample_rms_px: Vec<f64>,
    /// The standard deviations of the hand-eye transform.
    pub uncertainty: Uncertainty,
    /// Levenberg-Marquardt iterations taken.
    pub iterations: usize,
}

/// Refines `start` jointly with the target's pose and the robot poses on the pixels of
/// `observations` (one per sample, in the same order) seen through `camera`.
///
/// Errors: [`HandEyeError::TooFewSamples`] when the samples and observations do not
/// pair up or are fewer than 3, [`HandEyeError::NonFinite`] for non-finite input,
/// [`HandEyeError::NoSolution`] when a point falls behind the camera at the start or
/// the normal equations are singular (the motions do not determine the transform).
pub fn refine(
    camera: &CameraModel,
    samples: &[Sample],
    observations: &[TargetObservation],
    start: &HandEye,
    options: &RefineOptions,
) -> Result<RefinedHandEye, HandEyeError> {
    if samples.len() != observations.len() || samples.len() < super::MIN_SAMPLES {
        return Err(HandEyeError::TooFewSamples {
            needed: super::MIN_SAMPLES,
            got: samples.len().min(observations.len()),
        });
    }
    for (index, o) in observations.iter().enumerate() {
        let finite = o.target_points.len() == o.pixels.len()
            && o.target_points
                .iter()
                .all(|p| p.iter().all(|v| v.is_finite()))
            && o.pixels.iter().all(|p| p.iter().all(|v| v.is_finite()));
        if !finite {
            return Err(HandEyeError::NonFinite {
                index,
                what: "target points or pixels",
            });
        }
    }
    let failed = |reason: &str| HandEyeError::NoSolution {
        method: "refinement",
        reason: reason.into(),
    };
    let problem = Problem {
        setup: start.setup(),
        camera,
        measured: samples.iter().map(|s| s.base_from_tool).collect(),
        observations,
        options,
    };
    let mut state = State {
        mount_from_camera: *start.mount_from_camera(),
        anchor_from_target: *start.anchor_from_target(),
        base_from_tool: problem.measured.clone(),
    };
    let mut lin = problem
        .linearize(&state)
        .ok_or_else(|| failed("a target point is behind the camera at the start"))?;
    let mut lambda = 1e-6;
    let mut growth = 2.0;
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let mut damped = lin.information.clone();
        for i in 0..damped.nrows() {
            damped[(i, i)] += lambda * lin.information[(i, i)].max(1e-12);
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&(-&lin.gradient))) else {
            lambda *= growth;
            growth *= 2.0;
            continue;
        };
        let predicted = -lin.gradient.dot(&step) - 0.5 * step.dot(&(&lin.information * &step));
        if predicted <= RELATIVE_TOLERANCE * lin.cost {
            break;
        }
        let candidate = state.step(&step);
        match problem.linearize(&candidate) {
            Some(next) if next.cost <= lin.cost => {
                let decrease = lin.cost - next.cost;
                let gain = decrease / predicted;
                lambda = (lambda * (1.0 - (2.0 * gain - 1.0).powi(3)).max(1.0 / 3.0)).max(1e-12);
                growth = 2.0;
                state = candidate;
                lin = next;
                if decrease <= RELATIVE_TOLERANCE * lin.cost {
                    break;
                }
            }
            _ => {
                lambda *= growth;
                growth *= 2.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
    }
    let covariance = lin
        .information
        .clone()
        .cholesky()
        .map(|c| c.inverse())
        .ok_or_else(|| failed("the samples do not determine the transform"))?;
    let uncertainty = uncertainty(
        &covariance.fixed_view::<6, 6>(0, 0).into_owned(),
        &state.mount_from_camera,
    );
    Ok(RefinedHandEye {
        hand_eye: HandEye::new(
            problem.setup,
            state.mount_from_camera,
            state.anchor_from_target,
        ),
        sample_rms_px: problem.sample_rms(&state),
        base_from_tool: state.base_from_tool,
        rms_px: (lin.pixel_squared_error / lin.points.max(1) as f64).sqrt(),
        uncertainty,
        iterations,
    })
}

/// The fixed part of the problem.
struct Problem<'a> {
    setup: Setup,
    camera: &'a CameraModel,
    measured: Vec<Isometry3<f64>>,
    observations: &'a [TargetObservation],
    options: &'a RefineOptions,
}

/// The unknowns.
#[derive(Clone)]
struct State {
    mount_from_camera: Isometry3<f64>,
    anchor_from_target: Isometry3<f64>,
    base_from_tool: Vec<Isometry3<f64>>,
}

impl State {
    /// The state moved by `step`: `[X; W; E_1; ..]`, six each.
    fn step(&self, step: &DVector<f64>) -> Self {
        let six = |at: usize| Vector6::from_iterator(step.rows(at, 6).iter().copied());
        Self {
            mount_from_camera: retract_pose(&self.mount_from_camera, &six(0)),
            anchor_from_target: retract_pose(&self.anchor_from_target, &six(6)),
            base_from_tool: self
                .base_from_tool
                .iter()
                .enumerate()
                .map(|(i, pose)| pose * retract_pose(&Isometry3::identity(), &six(12 + 6 * i)))
                .collect(),
        }
    }
}

/// The weighted squared error, `J^T J` and `J^T r` at a state.
struct Linearization {
    cost: f64,
    information: DMatrix<f64>,
    gradient: DVector<f64>,
    pixel_squared_error: f64,
    points: usize,
}

impl Problem<'_> {
    /// Each sample's RMS pixel error at `state` (NaN where a point is behind the
    /// camera).
    fn sample_rms(&self, state: &State) -> Vec<f64> {
        let camera_from_mount = state.mount_from_camera.inverse();
        state
            .base_from_tool
            .iter()
            .zip(self.observations)
            .map(|(base_from_tool, observation)| {
                let anchor_from_mount = self.setup.anchor_from_mount(base_from_tool);
                let camera_from_target =
                    camera_from_mount * anchor_from_mount.inverse() * state.anchor_from_target;
                let squared: f64 = observation
                    .target_points
                    .iter()
                    .zip(&observation.pixels)
                    .map(|(point, pixel)| {
                        self.camera
                            .project(&(camera_from_target * point))
                            .map_or(f64::NAN, |p| (p - pixel).norm_squared())
                    })
                    .sum();
                (squared / observation.pixels.len().max(1) as f64).sqrt()
            })
            .collect()
    }

    fn linearize(&self, state: &State) -> Option<Linearization> {
        let n = self.measured.len();
        let size = 12 + 6 * n;
        let mut information = DMatrix::zeros(size, size);
        let mut gradient = DVector::zeros(size);
        let mut cost = 0.0;
        let mut pixel_squared_error = 0.0;
        let mut points = 0;
        let x = &state.mount_from_camera;
        let camera_from_mount = x.inverse();
        let d_x = -adjoint(&camera_from_mount);
        for i in 0..n {
            let base_from_tool = &state.base_from_tool[i];
            let anchor_from_mount = self.setup.anchor_from_mount(base_from_tool);
            let camera_from_anchor = camera_from_mount * anchor_from_mount.inverse();
            let camera_from_target = camera_from_anchor * state.anchor_from_target;
            let d_w = adjoint(&camera_from_anchor);
            // base_from_tool = measured * E: eye-in-hand puts E^-1 right after
            // camera_from_tool = X^-1, eye-to-hand puts E right after
            // camera_from_tool = X^-1 * base_from_tool.
            let d_e = match self.setup {
                Setup::EyeInHand => -adjoint(&camera_from_mount),
                Setup::EyeToHand => adjoint(&(camera_from_mount * base_from_tool)),
            };
            let blocks = [(0, d_x), (6, d_w), (12 + 6 * i, d_e)];
            let observation = &self.observations[i];
            let sigma = self.options.pixel_noise_px;
            for (point, pixel) in observation.target_points.iter().zip(&observation.pixels) {
                let (projected, j) = self
                    .camera
                    .project_with_pose_jacobian(&(camera_from_target * point))?;
                let r = (projected - pixel) / sigma;
                let j = j / sigma;
                let columns: [nalgebra::Matrix2x6<f64>; 3] =
                    std::array::from_fn(|k| j * blocks[k].1);
                for (row, ja) in blocks.iter().map(|b| b.0).zip(&columns) {
                    let mut g = gradient.rows_mut(row, 6);
                    g += ja.transpose() * r;
                    for (column, jb) in blocks.iter().map(|b| b.0).zip(&columns) {
                        let mut block = information.view_mut((row, column), (6, 6));
                        block += ja.transpose() * jb;
                    }
                }
                cost += r.norm_squared();
                pixel_squared_error += (projected - pixel).norm_squared();
                points += 1;
            }
            // The correction's prior: measured^-1 * base_from_tool = (R_c, t_c), its
            // rotation vector over the rotation noise and t_c over the translation noise.
            let correction = self.measured[i].inverse() * base_from_tool;
            let weights = Vector6::new(
                self.options.robot_rotation_noise_rad.recip(),
                self.options.robot_rotation_noise_rad.recip(),
                self.options.robot_rotation_noise_rad.recip(),
                self.options.robot_translation_noise_m.recip(),
                self.options.robot_translation_noise_m.recip(),
                self.options.robot_translation_noise_m.recip(),
            );
            let mut r = Vector6::zeros();
            r.fixed_rows_mut::<3>(0)
                .copy_from(&correction.rotation.scaled_axis());
            r.fixed_rows_mut::<3>(3)
                .copy_from(&correction.translation.vector);
            let r = r.component_mul(&weights);
            // d(correction)/d(E): the rotation vector moves with omega (to first order),
            // the translation by R_c tau.
            let mut j = Matrix6::identity();
            j.fixed_view_mut::<3, 3>(3, 3)
                .copy_from(correction.rotation.to_rotation_matrix().matrix());
            let j = Matrix6::from_diagonal(&weights) * j;
            let at = 12 + 6 * i;
            let mut g = gradient.rows_mut(at, 6);
            g += j.transpose() * r;
            let mut block = information.view_mut((at, at), (6, 6));
            block += j.transpose() * j;
            cost += r.norm_squared();
        }
        cost.is_finite().then_some(Linearization {
            cost,
            information,
            gradient,
            pixel_squared_error,
            points,
        })
    }
}

/// The 6x6 map from a left perturbation `[omega; tau]` of a pose `P` to the left
/// perturbation of `G * P`: `G E G^-1` turns by `R_G omega` and moves by
/// `R_G tau + [t_G]x R_G omega`.
fn adjoint(g: &Isometry3<f64>) -> Matrix6<f64> {
    let r = g.rotation.to_rotation_matrix().into_inner();
    let t = g.translation.vector;
    let mut a = Matrix6::zeros();
    a.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    a.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    a.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(t.cross_matrix() * r));
    a
}

/// One standard deviation of the hand-eye transform along its least certain rotation
/// and position directions, from the covariance of its perturbation `[omega; tau]`
/// (`t' = exp(omega) t + tau`, so the position moves by `-[t]x omega + tau`).
fn uncertainty(covariance: &Matrix6<f64>, mount_from_camera: &Isometry3<f64>) -> Uncertainty {
    let largest = |m: Matrix3<f64>| SymmetricEigen::new(m).eigenvalues.max().max(0.0).sqrt();
    let rotation = covariance.fixed_view::<3, 3>(0, 0).into_owned();
    let mut position_from_delta = nalgebra::Matrix3x6::zeros();
    position_from_delta
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-mount_from_camera.translation.vector.cross_matrix()));
    position_from_delta
        .fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&Matrix3::identity());
    let position = position_from_delta * covariance * position_from_delta.transpose();
    Uncertainty {
        rotation_deg: largest(rotation).to_degrees(),
        translation_mm: largest(position) * 1e3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::handeye::{Method, calibrate};
    use crate::synth::{CornerSessionSpec, RobotNoise, corner_session};

    fn errors(found: &Isometry3<f64>, truth: &Isometry3<f64>) -> (f64, f64) {
        (
            found.rotation.angle_to(&truth.rotation).to_degrees(),
            (found.translation.vector - truth.translation.vector).norm() * 1e3,
        )
    }

    fn median(mut v: Vec<f64>) -> f64 {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    }

    /// Over sessions of both setups, the refined transform's median error against the
    /// truth is below that of every one of the five AX = XB methods, in rotation and in
    /// translation, and its predicted uncertainty is of the size of its errors.
    #[test]
    fn refinement_beats_every_classic_method() {
        for setup in [Setup::EyeInHand, Setup::EyeToHand] {
            let mut refined = Vec::new();
            let mut classic: Vec<Vec<(f64, f64)>> = vec![Vec::new(); 5];
            let mut normalized = Vec::new();
            for seed in 0..20 {
                let s = corner_session(&CornerSessionSpec {
                    setup,
                    samples: 15,
                    pixel_noise_px: 0.2,
                    robot_noise: RobotNoise {
                        rotation_rad: 0.05_f64.to_radians(),
                        translation_m: 0.3e-3,
                    },
                    seed,
                });
                for (errors_of, &method) in classic.iter_mut().zip(&Method::ALL[..5]) {
                    let c = calibrate(setup, &s.samples, method).unwrap();
                    errors_of.push(errors(c.hand_eye.mount_from_camera(), &s.mount_from_camera));
                }
                let start = calibrate(setup, &s.samples, Method::Daniilidis).unwrap();
                let r = refine(
                    &s.camera,
                    &s.samples,
                    &s.observations,
                    &start.hand_eye,
                    &RefineOptions::default(),
                )
                .unwrap();
                let e = errors(r.hand_eye.mount_from_camera(), &s.mount_from_camera);
                refined.push(e);
                normalized.push((
                    e.0 / r.uncertainty.rotation_deg,
                    e.1 / r.uncertainty.translation_mm,
                ));
                assert!(r.rms_px < 0.3, "{setup:?}: rms {}", r.rms_px);
            }
            let m = |v: &[(f64, f64)], k: usize| {
                median(v.iter().map(|e| if k == 0 { e.0 } else { e.1 }).collect())
            };
            for (errors_of, method) in classic.iter().zip(&Method::ALL[..5]) {
                eprintln!(
                    "{setup:?} {method:?}: {:.4} deg {:.3} mm",
                    m(errors_of, 0),
                    m(errors_of, 1)
                );
                assert!(m(&refined, 0) < m(errors_of, 0) && m(&refined, 1) < m(errors_of, 1));
            }
            eprintln!(
                "{setup:?} refined: {:.4} deg {:.3} mm, error/sigma {:.2} {:.2}",
                m(&refined, 0),
                m(&refined, 1),
                m(&normalized, 0),
                m(&normalized, 1)
            );
            assert!(m(&normalized, 0) < 3.0 && m(&normalized, 1) < 3.0);
        }
    }
}
