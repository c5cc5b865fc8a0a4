//! What rectification is for, checked without any reference implementation: after
//! rectification a scene point images on the same row (horizontal rigs) or column
//! (vertical rigs) in both cameras, and `Q` maps its disparity back to the point.

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3, Vector4};
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::rectify::{
    StereoLayout, StereoRectification, StereoRectifyError, StereoRectifyOptions,
    fisheye_stereo_rectify, stereo_rectify,
};

fn camera(fx: f64, cx: f64, cy: f64, distortion: Distortion) -> CameraModel {
    CameraModel {
        width: 800,
        height: 600,
        intrinsics: Intrinsics {
            fx,
            fy: fx * 1.004,
            cx,
            cy,
        },
        distortion,
    }
}

fn rigs() -> Vec<(&'static str, CameraModel, CameraModel)> {
    vec![
        (
            "plumb_bob",
            camera(
                640.0,
                401.2,
                297.7,
                Distortion::PlumbBob {
                    coeffs: [-0.25, 0.08, 0.001, -0.0005, -0.01],
                },
            ),
            camera(
                652.0,
                396.4,
                303.1,
                Distortion::PlumbBob {
                    coeffs: [-0.24, 0.07, -0.0008, 0.0006, -0.008],
                },
            ),
        ),
        (
            "rational_polynomial",
            camera(
                520.0,
                398.0,
                301.0,
                Distortion::RationalPolynomial {
                    coeffs: [1.2, 0.3, 0.0005, -0.0003, 0.006, 1.5, 0.7, 0.05],
                },
            ),
            camera(
                515.0,
                403.0,
                296.0,
                Distortion::RationalPolynomial {
                    coeffs: [1.1, 0.28, -0.0004, 0.0002, 0.005, 1.4, 0.65, 0.045],
                },
            ),
        ),
        (
            "equidistant",
            camera(
                330.0,
                399.0,
                300.5,
                Distortion::Equidistant {
                    coeffs: [0.03, -0.01, 0.002, -0.0003],
                },
            ),
            camera(
                334.0,
                402.5,
                298.0,
                Distortion::Equidistant {
                    coeffs: [0.028, -0.009, 0.0021, -0.0002],
                },
            ),
        ),
    ]
}

fn right_from_left(translation: Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(translation),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.02, -0.035, 0.015)),
    )
}

/// Rectified pixel of a raw pixel: undistort, rotate into the rectified frame, project
/// with the 3x3 part of P.
fn rectified_pixel(
    camera: &CameraModel,
    rectification: &StereoRectification,
    right: bool,
    raw: &Point2<f64>,
) -> Point2<f64> {
    let (rotation, projection) = if right {
        (
            rectification.right_rectified_from_original,
            rectification.right_projection,
        )
    } else {
        (
            rectification.left_rectified_from_original,
            rectification.left_projection,
        )
    };
    let ray = rotation * camera.unproject(raw).expect("inside the image");
    let p = projection.fixed_view::<3, 3>(0, 0) * ray;
    Point2::new(p.x / p.z, p.y / p.z)
}

/// Scene points in front of the rig, seen by both cameras.
fn scene() -> Vec<Point3<f64>> {
    let mut points = Vec::new();
    for i in 0..7 {
        for j in 0..5 {
            let depth = 0.8 + 0.7 * ((i * 5 + j) % 6) as f64;
            let x = (i as f64 - 3.0) * 0.09 * depth;
            let y = (j as f64 - 2.0) * 0.08 * depth;
            points.push(Point3::new(x, y, depth));
        }
    }
    points
}

fn check_rig(
    name: &str,
    left: &CameraModel,
    right: &CameraModel,
    right_from_left: &Isometry3<f64>,
    rectification: &StereoRectification,
    layout: StereoLayout,
) {
    assert_eq!(rectification.layout, layout, "{name}");
    let (along, across) = match layout {
        StereoLayout::Horizontal => (0, 1),
        StereoLayout::Vertical => (1, 0),
    };
    let mut worst: f64 = 0.0;
    let mut seen_by_both = 0;
    for point in scene() {
        let Some(raw_left) = left.project(&point) else {
            continue;
        };
        let Some(raw_right) = right.project(&(right_from_left * point)) else {
            continue;
        };
        let l = rectified_pixel(left, rectification, false, &raw_left);
        let r = rectified_pixel(right, rectification, true, &raw_right);
        worst = worst.max((l[across] - r[across]).abs());
        seen_by_both += 1;

        // Q maps (u, v, disparity) back to the point in the rectified left frame.
        let disparity = l[along] - r[along];
        let homogeneous = rectification.disparity_to_depth * Vector4::new(l.x, l.y, disparity, 1.0);
        let reconstructed = homogeneous.xyz() / homogeneous.w;
        let expected = rectification.left_rectified_from_original * point.coords;
        assert!(
            (reconstructed - expected).norm() < 1e-9 * expected.norm(),
            "{name}: Q gives {reconstructed:?}, expected {expected:?}"
        );
    }
    assert_eq!(seen_by_both, scene().len(), "{name}");
    assert!(worst < 1e-9, "{name}: rectified rows differ by {worst} px");
}

#[test]
fn horizontal_rigs_share_rows_and_q_recovers_depth() {
    for (name, left, right) in rigs() {
        let rig = right_from_left(Vector3::new(-0.12, 0.004, 0.002));
        for alpha in [None, Some(0.0), Some(0.5), Some(1.0)] {
            let options = StereoRectifyOptions {
                alpha,
                ..StereoRectifyOptions::default()
            };
            let rectification = stereo_rectify(&left, &right, &rig, &options).expect("rectifies");
            check_rig(
                name,
                &left,
                &right,
                &rig,
                &rectification,
                StereoLayout::Horizontal,
            );
        }
        let fisheye =
            fisheye_stereo_rectify(&left, &right, &rig, true, 0.0, None, 1.0).expect("rectifies");
        check_rig(
            name,
            &left,
            &right,
            &rig,
            &fisheye,
            StereoLayout::Horizontal,
        );
    }
}

#[test]
fn vertical_rigs_share_columns_and_carry_the_baseline_in_p2_row_1() {
    for (name, left, right) in rigs() {
        let rig = right_from_left(Vector3::new(0.003, -0.1, 0.002));
        let rectification = stereo_rectify(&left, &right, &rig, &StereoRectifyOptions::default())
            .expect("rectifies");
        check_rig(
            name,
            &left,
            &right,
            &rig,
            &rectification,
            StereoLayout::Vertical,
        );
        assert_ne!(rectification.right_projection[(1, 3)], 0.0);
        assert_eq!(rectification.right_projection[(0, 3)], 0.0);
        let fisheye =
            fisheye_stereo_rectify(&left, &right, &rig, true, 0.5, None, 1.0).expect("rectifies");
        check_rig(name, &left, &right, &rig, &fisheye, StereoLayout::Vertical);
    }
}

#[test]
fn bad_input_is_reported() {
    let (_, left, right) = rigs().remove(0);
    let options = StereoRectifyOptions::default();
    assert_eq!(
        stereo_rectify(&left, &right, &right_from_left(Vector3::zeros()), &options),
        Err(StereoRectifyError::BadBaseline([0.0, 0.0, 0.0]))
    );
    let mut small = right.clone();
    small.width = 640;
    assert!(matches!(
        stereo_rectify(&left, &small, &right_from_left(Vector3::x()), &options),
        Err(StereoRectifyError::SizeMismatch { .. })
    ));
    let nan_alpha = StereoRectifyOptions {
        alpha: Some(f64::NAN),
        ..options
    };
    assert!(matches!(
        stereo_rectify(&left, &right, &right_from_left(Vector3::x()), &nan_alpha),
        Err(StereoRectifyError::BadAlpha(_))
    ));
    let nan_baseline = right_from_left(Vector3::new(f64::NAN, 0.0, 0.0));
    assert!(matches!(
        stereo_rectify(&left, &right, &nan_baseline, &options),
        Err(StereoRectifyError::BadBaseline(_))
    ));
}
