//! Projection with analytic Jacobians, for calibration and pose refinement.
//!
//! Pose parameterization: a pose `camera_from_target` is perturbed on the left, in the
//! camera frame, by a 6-vector `delta = [omega; tau]` (rotation vector `omega` in
//! radians, then translation `tau` in metres):
//! `camera_from_target' = Isometry3::new(tau, omega) * camera_from_target`, i.e. a point
//! `X` of the camera frame moves to `exp(omega) X + tau`. [`retract_pose`] applies such
//! an update, and [`TargetProjection::d_pixel_d_pose`] is the derivative at
//! `delta = 0`.

use nalgebra::{
    Isometry3, Matrix2, Matrix2x3, Matrix2x4, Matrix2x6, Matrix2xX, Matrix3, Point2, Point3,
    Vector2, Vector3, Vector6,
};

use super::CameraModel;

/// A projected pixel with its derivatives.
#[derive(Clone, Debug, PartialEq)]
pub struct Projection {
    /// The pixel (pixel centres at integer coordinates).
    pub pixel: Point2<f64>,
    /// Derivative with respect to the point in the camera frame (pixels per metre).
    pub d_pixel_d_point: Matrix2x3<f64>,
    /// Derivative with respect to the intrinsics, columns `fx, fy, cx, cy`.
    pub d_pixel_d_intrinsics: Matrix2x4<f64>,
    /// Derivative with respect to the distortion coefficients, one column per
    /// coefficient in camera_info order.
    pub d_pixel_d_distortion: Matrix2xX<f64>,
}

/// The projection of a point given in a target frame, with the derivatives that pose
/// estimation and calibration need beyond those of [`Projection`].
#[derive(Clone, Debug, PartialEq)]
pub struct TargetProjection {
    /// Projection of the point in the camera frame, with its derivatives (those with
    /// respect to the point are in the camera frame).
    pub projection: Projection,
    /// Derivative with respect to the left perturbation `[omega; tau]` of
    /// `camera_from_target` (see the module documentation).
    pub d_pixel_d_pose: Matrix2x6<f64>,
    /// Derivative with respect to the point in the target frame.
    pub d_pixel_d_target_point: Matrix2x3<f64>,
}

/// Applies a 6-vector pose update `[omega; tau]` (rotation vector, radians; translation,
/// metres) on the left of `camera_from_target`: the parameterization of
/// [`TargetProjection::d_pixel_d_pose`].
pub fn retract_pose(camera_from_target: &Isometry3<f64>, delta: &Vector6<f64>) -> Isometry3<f64> {
    let omega = Vector3::new(delta[0], delta[1], delta[2]);
    let tau = Vector3::new(delta[3], delta[4], delta[5]);
    Isometry3::new(tau, omega) * camera_from_target
}

impl CameraModel {
    /// Projects a point of the camera frame with only the derivative with respect to
    /// the pose that put it there (left perturbation, see [`retract_pose`]): what pose
    /// estimation needs, without the intrinsics' and distortion's derivatives. `None`
    /// when the point is not in front of the camera.
    #[inline]
    pub fn project_with_pose_jacobian(
        &self,
        point_in_camera: &Point3<f64>,
    ) -> Option<(Point2<f64>, Matrix2x6<f64>)> {
        let (x, y, z) = (point_in_camera.x, point_in_camera.y, point_in_camera.z);
        if z <= 0.0 {
            return None;
        }
        let inv_z = 1.0 / z;
        let normalized = Vector2::new(x * inv_z, y * inv_z);
        let (distorted, d_distorted) = self.distortion.distort_with_point_jacobian(&normalized);
        let pixel = self.intrinsics.pixel_from_normalized(&distorted);
        // d(pixel)/d(point) = F * D * d(normalized)/d(point), written out: each row is
        // (a0, a1, -(a0 x + a1 y)) / z.
        let (fx, fy) = (self.intrinsics.fx, self.intrinsics.fy);
        let row = |f: f64, d0: f64, d1: f64| {
            let (a0, a1) = (f * d0 * inv_z, f * d1 * inv_z);
            Vector3::new(a0, a1, -(a0 * normalized.x + a1 * normalized.y))
        };
        let rows = [
            row(fx, d_distorted[(0, 0)], d_distorted[(0, 1)]),
            row(fy, d_distorted[(1, 0)], d_distorted[(1, 1)]),
        ];
        // d(exp(omega) X + tau) / d(omega, tau) at 0 is [-[X]x, I]; a row `a` times
        // -[X]x is (X x a)^T.
        let point = point_in_camera.coords;
        let (turn_u, turn_v) = (point.cross(&rows[0]), point.cross(&rows[1]));
        #[rustfmt::skip]
        let d_pixel_d_pose = Matrix2x6::new(
            turn_u.x, turn_u.y, turn_u.z, rows[0].x, rows[0].y, rows[0].z,
            turn_v.x, turn_v.y, turn_v.z, rows[1].x, rows[1].y, rows[1].z,
        );
        Some((pixel, d_pixel_d_pose))
    }

    /// Projects a point in the camera frame with the analytic derivatives of the pixel
    /// with respect to the point, the intrinsics and the distortion coefficients;
    /// `None` when the point is not in front of the camera (`z <= 0`).
    pub fn project_with_jacobians(&self, point_in_camera: &Point3<f64>) -> Option<Projection> {
        let (x, y, z) = (point_in_camera.x, point_in_camera.y, point_in_camera.z);
        if z <= 0.0 {
            return None;
        }
        let normalized = Vector2::new(x / z, y / z);
        let distortion = self.distortion.distort_with_jacobians(&normalized);
        let focal = Matrix2::new(self.intrinsics.fx, 0.0, 0.0, self.intrinsics.fy);
        let d_normalized_d_point =
            Matrix2x3::new(1.0 / z, 0.0, -x / (z * z), 0.0, 1.0 / z, -y / (z * z));
        let d = distortion.distorted;
        Some(Projection {
            pixel: self.intrinsics.pixel_from_normalized(&d),
            d_pixel_d_point: focal * distortion.d_distorted_d_undistorted * d_normalized_d_point,
            d_pixel_d_intrinsics: Matrix2x4::new(d.x, 0.0, 1.0, 0.0, 0.0, d.y, 0.0, 1.0),
            d_pixel_d_distortion: focal * distortion.d_distorted_d_coeffs,
        })
    }

    /// Projects a point given in a target frame through `camera_from_target`, with the
    /// derivatives of [`CameraModel::project_with_jacobians`] and those with respect to
    /// the pose (left perturbation, see [`retract_pose`]) and the target point; `None`
    /// when the point is not in front of the camera.
    pub fn project_target_point_with_jacobians(
        &self,
        camera_from_target: &Isometry3<f64>,
        point_in_target: &Point3<f64>,
    ) -> Option<TargetProjection> {
        let point_in_camera = camera_from_target * point_in_target;
        let projection = self.project_with_jacobians(&point_in_camera)?;
        let p = point_in_camera.coords;
        // d(exp(omega) X + tau) / d(omega, tau) at 0 is [-[X]x, I].
        let mut d_point_d_pose = nalgebra::Matrix3x6::zeros();
        d_point_d_pose
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-p.cross_matrix()));
        d_point_d_pose
            .fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&Matrix3::identity());
        let rotation = camera_from_target.rotation.to_rotation_matrix();
        Some(TargetProjection {
            d_pixel_d_pose: projection.d_pixel_d_point * d_point_d_pose,
            d_pixel_d_target_point: projection.d_pixel_d_point * rotation.matrix(),
            projection,
        })
    }
}
