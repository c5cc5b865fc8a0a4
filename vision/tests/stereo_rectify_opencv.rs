//! Stereo rectification against OpenCV's `stereoRectify` and `fisheye::stereoRectify`,
//! on the fixture written by `interop/opencv_camera_reference.py`.

use nalgebra::{DMatrix, Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde_json::Value;
use stereocal_vision::camera::CameraModel;
use stereocal_vision::rectify::{
    StereoLayout, StereoRectification, StereoRectifyOptions, fisheye_stereo_rectify, stereo_rectify,
};

use crate::common;
use common::opencv_fixture::{camera, f64s, fixture, roi};

fn matrix(value: &Value, rows: usize, cols: usize) -> DMatrix<f64> {
    DMatrix::from_row_slice(rows, cols, &f64s(value))
}

/// The rig's cameras and `right_from_left` (OpenCV's `R`, `T`).
fn rig(fixture: &Value, name: &str) -> (CameraModel, CameraModel, Isometry3<f64>) {
    let rig = &fixture["rigs"][name];
    let rvec = f64s(&rig["rvec"]);
    let tvec = f64s(&rig["tvec"]);
    let right_from_left = Isometry3::from_parts(
        Translation3::new(tvec[0], tvec[1], tvec[2]),
        UnitQuaternion::from_scaled_axis(Vector3::new(rvec[0], rvec[1], rvec[2])),
    );
    (
        camera(fixture, rig["left"].as_str().expect("left")),
        camera(fixture, rig["right"].as_str().expect("right")),
        right_from_left,
    )
}

fn to_dynamic(m: impl AsRef<[f64]>, rows: usize, cols: usize) -> DMatrix<f64> {
    DMatrix::from_column_slice(rows, cols, m.as_ref())
}

fn assert_matrix_close(what: &str, ours: &DMatrix<f64>, theirs: &DMatrix<f64>, relative: f64) {
    let scale = theirs.abs().max().max(1.0);
    let error = (ours - theirs).abs().max();
    assert!(
        error <= relative * scale,
        "{what}: ours\n{ours}\nreference\n{theirs}\nmax error {error}"
    );
}

fn rotation(r: &Rotation3<f64>) -> DMatrix<f64> {
    to_dynamic(r.matrix().as_slice(), 3, 3)
}

fn ours_as_matrices(r: &StereoRectification) -> [(&'static str, DMatrix<f64>); 5] {
    [
        ("R1", rotation(&r.left_rectified_from_original)),
        ("R2", rotation(&r.right_rectified_from_original)),
        ("P1", to_dynamic(r.left_projection.as_slice(), 3, 4)),
        ("P2", to_dynamic(r.right_projection.as_slice(), 3, 4)),
        ("Q", to_dynamic(r.disparity_to_depth.as_slice(), 4, 4)),
    ]
}

/// R1 and R2 are pure double-precision algebra in OpenCV too: they agree to rounding.
/// P, Q and the ROIs depend on undistorted image points, which OpenCV computes with 5
/// fixed-point iterations (in single precision for the four corners); they are compared
/// with OpenCV's algorithm re-run with converged undistortion (the script checks that the
/// re-run reproduces OpenCV exactly when given OpenCV's own undistortion).
#[test]
fn stereo_rectify_matches_opencv() {
    let fixture = fixture();
    let mut checked = 0;
    for case in fixture["stereo_rectifications"].as_array().expect("cases") {
        let rig_name = case["rig"].as_str().expect("rig");
        let (left, right, right_from_left) = rig(&fixture, rig_name);
        let alpha = case["alpha"].as_f64().expect("alpha");
        let options = StereoRectifyOptions {
            zero_disparity: case["zero_disparity"].as_bool().expect("flag"),
            alpha: (alpha >= 0.0).then_some(alpha),
            new_size: case["new_size"].as_array().map(|s| {
                (
                    s[0].as_u64().expect("width") as u32,
                    s[1].as_u64().expect("height") as u32,
                )
            }),
        };
        let what = format!("{rig_name} {options:?}");
        let ours = stereo_rectify(&left, &right, &right_from_left, &options).expect("rectifies");
        let matrices = ours_as_matrices(&ours);
        for (name, theirs) in
            [("R1", 3), ("R2", 3)].map(|(k, n)| (k, matrix(&case["opencv"][k], n, 3)))
        {
            let our = &matrices.iter().find(|(k, _)| *k == name).expect("ours").1;
            assert_matrix_close(&format!("{what} {name}"), our, &theirs, 1e-12);
        }
        for (name, rows, cols) in [("P1", 3, 4), ("P2", 3, 4), ("Q", 4, 4)] {
            let theirs = matrix(&case["converged"][name], rows, cols);
            let our = &matrices.iter().find(|(k, _)| *k == name).expect("ours").1;
            assert_matrix_close(&format!("{what} {name}"), our, &theirs, 1e-9);
        }
        assert_eq!(
            ours.left_roi,
            roi(&case["converged"]["roi1"]),
            "{what} roi1"
        );
        assert_eq!(
            ours.right_roi,
            roi(&case["converged"]["roi2"]),
            "{what} roi2"
        );
        let vertical = rig_name == "vertical";
        assert_eq!(
            ours.layout,
            if vertical {
                StereoLayout::Vertical
            } else {
                StereoLayout::Horizontal
            }
        );
        // The baseline sits where camera_info consumers look for it: -f * baseline for
        // a right (or lower) camera whose origin is at negative x (y) in the right frame.
        let (along, across) = if vertical { (1, 0) } else { (0, 1) };
        assert!(ours.right_projection[(along, 3)] < 0.0, "{what}");
        assert_eq!(ours.right_projection[(across, 3)], 0.0, "{what}");
        checked += 1;
    }
    assert_eq!(checked, 21);
}

#[test]
fn stereo_rectify_is_close_to_opencv_for_moderate_distortion() {
    // For the moderately distorted rigs OpenCV's inexact undistortion moves P and Q by
    // less than 0.1 px.
    let fixture = fixture();
    for case in fixture["stereo_rectifications"].as_array().expect("cases") {
        let rig_name = case["rig"].as_str().expect("rig");
        if rig_name == "rational_horizontal" {
            continue;
        }
        let (left, right, right_from_left) = rig(&fixture, rig_name);
        let alpha = case["alpha"].as_f64().expect("alpha");
        let options = StereoRectifyOptions {
            zero_disparity: case["zero_disparity"].as_bool().expect("flag"),
            alpha: (alpha >= 0.0).then_some(alpha),
            new_size: case["new_size"].as_array().map(|s| {
                (
                    s[0].as_u64().expect("w") as u32,
                    s[1].as_u64().expect("h") as u32,
                )
            }),
        };
        let ours = stereo_rectify(&left, &right, &right_from_left, &options).expect("rectifies");
        let p1 = matrix(&case["opencv"]["P1"], 3, 4);
        let p2 = matrix(&case["opencv"]["P2"], 3, 4);
        let our_p1 = to_dynamic(ours.left_projection.as_slice(), 3, 4);
        let our_p2 = to_dynamic(ours.right_projection.as_slice(), 3, 4);
        assert!((our_p1 - p1).abs().max() < 0.1, "{rig_name} {options:?}");
        assert!((our_p2 - p2).abs().max() < 0.1, "{rig_name} {options:?}");
    }
}

#[test]
fn fisheye_stereo_rectify_matches_opencv() {
    let fixture = fixture();
    let mut checked = 0;
    for case in fixture["fisheye_stereo_rectifications"]
        .as_array()
        .expect("cases")
    {
        let (left, right, right_from_left) = rig(&fixture, case["rig"].as_str().expect("rig name"));
        let new_size = case["new_size"].as_array().map(|s| {
            (
                s[0].as_u64().expect("w") as u32,
                s[1].as_u64().expect("h") as u32,
            )
        });
        let ours = fisheye_stereo_rectify(
            &left,
            &right,
            &right_from_left,
            case["zero_disparity"].as_bool().expect("flag"),
            case["balance"].as_f64().expect("balance"),
            new_size,
            case["fov_scale"].as_f64().expect("fov_scale"),
        )
        .expect("rectifies");
        // fisheye::undistortPoints converges on these points, so OpenCV's values are exact.
        for (name, our) in ours_as_matrices(&ours) {
            let (rows, cols) = our.shape();
            let theirs = matrix(&case["opencv"][name], rows, cols);
            assert_matrix_close(&format!("fisheye {case} {name}"), &our, &theirs, 1e-9);
        }
        let size = new_size.unwrap_or((left.width, left.height));
        for roi in [ours.left_roi, ours.right_roi] {
            assert!(roi.width > size.0 / 2 && roi.height > size.1 / 2, "{roi:?}");
        }
        checked += 1;
    }
    assert_eq!(checked, 5);
}

#[test]
fn rotations_are_proper() {
    let fixture = fixture();
    let (left, right, right_from_left) = rig(&fixture, "horizontal");
    let ours = stereo_rectify(
        &left,
        &right,
        &right_from_left,
        &StereoRectifyOptions::default(),
    )
    .expect("rectifies");
    for r in [
        ours.left_rectified_from_original,
        ours.right_rectified_from_original,
    ] {
        let m: Matrix3<f64> = r.into_inner();
        assert!((m * m.transpose() - Matrix3::identity()).abs().max() < 1e-14);
        assert!((m.determinant() - 1.0).abs() < 1e-14);
    }
}
