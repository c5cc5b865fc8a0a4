//! Stereo calibration: `right_from_left` from two calibrated cameras and the views of a
//! target both saw, refined jointly (optionally with the intrinsics) on both cameras'
//! reprojection error; E, F, per-pair and epipolar errors.

use nalgebra::{
    DVector, Isometry3, Matrix2x6, Matrix3, Matrix6, Point2, Point3, Translation3, UnitQuaternion,
    Vector2, Vector3, Vector6,
};

use super::bundle::{self, BlockProblem, Termination, ViewAccumulator};
use super::epipolar::{epipolar_distances, essential_matrix, fundamental_matrix};
use super::init::initial_pose;
use super::invertibility::invertible_over_image;
use super::mono::{MIN_VIEWS, corner_errors};
use super::parameters::{FixedParameters, Parameterization};
use super::rejection::{RejectedView, RejectionOptions, RejectionReason, median, worst_view};
use super::reprojection::{MonoProblem, MonoState, full_intrinsic_jacobian, view_sum_of_squares};
use super::{CalibError, View};
use crate::camera::{CameraModel, DistortionModel, retract_pose};

/// The corners of a target seen by both cameras of a pair: target points (target
/// frame, `z = 0`) with their left and right pixels, in the same order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StereoView {
    /// Points of the target, in the target frame.
    pub points_in_target: Vec<Point3<f64>>,
    /// Their pixels in the left image.
    pub left: Vec<Point2<f64>>,
    /// Their pixels in the right image.
    pub right: Vec<Point2<f64>>,
}

impl StereoView {
    fn left_view(&self) -> View {
        View {
            points_in_target: self.points_in_target.clone(),
            pixels: self.left.clone(),
        }
    }

    fn right_view(&self) -> View {
        View {
            points_in_target: self.points_in_target.clone(),
            pixels: self.right.clone(),
        }
    }
}

/// What a stereo calibration estimates.
#[derive(Clone, Debug, PartialEq)]
pub struct StereoOptions {
    /// Refine both cameras' intrinsics with the extrinsics; otherwise they are held
    /// (OpenCV's `CALIB_FIX_INTRINSIC`).
    pub refine_intrinsics: bool,
    /// Parameters held in both cameras when the intrinsics are refined.
    pub fixed: FixedParameters,
    /// Rejection of pairs that do not fit; `None` keeps every pair.
    pub rejection: Option<RejectionOptions>,
    /// Maximum number of Levenberg-Marquardt iterations per solve.
    pub max_iterations: usize,
}

impl Default for StereoOptions {
    fn default() -> Self {
        Self {
            refine_intrinsics: false,
            fixed: FixedParameters::default(),
            rejection: Some(RejectionOptions::default()),
            max_iterations: 100,
        }
    }
}

/// How one pair fits the stereo calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct PairFit {
    /// Index of the pair in the input.
    pub index: usize,
    /// Pose of the target in the left camera frame.
    pub left_from_target: Isometry3<f64>,
    /// RMS reprojection error over both cameras' corners, pixels.
    pub rms: f64,
    /// RMS reprojection error of the left corners, pixels.
    pub left_rms: f64,
    /// RMS reprojection error of the right corners, pixels.
    pub right_rms: f64,
    /// RMS distance of the undistorted right corners to the epipolar lines of the
    /// undistorted left corners, pixels.
    pub epipolar_rms: f64,
}

/// A stereo calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct StereoCalibration {
    /// The left camera (refined when asked).
    pub left: CameraModel,
    /// The right camera (refined when asked).
    pub right: CameraModel,
    /// Maps points in the left camera frame to the right camera frame.
    pub right_from_left: Isometry3<f64>,
    /// Essential matrix, `x_right^T E x_left = 0` on normalized coordinates.
    pub essential: Matrix3<f64>,
    /// Fundamental matrix on undistorted pixels, `F[(2, 2)] = 1`.
    pub fundamental: Matrix3<f64>,
    /// RMS reprojection error over both cameras' corners of the pairs used, pixels
    /// (OpenCV's `stereoCalibrate` return value).
    pub rms: f64,
    /// RMS epipolar distance over the pairs used, pixels.
    pub epipolar_rms: f64,
    /// The pairs used, in input order.
    pub pairs: Vec<PairFit>,
    /// The pairs left out, with the reason.
    pub rejected: Vec<RejectedView>,
}

#[derive(Clone, Debug)]
struct StereoState {
    left: CameraModel,
    right: CameraModel,
    right_from_left: Isometry3<f64>,
    left_from_target: Vec<Isometry3<f64>>,
}

struct StereoProblem<'a> {
    pairs: Vec<&'a StereoView>,
    left: Parameterization,
    right: Parameterization,
    /// Refuse steps to a lens that cannot be inverted out to the image corners.
    keep_invertible: bool,
}

/// The adjoint of a pose for the `[omega; tau]` left perturbation:
/// `T exp(d) T^-1 = exp(Ad(T) d)`.
fn adjoint(pose: &Isometry3<f64>) -> Matrix6<f64> {
    let r = pose.rotation.to_rotation_matrix().into_inner();
    let mut ad = Matrix6::zeros();
    ad.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    ad.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    ad.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(pose.translation.vector.cross_matrix() * r));
    ad
}

impl StereoProblem<'_> {
    fn shared_layout(&self) -> (usize, usize) {
        (self.left.len(), self.right.len())
    }
}

impl BlockProblem for StereoProblem<'_> {
    type State = StereoState;

    fn shared_dim(&self) -> usize {
        6 + self.left.len() + self.right.len()
    }

    fn view_count(&self) -> usize {
        self.pairs.len()
    }

    fn linearize_view(&self, state: &StereoState, view: usize, acc: &mut ViewAccumulator) {
        let n = self.shared_dim();
        let (nl, nr) = self.shared_layout();
        let pair = self.pairs[view];
        let left_from_target = &state.left_from_target[view];
        let right_from_target = state.right_from_left * left_from_target;
        let ad = adjoint(&state.right_from_left);
        let mut j_shared = vec![0.0; 2 * n];
        let mut intrinsic = vec![0.0; 2 * nl.max(nr)];
        for (i, point) in pair.points_in_target.iter().enumerate() {
            if let Some(p) = state
                .left
                .project_target_point_with_jacobians(left_from_target, point)
            {
                j_shared.fill(0.0);
                self.left
                    .free_jacobian(&full_intrinsic_jacobian(&p), &mut intrinsic[..2 * nl]);
                for r in 0..2 {
                    j_shared[r * n + 6..r * n + 6 + nl]
                        .copy_from_slice(&intrinsic[r * nl..(r + 1) * nl]);
                }
                let residual: Vector2<f64> = p.projection.pixel - pair.left[i];
                acc.add(&residual, &j_shared, &p.d_pixel_d_pose);
            }
            if let Some(p) = state
                .right
                .project_target_point_with_jacobians(&right_from_target, point)
            {
                j_shared.fill(0.0);
                self.right
                    .free_jacobian(&full_intrinsic_jacobian(&p), &mut intrinsic[..2 * nr]);
                for r in 0..2 {
                    for c in 0..6 {
                        j_shared[r * n + c] = p.d_pixel_d_pose[(r, c)];
                    }
                    j_shared[r * n + 6 + nl..(r + 1) * n]
                        .copy_from_slice(&intrinsic[r * nr..(r + 1) * nr]);
                }
                let j_pose: Matrix2x6<f64> = p.d_pixel_d_pose * ad;
                let residual: Vector2<f64> = p.projection.pixel - pair.right[i];
                acc.add(&residual, &j_shared, &j_pose);
            }
        }
    }

    fn view_cost(&self, state: &StereoState, view: usize) -> f64 {
        let pair = self.pairs[view];
        let left_from_target = state.left_from_target[view];
        let (left, right) = (pair.left_view(), pair.right_view());
        view_sum_of_squares(&state.left, &left_from_target, &left)
            + view_sum_of_squares(
                &state.right,
                &(state.right_from_left * left_from_target),
                &right,
            )
    }

    fn admissible(&self, state: &StereoState) -> bool {
        !self.keep_invertible
            || (invertible_over_image(&state.left) && invertible_over_image(&state.right))
    }

    fn retract(
        &self,
        state: &StereoState,
        d_shared: &DVector<f64>,
        d_views: &[Vector6<f64>],
    ) -> StereoState {
        let (nl, _) = self.shared_layout();
        let d = d_shared.as_slice();
        StereoState {
            left: self.left.apply(&state.left, &d[6..6 + nl]),
            right: self.right.apply(&state.right, &d[6 + nl..]),
            right_from_left: retract_pose(
                &state.right_from_left,
                &Vector6::from_column_slice(&d[..6]),
            ),
            left_from_target: state
                .left_from_target
                .iter()
                .zip(d_views)
                .map(|(pose, d)| retract_pose(pose, d))
                .collect(),
        }
    }
}

/// `camera_from_target` of one view by homography and refinement with the camera held.
fn target_pose(camera: &CameraModel, view: &View) -> Option<Isometry3<f64>> {
    let pose = initial_pose(camera, view)?;
    let problem = MonoProblem {
        views: vec![view],
        parameterization: Parameterization::none(),
        keep_invertible: false,
    };
    let state = MonoState {
        camera: camera.clone(),
        camera_from_target: vec![pose],
    };
    let solved = bundle::solve(
        &problem,
        state,
        Termination {
            max_iterations: 20,
            ..Termination::default()
        },
    );
    solved.state.camera_from_target.first().copied()
}

/// Component-wise median of the rotation vectors and translations of several poses.
fn median_pose(poses: &[Isometry3<f64>]) -> Isometry3<f64> {
    let component =
        |f: &dyn Fn(&Isometry3<f64>) -> f64| median(&poses.iter().map(f).collect::<Vec<_>>());
    let rotation = Vector3::new(
        component(&|p| p.rotation.scaled_axis().x),
        component(&|p| p.rotation.scaled_axis().y),
        component(&|p| p.rotation.scaled_axis().z),
    );
    let translation = Vector3::new(
        component(&|p| p.translation.vector.x),
        component(&|p| p.translation.vector.y),
        component(&|p| p.translation.vector.z),
    );
    Isometry3::from_parts(
        Translation3::from(translation),
        UnitQuaternion::from_scaled_axis(rotation),
    )
}

/// Calibrates a stereo pair from its two calibrated cameras and the corners both saw:
/// `right_from_left` starts at the median of the pairs' relative poses, then is refined
/// with every pair's `left_from_target` (and the intrinsics when asked) on both
/// cameras' reprojection error.
pub fn calibrate_stereo(
    left: &CameraModel,
    right: &CameraModel,
    pairs: &[StereoView],
    options: &StereoOptions,
) -> Result<StereoCalibration, CalibError> {
    for (i, pair) in pairs.iter().enumerate() {
        pair.left_view().validate(i)?;
        pair.right_view().validate(i)?;
    }
    let needed = if options.refine_intrinsics {
        MIN_VIEWS
    } else {
        1
    };
    let mut rejected = Vec::new();
    let mut used = Vec::new();
    let mut left_from_target = Vec::new();
    let mut relative = Vec::new();
    for (i, pair) in pairs.iter().enumerate() {
        let poses =
            target_pose(left, &pair.left_view()).zip(target_pose(right, &pair.right_view()));
        match poses {
            Some((l, r)) => {
                used.push(i);
                left_from_target.push(l);
                relative.push(r * l.inverse());
            }
            None => rejected.push(RejectedView {
                index: i,
                reason: RejectionReason::NoPose,
            }),
        }
    }
    if used.len() < needed {
        return Err(CalibError::TooFewViews {
            usable: used.len(),
            needed,
            rejected: rejected.len(),
        });
    }
    let (left_parameters, right_parameters) = if options.refine_intrinsics {
        let ratio = |c: &CameraModel| c.intrinsics.fx / c.intrinsics.fy;
        (
            Parameterization::new(left.distortion.model(), &options.fixed, ratio(left)),
            Parameterization::new(right.distortion.model(), &options.fixed, ratio(right)),
        )
    } else {
        (Parameterization::none(), Parameterization::none())
    };
    let termination = Termination {
        max_iterations: options.max_iterations,
        ..Termination::default()
    };
    // Refined rational_polynomial lenses keep to the invertible fits the mono
    // calibrations found (see `calibrate_mono`).
    let keep_invertible = options.refine_intrinsics
        && [left, right]
            .iter()
            .any(|c| c.distortion.model() == DistortionModel::RationalPolynomial);
    let mut state = StereoState {
        left: left.clone(),
        right: right.clone(),
        right_from_left: median_pose(&relative),
        left_from_target,
    };
    loop {
        let problem = StereoProblem {
            pairs: used.iter().map(|&i| &pairs[i]).collect(),
            left: left_parameters.clone(),
            right: right_parameters.clone(),
            keep_invertible,
        };
        state = bundle::solve(&problem, state, termination).state;
        let Some(rejection) = &options.rejection else {
            break;
        };
        let limit = (rejection.max_rejected_fraction * pairs.len() as f64).floor() as usize;
        if rejected.len() >= limit || used.len() <= needed {
            break;
        }
        let errors: Vec<Vec<f64>> = used
            .iter()
            .zip(&state.left_from_target)
            .map(|(&i, pose)| pair_errors(&state, pose, &pairs[i]).concat())
            .collect();
        let Some((position, reason)) = worst_view(&errors, rejection) else {
            break;
        };
        rejected.push(RejectedView {
            index: used.remove(position),
            reason,
        });
        state.left_from_target.remove(position);
    }
    if !state
        .right_from_left
        .translation
        .vector
        .iter()
        .all(|x| x.is_finite())
    {
        return Err(CalibError::Diverged);
    }
    rejected.sort_by_key(|r| r.index);
    let essential = essential_matrix(&state.right_from_left);
    let fundamental = fundamental_matrix(&state.left, &state.right, &essential);
    let mut total = (0.0, 0usize);
    let mut epipolar_total = (0.0, 0usize);
    let fits = used
        .iter()
        .zip(&state.left_from_target)
        .map(|(&index, pose)| {
            let pair = &pairs[index];
            let [left_errors, right_errors] = pair_errors(&state, pose, pair);
            let epipolar = epipolar_distances(
                &state.left,
                &state.right,
                &fundamental,
                &pair.left,
                &pair.right,
            );
            let sum = |e: &[f64]| e.iter().map(|x| x * x).sum::<f64>();
            let rms = |e: &[f64]| (sum(e) / e.len().max(1) as f64).sqrt();
            total.0 += sum(&left_errors) + sum(&right_errors);
            total.1 += left_errors.len() + right_errors.len();
            epipolar_total.0 += sum(&epipolar);
            epipolar_total.1 += epipolar.len();
            PairFit {
                index,
                left_from_target: *pose,
                rms: rms(&[left_errors.as_slice(), right_errors.as_slice()].concat()),
                left_rms: rms(&left_errors),
                right_rms: rms(&right_errors),
                epipolar_rms: rms(&epipolar),
            }
        })
        .collect();
    Ok(StereoCalibration {
        left: state.left,
        right: state.right,
        right_from_left: state.right_from_left,
        essential,
        fundamental,
        rms: (total.0 / total.1.max(1) as f64).sqrt(),
        epipolar_rms: (epipolar_total.0 / epipolar_total.1.max(1) as f64).sqrt(),
        pairs: fits,
        rejected,
    })
}

/// Per-corner reprojection errors of a pair, left then right, pixels.
fn pair_errors(
    state: &StereoState,
    left_from_target: &Isometry3<f64>,
    pair: &StereoView,
) -> [Vec<f64>; 2] {
    [
        corner_errors(&state.left, left_from_target, &pair.left_view()),
        corner_errors(
            &state.right,
            &(state.right_from_left * left_from_target),
            &pair.right_view(),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adjoint_moves_a_left_perturbation_across_a_pose() {
        let pose = Isometry3::new(Vector3::new(0.3, -0.1, 0.2), Vector3::new(0.2, 0.4, -0.3));
        let d = Vector6::new(1.0, -2.0, 1.5, 0.3, 0.1, -0.2) * 1e-4;
        let inner = Isometry3::new(Vector3::new(0.1, 0.2, 1.0), Vector3::new(-0.1, 0.05, 0.2));
        let through = pose * retract_pose(&inner, &d);
        let moved = retract_pose(&(pose * inner), &(adjoint(&pose) * d));
        // Equal to first order in d: the difference is of the order of |d|^2.
        assert!((through.translation.vector - moved.translation.vector).norm() < 1e-7);
        assert!(through.rotation.angle_to(&moved.rotation) < 1e-7);
        assert!(through.rotation.angle_to(&(pose * inner).rotation) > 1e-4);
    }
}
