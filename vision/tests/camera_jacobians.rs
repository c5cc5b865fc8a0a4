//! Every analytic Jacobian of the camera models against central finite differences,
//! for the three distortion models.

use nalgebra::{
    DMatrix, DVector, Dim, Isometry3, Matrix, Point3, RawStorage, Translation3, UnitQuaternion,
    Vector2, Vector3, Vector6,
};
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics, retract_pose};

const STEP: f64 = 1e-6;

fn models() -> Vec<CameraModel> {
    let intrinsics = Intrinsics {
        fx: 612.5,
        fy: 608.25,
        cx: 321.7,
        cy: 238.4,
    };
    [
        Distortion::PlumbBob {
            coeffs: [-0.28, 0.09, 0.0011, -0.0007, -0.012],
        },
        Distortion::RationalPolynomial {
            coeffs: [1.6, 0.35, 0.0007, -0.0004, 0.008, 2.0, 0.9, 0.06],
        },
        Distortion::Equidistant {
            coeffs: [0.04, -0.012, 0.003, -0.0004],
        },
    ]
    .into_iter()
    .map(|distortion| CameraModel {
        width: 640,
        height: 480,
        intrinsics,
        distortion,
    })
    .collect()
}

/// Points spread over the field of view, including one on the optical axis.
fn points_in_camera() -> Vec<Point3<f64>> {
    vec![
        Point3::new(0.0, 0.0, 2.0),
        Point3::new(0.31, -0.22, 1.4),
        Point3::new(-0.9, 0.45, 1.1),
        Point3::new(0.7, 0.8, 0.9),
        Point3::new(-0.05, -0.6, 3.2),
    ]
}

/// Central differences of `f` around `x`, one column per parameter.
fn numeric(x: &DVector<f64>, f: impl Fn(&DVector<f64>) -> DVector<f64>) -> DMatrix<f64> {
    let rows = f(x).len();
    let mut jacobian = DMatrix::zeros(rows, x.len());
    for i in 0..x.len() {
        let h = STEP * x[i].abs().max(1.0);
        let mut plus = x.clone();
        let mut minus = x.clone();
        plus[i] += h;
        minus[i] -= h;
        jacobian.set_column(i, &((f(&plus) - f(&minus)) / (2.0 * h)));
    }
    jacobian
}

fn assert_close(what: &str, analytic: DMatrix<f64>, numeric: DMatrix<f64>) {
    assert_eq!(analytic.shape(), numeric.shape(), "{what}: shape");
    let scale = numeric.abs().max().max(1.0);
    let error = (&analytic - &numeric).abs().max();
    assert!(
        error <= 1e-6 * scale,
        "{what}: analytic\n{analytic}\nnumeric\n{numeric}\nmax error {error} (scale {scale})"
    );
}

fn dyn2<R: Dim, C: Dim, S: RawStorage<f64, R, C>>(m: &Matrix<f64, R, C, S>) -> DMatrix<f64> {
    DMatrix::from_iterator(m.nrows(), m.ncols(), m.iter().copied())
}

#[test]
fn distortion_jacobians_match_finite_differences() {
    for camera in models() {
        let model = camera.distortion.model();
        for point in points_in_camera() {
            let p = Vector2::new(point.x / point.z, point.y / point.z);
            let jacobians = camera.distortion.distort_with_jacobians(&p);
            assert_eq!(jacobians.distorted, camera.distortion.distort(&p));
            let x = DVector::from_column_slice(p.as_slice());
            let numeric_point = numeric(&x, |x| {
                let d = camera.distortion.distort(&Vector2::new(x[0], x[1]));
                DVector::from_column_slice(d.as_slice())
            });
            assert_close(
                &format!("{model:?} d_distorted_d_undistorted at {p:?}"),
                dyn2(&jacobians.d_distorted_d_undistorted),
                numeric_point,
            );
            let coeffs = DVector::from_column_slice(camera.distortion.coeffs());
            let numeric_coeffs = numeric(&coeffs, |c| {
                let distortion = Distortion::from_coeffs(model, c.as_slice()).expect("same model");
                DVector::from_column_slice(distortion.distort(&p).as_slice())
            });
            assert_close(
                &format!("{model:?} d_distorted_d_coeffs at {p:?}"),
                dyn2(&jacobians.d_distorted_d_coeffs),
                numeric_coeffs,
            );
        }
    }
}

#[test]
fn projection_jacobians_match_finite_differences() {
    for camera in models() {
        let model = camera.distortion.model();
        for point in points_in_camera() {
            let projection = camera.project_with_jacobians(&point).expect("in front");
            assert_eq!(Some(projection.pixel), camera.project(&point));
            let pixel_of = |camera: &CameraModel, point: &Point3<f64>| {
                let pixel = camera.project(point).expect("in front");
                DVector::from_column_slice(pixel.coords.as_slice())
            };

            let x = DVector::from_column_slice(point.coords.as_slice());
            let numeric_point = numeric(&x, |x| pixel_of(&camera, &Point3::new(x[0], x[1], x[2])));
            assert_close(
                &format!("{model:?} d_pixel_d_point at {point:?}"),
                dyn2(&projection.d_pixel_d_point),
                numeric_point,
            );

            let k = &camera.intrinsics;
            let x = DVector::from_column_slice(&[k.fx, k.fy, k.cx, k.cy]);
            let numeric_intrinsics = numeric(&x, |x| {
                let mut other = camera.clone();
                other.intrinsics = Intrinsics {
                    fx: x[0],
                    fy: x[1],
                    cx: x[2],
                    cy: x[3],
                };
                pixel_of(&other, &point)
            });
            assert_close(
                &format!("{model:?} d_pixel_d_intrinsics at {point:?}"),
                dyn2(&projection.d_pixel_d_intrinsics),
                numeric_intrinsics,
            );

            let x = DVector::from_column_slice(camera.distortion.coeffs());
            let numeric_distortion = numeric(&x, |c| {
                let mut other = camera.clone();
                other.distortion = Distortion::from_coeffs(model, c.as_slice()).expect("model");
                pixel_of(&other, &point)
            });
            assert_close(
                &format!("{model:?} d_pixel_d_distortion at {point:?}"),
                dyn2(&projection.d_pixel_d_distortion),
                numeric_distortion,
            );
        }
    }
}

#[test]
fn pose_and_target_point_jacobians_match_finite_differences() {
    let camera_from_target = Isometry3::from_parts(
        Translation3::new(-0.12, 0.05, 1.3),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.5, 0.2)),
    );
    let target_points = [
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(0.25, 0.0, 0.0),
        Point3::new(0.1, 0.3, 0.0),
        Point3::new(-0.2, -0.15, 0.05),
    ];
    for camera in models() {
        let model = camera.distortion.model();
        for point in target_points {
            let projected = camera
                .project_target_point_with_jacobians(&camera_from_target, &point)
                .expect("in front");
            assert_eq!(
                Some(projected.projection.pixel),
                camera.project(&(camera_from_target * point))
            );

            let numeric_pose = numeric(&DVector::zeros(6), |delta| {
                let delta = Vector6::from_column_slice(delta.as_slice());
                let pose = retract_pose(&camera_from_target, &delta);
                let pixel = camera.project(&(pose * point)).expect("in front");
                DVector::from_column_slice(pixel.coords.as_slice())
            });
            assert_close(
                &format!("{model:?} d_pixel_d_pose at {point:?}"),
                dyn2(&projected.d_pixel_d_pose),
                numeric_pose,
            );

            let x = DVector::from_column_slice(point.coords.as_slice());
            let numeric_target = numeric(&x, |x| {
                let p = camera_from_target * Point3::new(x[0], x[1], x[2]);
                let pixel = camera.project(&p).expect("in front");
                DVector::from_column_slice(pixel.coords.as_slice())
            });
            assert_close(
                &format!("{model:?} d_pixel_d_target_point at {point:?}"),
                dyn2(&projected.d_pixel_d_target_point),
                numeric_target,
            );
        }
    }
}

#[test]
fn retract_pose_with_zero_is_identity_and_moves_camera_frame_points() {
    let pose = Isometry3::from_parts(
        Translation3::new(0.1, 0.2, 0.3),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.4, 0.0)),
    );
    assert_eq!(retract_pose(&pose, &Vector6::zeros()), pose);
    let delta = Vector6::new(0.0, 0.0, 0.0, 0.01, -0.02, 0.03);
    let moved = retract_pose(&pose, &delta) * Point3::origin();
    let expected = pose * Point3::origin() + Vector3::new(0.01, -0.02, 0.03);
    assert!((moved - expected).norm() < 1e-15);
}

#[test]
fn points_behind_the_camera_have_no_projection() {
    let camera = &models()[0];
    assert!(
        camera
            .project_with_jacobians(&Point3::new(0.1, 0.1, -1.0))
            .is_none()
    );
    assert!(
        camera
            .project_with_jacobians(&Point3::new(0.1, 0.1, 0.0))
            .is_none()
    );
}

/// The pose-only projection is the full one's pixel and pose derivative.
#[test]
fn pose_only_projection_matches_the_full_one() {
    use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
    use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};
    for (model, d) in [
        (
            DistortionModel::PlumbBob,
            vec![-0.25, 0.08, 0.001, -0.0005, 0.01],
        ),
        (
            DistortionModel::RationalPolynomial,
            vec![0.3, -0.1, 0.001, 0.002, 0.01, 0.5, -0.05, 0.02],
        ),
        (
            DistortionModel::Equidistant,
            vec![0.05, -0.01, 0.002, -0.0005],
        ),
    ] {
        let camera = CameraModel {
            width: 1024,
            height: 768,
            intrinsics: Intrinsics {
                fx: 800.0,
                fy: 805.0,
                cx: 515.0,
                cy: 380.0,
            },
            distortion: Distortion::from_coeffs(model, &d).unwrap(),
        };
        let pose = Isometry3::from_parts(
            Translation3::new(-0.1, 0.05, 0.7),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.2, 0.1)),
        );
        let point = Point3::new(0.2, 0.1, 0.0);
        let full = camera
            .project_target_point_with_jacobians(&pose, &point)
            .unwrap();
        let (pixel, jacobian) = camera.project_with_pose_jacobian(&(pose * point)).unwrap();
        assert!((pixel - full.projection.pixel).norm() < 1e-12, "{model:?}");
        assert!(
            (jacobian - full.d_pixel_d_pose).abs().max() < 1e-9,
            "{model:?}"
        );
    }
}
