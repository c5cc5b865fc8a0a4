//! Closed-form starting points: intrinsics from plane homographies (pinhole models) or
//! from the image size (equidistant), and each view's pose from the homography of its
//! undistorted corners.

use nalgebra::{
    Isometry3, Matrix2, Matrix3, Point2, Rotation3, Translation3, UnitQuaternion, Vector2,
};

use super::View;
use crate::camera::{CameraModel, Intrinsics};
use crate::geometry::homography_dlt;

/// Pinhole intrinsics from the homographies (target plane to pixels) of several views,
/// as OpenCV's `initIntrinsicParams2D`: the principal point at the image centre (pixel
/// centres at integer coordinates, so `(w - 1) / 2`), then `1/fx^2` and `1/fy^2` by
/// least squares from Zhang's constraints (the images of the target's x and y axes, and
/// of its two diagonals, are orthogonal). With `aspect_ratio`, `fx / fy` is set to it
/// keeping `fx + fy`. `None` when the constraints do not determine positive focal
/// lengths: views nearly fronto-parallel, or too few.
pub(crate) fn pinhole_intrinsics(
    homographies: &[Matrix3<f64>],
    width: u32,
    height: u32,
    aspect_ratio: Option<f64>,
) -> Option<Intrinsics> {
    let cx = (f64::from(width) - 1.0) * 0.5;
    let cy = (f64::from(height) - 1.0) * 0.5;
    let centre_inverse = Matrix3::new(1.0, 0.0, -cx, 0.0, 1.0, -cy, 0.0, 0.0, 1.0);
    let mut ata = Matrix2::zeros();
    let mut atb = Vector2::zeros();
    for h in homographies {
        let h = centre_inverse * h;
        let x_axis = h.column(0).normalize();
        let y_axis = h.column(1).normalize();
        let diagonal = (h.column(0) + h.column(1)).normalize();
        let antidiagonal = (h.column(0) - h.column(1)).normalize();
        for (a, b) in [(x_axis, y_axis), (diagonal, antidiagonal)] {
            let row = Vector2::new(a.x * b.x, a.y * b.y);
            let rhs = -a.z * b.z;
            ata += row * row.transpose();
            atb += row * rhs;
        }
    }
    let inverse_squares = ata.try_inverse()? * atb;
    if !(inverse_squares.x > 0.0 && inverse_squares.y > 0.0) {
        return None;
    }
    let mut fx = 1.0 / inverse_squares.x.sqrt();
    let mut fy = 1.0 / inverse_squares.y.sqrt();
    if let Some(ratio) = aspect_ratio {
        let f = (fx + fy) / (ratio + 1.0);
        fx = ratio * f;
        fy = f;
    }
    let limit = 1e3 * f64::from(width.max(height));
    if !(fx.is_finite() && fy.is_finite() && fx < limit && fy < limit) {
        return None;
    }
    Some(Intrinsics { fx, fy, cx, cy })
}

/// Equidistant (fisheye) intrinsics as `cv::fisheye::calibrate` starts: a 180-degree
/// field of view across the larger image side, principal point at the image centre.
pub(crate) fn fisheye_intrinsics(width: u32, height: u32) -> Intrinsics {
    let f = f64::from(width.max(height)) / std::f64::consts::PI;
    Intrinsics {
        fx: f,
        fy: f,
        cx: (f64::from(width) - 1.0) * 0.5,
        cy: (f64::from(height) - 1.0) * 0.5,
    }
}

/// `camera_from_target` of a planar view (target points at `z = 0`) from the
/// homography of its corners undistorted through `camera`; `None` when too few corners
/// undistort or they are degenerate.
pub(crate) fn initial_pose(camera: &CameraModel, view: &View) -> Option<Isometry3<f64>> {
    let mut plane = Vec::with_capacity(view.pixels.len());
    let mut normalized = Vec::with_capacity(view.pixels.len());
    for (point, pixel) in view.points_in_target.iter().zip(&view.pixels) {
        if let Some(ray) = camera.unproject(pixel) {
            plane.push(Point2::new(point.x, point.y));
            normalized.push(Point2::new(ray.x, ray.y));
        }
    }
    pose_from_homography(&homography_dlt(&plane, &normalized).ok()?)
}

/// Decomposes `H ~ [r1 r2 t]` (target plane to normalized image coordinates) into the
/// nearest rotation and the translation, with the target in front of the camera.
fn pose_from_homography(h: &Matrix3<f64>) -> Option<Isometry3<f64>> {
    let norm = (h.column(0).norm() + h.column(1).norm()) * 0.5;
    if norm.is_nan() || norm <= 0.0 {
        return None;
    }
    let sign = if h[(2, 2)] < 0.0 { -1.0 } else { 1.0 };
    let scale = sign / norm;
    let r1 = h.column(0) * scale;
    let r2 = h.column(1) * scale;
    let t = h.column(2) * scale;
    let approximate = Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]);
    let svd = approximate.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut rotation = u * v_t;
    if rotation.determinant() < 0.0 {
        let mut u = u;
        u.column_mut(2).neg_mut();
        rotation = u * v_t;
    }
    let rotation =
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rotation));
    Some(Isometry3::from_parts(Translation3::from(t), rotation))
}

/// Angle in radians between the target's normal and the camera's optical axis.
pub(crate) fn tilt(camera_from_target: &Isometry3<f64>) -> f64 {
    let normal = camera_from_target.rotation * nalgebra::Vector3::z();
    normal.z.abs().min(1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Distortion;
    use nalgebra::{Point3, Vector3};

    fn board() -> Vec<Point3<f64>> {
        (0..6)
            .flat_map(|r| (0..9).map(move |c| Point3::new(c as f64 * 0.03, r as f64 * 0.03, 0.0)))
            .collect()
    }

    fn camera() -> CameraModel {
        CameraModel {
            width: 1024,
            height: 768,
            intrinsics: Intrinsics {
                fx: 800.0,
                fy: 790.0,
                cx: 511.5,
                cy: 383.5,
            },
            distortion: Distortion::none(),
        }
    }

    fn view(camera_from_target: &Isometry3<f64>) -> View {
        let points = board();
        let pixels = points
            .iter()
            .map(|p| camera().project(&(camera_from_target * p)).unwrap())
            .collect();
        View {
            points_in_target: points,
            pixels,
        }
    }

    fn poses() -> Vec<Isometry3<f64>> {
        vec![
            Isometry3::new(Vector3::new(-0.1, -0.05, 0.5), Vector3::new(0.4, 0.1, 0.05)),
            Isometry3::new(
                Vector3::new(-0.12, -0.08, 0.6),
                Vector3::new(-0.1, 0.5, 0.0),
            ),
            Isometry3::new(Vector3::new(-0.1, -0.1, 0.55), Vector3::new(0.3, -0.3, 0.2)),
        ]
    }

    #[test]
    fn initial_pose_recovers_an_exact_view() {
        for truth in poses() {
            let pose = initial_pose(&camera(), &view(&truth)).unwrap();
            assert!((pose.translation.vector - truth.translation.vector).norm() < 1e-9);
            assert!(pose.rotation.angle_to(&truth.rotation) < 1e-9);
            assert!((tilt(&pose) - tilt(&truth)).abs() < 1e-9);
            assert!(tilt(&truth) > 0.1);
        }
    }

    #[test]
    fn tilt_is_the_angle_of_the_target_normal_to_the_optical_axis() {
        let about_x = Isometry3::new(Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.3, 0.0, 0.0));
        assert!((tilt(&about_x) - 0.3).abs() < 1e-12);
        let rolled = Isometry3::new(Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.0, 0.0, 1.2));
        assert!(tilt(&rolled) < 1e-12);
    }

    #[test]
    fn pinhole_intrinsics_from_exact_homographies() {
        let homographies: Vec<Matrix3<f64>> = poses()
            .iter()
            .map(|pose| {
                let v = view(pose);
                let plane: Vec<Point2<f64>> = v.points_in_target.iter().map(|p| p.xy()).collect();
                homography_dlt(&plane, &v.pixels).unwrap()
            })
            .collect();
        let k = pinhole_intrinsics(&homographies, 1024, 768, None).unwrap();
        // The true principal point is the centre, so the focal lengths are exact.
        assert!(
            (k.fx - 800.0).abs() < 1e-6 && (k.fy - 790.0).abs() < 1e-6,
            "{k:?}"
        );
    }

    #[test]
    fn fronto_parallel_views_do_not_determine_focal_length() {
        let fronto = Isometry3::new(Vector3::new(-0.1, -0.05, 0.5), Vector3::zeros());
        let v = view(&fronto);
        let plane: Vec<Point2<f64>> = v.points_in_target.iter().map(|p| p.xy()).collect();
        let h = homography_dlt(&plane, &v.pixels).unwrap();
        assert!(pinhole_intrinsics(&[h, h, h], 1024, 768, None).is_none());
    }
}
