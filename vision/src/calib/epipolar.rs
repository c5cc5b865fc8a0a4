//! Epipolar geometry of a calibrated pair: essential and fundamental matrices and the
//! distance of corners to their epipolar lines.

use nalgebra::{Isometry3, Matrix3, Point2};

use crate::camera::CameraModel;

/// The essential matrix `E = [t]x R` of `right_from_left = (R, t)`: normalized
/// undistorted coordinates satisfy `x_right^T E x_left = 0` (OpenCV's convention).
pub fn essential_matrix(right_from_left: &Isometry3<f64>) -> Matrix3<f64> {
    right_from_left.translation.vector.cross_matrix()
        * right_from_left.rotation.to_rotation_matrix().matrix()
}

/// The fundamental matrix `F = K_right^-T E K_left^-1` on undistorted pixels, scaled so
/// that `F[(2, 2)] = 1` when that entry is not zero (as OpenCV's `stereoCalibrate`).
pub fn fundamental_matrix(
    left: &CameraModel,
    right: &CameraModel,
    essential: &Matrix3<f64>,
) -> Matrix3<f64> {
    let inverse = |c: &CameraModel| {
        let k = &c.intrinsics;
        Matrix3::new(
            1.0 / k.fx,
            0.0,
            -k.cx / k.fx,
            0.0,
            1.0 / k.fy,
            -k.cy / k.fy,
            0.0,
            0.0,
            1.0,
        )
    };
    let f = inverse(right).transpose() * essential * inverse(left);
    let scale = f[(2, 2)];
    if scale.abs() > f.norm() * 1e-15 {
        f / scale
    } else {
        f
    }
}

/// Distances in pixels of the right corners, undistorted, to the epipolar lines of the
/// corresponding left corners, undistorted (pixel centres at integer coordinates); a
/// corner that does not undistort is left out.
pub fn epipolar_distances(
    left: &CameraModel,
    right: &CameraModel,
    fundamental: &Matrix3<f64>,
    left_pixels: &[Point2<f64>],
    right_pixels: &[Point2<f64>],
) -> Vec<f64> {
    left_pixels
        .iter()
        .zip(right_pixels)
        .filter_map(|(l, r)| {
            let l = left.undistort_pixel(l)?;
            let r = right.undistort_pixel(r)?;
            let line = fundamental * l.to_homogeneous();
            let norm = (line.x * line.x + line.y * line.y).sqrt();
            (norm > 0.0).then(|| line.dot(&r.to_homogeneous()).abs() / norm)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Distortion, Intrinsics};
    use nalgebra::{Point3, Vector3};

    #[test]
    fn corresponding_points_lie_on_their_epipolar_lines() {
        let camera = CameraModel {
            width: 640,
            height: 480,
            intrinsics: Intrinsics {
                fx: 500.0,
                fy: 505.0,
                cx: 320.0,
                cy: 240.0,
            },
            distortion: Distortion::PlumbBob {
                coeffs: [-0.2, 0.05, 0.001, -0.001, 0.0],
            },
        };
        let right_from_left = Isometry3::new(
            Vector3::new(-0.12, 0.004, 0.002),
            Vector3::new(0.01, -0.02, 0.005),
        );
        let f = fundamental_matrix(&camera, &camera, &essential_matrix(&right_from_left));
        assert_eq!(f[(2, 2)], 1.0);
        let points = [Point3::new(0.1, -0.05, 1.0), Point3::new(-0.3, 0.2, 2.5)];
        let left: Vec<Point2<f64>> = points.iter().map(|p| camera.project(p).unwrap()).collect();
        let right: Vec<Point2<f64>> = points
            .iter()
            .map(|p| camera.project(&(right_from_left * p)).unwrap())
            .collect();
        for d in epipolar_distances(&camera, &camera, &f, &left, &right) {
            assert!(d < 1e-6, "{d}");
        }
        let moved: Vec<Point2<f64>> = right
            .iter()
            .map(|p| p + nalgebra::Vector2::new(0.0, 2.0))
            .collect();
        let d = epipolar_distances(&camera, &camera, &f, &left, &moved);
        assert!(d.iter().all(|&d| d > 1.5), "{d:?}");
    }
}
