//! Camera models against OpenCV: projection, point undistortion and the optimal new
//! camera matrix, on the fixture written by `interop/opencv_camera_reference.py`.

use nalgebra::{Point2, Point3, Vector2};
use stereocal_vision::camera::{CameraModel, DistortionModel, optimal_new_camera_matrix};

use crate::common;
use common::opencv_fixture::{camera, f64s, fixture, roi};

fn reprojection_px(camera: &CameraModel, pixel: &Point2<f64>, undistorted: &Vector2<f64>) -> f64 {
    let back = camera
        .project(&Point3::new(undistorted.x, undistorted.y, 1.0))
        .expect("in front");
    (back - pixel).norm()
}

#[test]
fn projection_matches_opencv() {
    let fixture = fixture();
    for case in fixture["projections"].as_array().expect("projections") {
        let name = case["camera"].as_str().expect("name");
        let camera = camera(&fixture, name);
        let points = f64s(&case["points"]);
        let pixels = f64s(&case["pixels"]);
        for (p, q) in points.chunks(3).zip(pixels.chunks(2)) {
            let ours = camera
                .project(&Point3::new(p[0], p[1], p[2]))
                .expect("in front");
            let error = (ours - Point2::new(q[0], q[1])).norm();
            assert!(
                error < 1e-9,
                "{name}: {p:?} projects {error} px from OpenCV"
            );
        }
    }
}

/// Where OpenCV's iterated undistortion converged, ours agrees with it; where it did not
/// (strong distortion, fisheye near the edge of the field of view), ours still
/// reprojects onto the pixel and so is the more accurate. OpenCV's default 5
/// iterations are pixels off at strong distortion; ours never is.
#[test]
fn undistortion_matches_opencv_where_it_converges_and_beats_it_elsewhere() {
    let fixture = fixture();
    let mut compared = 0;
    let mut opencv_failures = 0;
    for case in fixture["undistortions"].as_array().expect("undistortions") {
        let name = case["camera"].as_str().expect("name");
        let camera = camera(&fixture, name);
        let pixels = f64s(&case["pixels"]);
        let iterated = f64s(&case["opencv_iterated"]);
        let iterated_error = f64s(&case["opencv_iterated_reprojection_px"]);
        let default_error = f64s(&case["opencv_default_reprojection_px"]);
        for (i, pixel) in pixels.chunks(2).enumerate() {
            let pixel = Point2::new(pixel[0], pixel[1]);
            let ours = camera
                .distortion
                .undistort(&camera.intrinsics.normalized_from_pixel(&pixel))
                .unwrap_or_else(|| panic!("{name}: {pixel:?} has a preimage"));
            let our_error = reprojection_px(&camera, &pixel, &ours);
            assert!(
                our_error < 1e-9,
                "{name}: {pixel:?} reprojects {our_error} px away"
            );
            if iterated_error[i] < 1e-9 {
                let theirs = Vector2::new(iterated[2 * i], iterated[2 * i + 1]);
                let difference_px = ((ours - theirs)
                    .component_mul(&Vector2::new(camera.intrinsics.fx, camera.intrinsics.fy)))
                .norm();
                assert!(
                    difference_px < 1e-6,
                    "{name}: {pixel:?} differs from OpenCV by {difference_px} px"
                );
                compared += 1;
            } else {
                assert!(our_error < iterated_error[i]);
                opencv_failures += 1;
            }
            assert!(our_error <= default_error[i].max(1e-9));
        }
    }
    assert!(compared > 1000, "only {compared} points compared");
    // The fisheye fixture reaches where OpenCV's iteration fails: the test covers it.
    assert!(opencv_failures > 0);
}

#[test]
fn pinhole_new_camera_matrix_is_opencvs_with_converged_undistortion() {
    let fixture = fixture();
    let mut checked = 0;
    for case in fixture["new_camera_matrices"].as_array().expect("cases") {
        let name = case["camera"].as_str().expect("name");
        let camera = camera(&fixture, name);
        if camera.distortion.model() == DistortionModel::Equidistant {
            continue;
        }
        let alpha = case["alpha"].as_f64().expect("alpha");
        let size = f64s(&case["new_size"]);
        let new_size = (size[0] as u32, size[1] as u32);
        let (ours, our_roi) =
            optimal_new_camera_matrix(&camera, alpha, new_size).expect("new camera matrix");
        // OpenCV's own algorithm with every border point undistorted to convergence (the
        // script checks that it reproduces OpenCV exactly when fed OpenCV's 5-iteration
        // undistortion). The remaining difference from OpenCV's output is the error of
        // those 5 iterations.
        let k = f64s(&case["converged"]["K"]);
        let expected = [k[0], k[4], k[2], k[5]];
        let got = [ours.fx, ours.fy, ours.cx, ours.cy];
        for (g, e) in got.iter().zip(expected) {
            assert!(
                (g - e).abs() <= 1e-9 * e.abs().max(1.0),
                "{name} alpha {alpha} {new_size:?}: {got:?} vs {expected:?}"
            );
        }
        assert_eq!(
            our_roi,
            roi(&case["converged"]["roi"]),
            "{name} alpha {alpha}"
        );
        checked += 1;
    }
    assert_eq!(checked, 18);
}

#[test]
fn pinhole_new_camera_matrix_is_close_to_opencv_for_moderate_distortion() {
    // With moderate distortion OpenCV's 5 iterations are within 0.1 px, so its matrix and
    // ROI are within that of ours.
    let fixture = fixture();
    let camera = camera(&fixture, "wide_plumb_bob");
    for case in fixture["new_camera_matrices"].as_array().expect("cases") {
        if case["camera"] != "wide_plumb_bob" {
            continue;
        }
        let alpha = case["alpha"].as_f64().expect("alpha");
        let size = f64s(&case["new_size"]);
        let (ours, our_roi) =
            optimal_new_camera_matrix(&camera, alpha, (size[0] as u32, size[1] as u32))
                .expect("new camera matrix");
        let k = f64s(&case["opencv"]["K"]);
        let got = [ours.fx, ours.fy, ours.cx, ours.cy];
        for (g, e) in got.iter().zip([k[0], k[4], k[2], k[5]]) {
            assert!((g - e).abs() < 0.1, "alpha {alpha}: {g} vs OpenCV {e}");
        }
        let theirs = roi(&case["opencv"]["roi"]);
        for (a, b) in [
            (our_roi.x, theirs.x),
            (our_roi.y, theirs.y),
            (our_roi.width, theirs.width),
            (our_roi.height, theirs.height),
        ] {
            assert!(
                a.abs_diff(b) <= 1,
                "alpha {alpha}: {our_roi:?} vs {theirs:?}"
            );
        }
    }
}

#[test]
fn fisheye_new_camera_matrix_matches_opencv() {
    let fixture = fixture();
    let mut checked = 0;
    for case in fixture["new_camera_matrices"].as_array().expect("cases") {
        let name = case["camera"].as_str().expect("name");
        let camera = camera(&fixture, name);
        if camera.distortion.model() != DistortionModel::Equidistant {
            continue;
        }
        let balance = case["alpha"].as_f64().expect("balance");
        let size = f64s(&case["new_size"]);
        let new_size = (size[0] as u32, size[1] as u32);
        let (ours, roi) =
            optimal_new_camera_matrix(&camera, balance, new_size).expect("new camera matrix");
        let k = f64s(&case["opencv"]["K"]);
        let expected = [k[0], k[4], k[2], k[5]];
        let got = [ours.fx, ours.fy, ours.cx, ours.cy];
        for (g, e) in got.iter().zip(expected) {
            assert!(
                (g - e).abs() <= 1e-9 * e.abs().max(1.0),
                "balance {balance} {new_size:?}: {got:?} vs OpenCV {expected:?}"
            );
        }
        assert!(roi.width > 0 && roi.height > 0);
        assert!(roi.x + roi.width <= new_size.0 && roi.y + roi.height <= new_size.1);
        checked += 1;
    }
    assert_eq!(checked, 6);
}
