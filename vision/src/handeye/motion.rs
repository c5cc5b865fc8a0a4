//! The motions between samples, what they can determine, and the translation every
//! `AX = XB` method shares.

use nalgebra::{Isometry3, Matrix3, SymmetricEigen, Vector3};

use super::{HandEyeError, Sample, Setup};

/// Below this largest rotation between two samples (0.5 degree) the rotation of the
/// hand-eye transform is undetermined: an error.
const DEGENERATE_ROTATION_RAD: f64 = 0.5 * std::f64::consts::PI / 180.0;
/// Below this spread of the motions' rotation axes (1 degree) the translation along
/// their common axis is undetermined: an error.
const DEGENERATE_AXIS_SPREAD_RAD: f64 = std::f64::consts::PI / 180.0;
/// Below this largest rotation (20 degrees) noise weighs heavily on the result: a
/// warning.
const WEAK_ROTATION_RAD: f64 = 20.0 * std::f64::consts::PI / 180.0;
/// Below this spread of rotation axes (10 degrees): a warning.
const WEAK_AXIS_SPREAD_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// The motion between samples `i` and `j`: `a = mount_j_from_mount_i` and
/// `b = camera_j_from_camera_i`, so that `a X = X b` for `X = mount_from_camera`.
pub(super) struct Motion {
    pub a: Isometry3<f64>,
    pub b: Isometry3<f64>,
}

/// The motions between every pair of samples `i < j`, in that order.
pub(super) fn pairs(
    anchor_from_mount: &[Isometry3<f64>],
    camera_from_target: &[Isometry3<f64>],
) -> Vec<Motion> {
    let n = anchor_from_mount.len().min(camera_from_target.len());
    let mut motions = Vec::with_capacity(n * n.saturating_sub(1) / 2);
    for i in 0..n {
        for j in i + 1..n {
            motions.push(Motion {
                a: anchor_from_mount[j].inverse() * anchor_from_mount[i],
                b: camera_from_target[j] * camera_from_target[i].inverse(),
            });
        }
    }
    motions
}

/// The translation of `X = mount_from_camera` given its rotation: the least-squares
/// solution over the motions of `(R_a - I) t = R t_b - t_a`.
pub(super) fn translation<'m>(
    motions: impl IntoIterator<Item = &'m Motion>,
    rotation: &Matrix3<f64>,
) -> Result<Vector3<f64>, &'static str> {
    let mut normal = Matrix3::zeros();
    let mut right = Vector3::zeros();
    for m in motions {
        let lhs = m.a.rotation.to_rotation_matrix().into_inner() - Matrix3::identity();
        let rhs = rotation * m.b.translation.vector - m.a.translation.vector;
        normal += lhs.transpose() * lhs;
        right += lhs.transpose() * rhs;
    }
    normal
        .cholesky()
        .map(|c| c.solve(&right))
        .filter(|t| t.iter().all(|v| v.is_finite()))
        .ok_or("the motions leave the translation undetermined")
}

/// How much the robot turned between the samples and about which axes: what decides
/// whether hand-eye calibration can succeed.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionSpread {
    /// The largest rotation between two samples, radians.
    pub largest_rotation_rad: f64,
    /// How far the rotation axes of the motions stray from their main direction,
    /// radians (the RMS angle, over the motions that turn at all): 0 when all are
    /// parallel, which leaves the translation along them undetermined.
    pub axis_spread_rad: f64,
    /// The main direction of the rotation axes, in the frame the camera is fixed to.
    pub main_axis: Vector3<f64>,
    /// Each motion between two samples that turns at all: its unit rotation axis, in
    /// the frame the camera is fixed to, and its angle, radians.
    pub motions: Vec<(Vector3<f64>, f64)>,
}

/// The spread of the motions between `samples`.
pub fn motion_spread(setup: Setup, samples: &[Sample]) -> MotionSpread {
    let anchor_from_mount: Vec<Isometry3<f64>> = samples
        .iter()
        .map(|s| setup.anchor_from_mount(&s.base_from_tool))
        .collect();
    let mut largest_rotation_rad: f64 = 0.0;
    let mut scatter = Matrix3::zeros();
    let mut turning = 0usize;
    let mut motions = Vec::new();
    for i in 0..anchor_from_mount.len() {
        for j in i + 1..anchor_from_mount.len() {
            let a = anchor_from_mount[j].inverse() * anchor_from_mount[i];
            let Some((axis, angle)) = a.rotation.axis_angle() else {
                continue;
            };
            largest_rotation_rad = largest_rotation_rad.max(angle);
            motions.push((axis.into_inner(), angle));
            if angle >= DEGENERATE_ROTATION_RAD {
                scatter += axis.into_inner() * axis.transpose();
                turning += 1;
            }
        }
    }
    let (axis_spread_rad, main_axis) = if turning == 0 {
        (0.0, Vector3::z())
    } else {
        let eigen = SymmetricEigen::new(scatter / turning as f64);
        let main = eigen.eigenvalues.imax();
        let along = eigen.eigenvalues[main].clamp(0.0, 1.0);
        (
            (1.0 - along).sqrt().asin(),
            eigen.eigenvectors.column(main).normalize(),
        )
    };
    MotionSpread {
        largest_rotation_rad,
        axis_spread_rad,
        main_axis,
        motions,
    }
}

impl MotionSpread {
    /// Refuses motions that cannot determine the hand-eye transform.
    pub fn check(&self) -> Result<(), HandEyeError> {
        if self.largest_rotation_rad < DEGENERATE_ROTATION_RAD {
            return Err(HandEyeError::Degenerate(format!(
                "the tool turned by at most {:.2} degrees between samples, so the camera's \
                 rotation cannot be found: turn the tool by 30 degrees or more about \
                 different axes between samples",
                self.largest_rotation_rad.to_degrees()
            )));
        }
        if self.axis_spread_rad < DEGENERATE_AXIS_SPREAD_RAD {
            return Err(HandEyeError::Degenerate(format!(
                "every motion turns about nearly one axis ({} within {:.2} degrees), so \
                 the camera's position along it cannot be found: {}",
                self.axis_text(),
                self.axis_spread_rad.to_degrees(),
                self.advice()
            )));
        }
        Ok(())
    }

    /// What makes the motions a weak basis for calibration, with the poses to add;
    /// empty when they are well spread.
    pub fn warnings(&self, setup: Setup) -> Vec<String> {
        let mut warnings = Vec::new();
        if self.largest_rotation_rad < WEAK_ROTATION_RAD {
            warnings.push(format!(
                "the tool turned by at most {:.1} degrees between samples: noise weighs \
                 heavily on the result; turn it by 30 degrees or more between samples",
                self.largest_rotation_rad.to_degrees()
            ));
        }
        if self.axis_spread_rad < WEAK_AXIS_SPREAD_RAD {
            warnings.push(format!(
                "the motions turn about nearly one axis ({} in the {} frame, within \
                 {:.1} degrees): {}",
                self.axis_text(),
                setup.mount(),
                self.axis_spread_rad.to_degrees(),
                self.advice()
            ));
        }
        warnings
    }

    fn axis_text(&self) -> String {
        let a = self.main_axis;
        format!("({:.2}, {:.2}, {:.2})", a.x, a.y, a.z)
    }

    fn advice(&self) -> String {
        format!(
            "add poses that turn the tool about axes across {}",
            self.axis_text()
        )
    }
}
