//! Given exactly OpenCV's corners on the 13 real stereo pairs
//! (tests/fixtures/opencv_calib_reference.json, made by
//! interop/opencv_calib_reference.py), the solvers reproduce OpenCV's calibrateCamera
//! (RMS, K, D, standard deviations) and stereoCalibrate with CALIB_FIX_INTRINSIC (RMS,
//! R, T).

use nalgebra::{Isometry3, Matrix3, Point2, Point3, Rotation3, Translation3, UnitQuaternion};
use serde::Deserialize;
use stereocal_vision::calib::{
    MonoCalibration, MonoOptions, StereoOptions, StereoView, View, calibrate_mono, calibrate_stereo,
};
use stereocal_vision::camera::DistortionModel;

#[derive(Deserialize)]
struct Fixture {
    image_size: [u32; 2],
    object_points: Vec<[f64; 3]>,
    pairs: Vec<Pair>,
    left: Mono,
    right: Mono,
    stereo: Stereo,
}

#[derive(Deserialize)]
struct Pair {
    left: Vec<[f64; 2]>,
    right: Vec<[f64; 2]>,
}

#[derive(Deserialize)]
struct Mono {
    rms: f64,
    k: [f64; 9],
    d: [f64; 5],
    std_intrinsics: [f64; 9],
    per_view_rms: Vec<f64>,
}

#[derive(Deserialize)]
struct Stereo {
    rms: f64,
    rotation: [f64; 9],
    translation: [f64; 3],
}

fn fixture() -> Fixture {
    let text = include_str!("fixtures/opencv_calib_reference.json");
    serde_json::from_str(text).unwrap()
}

fn points(fixture: &Fixture) -> Vec<Point3<f64>> {
    fixture
        .object_points
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect()
}

fn pixels(corners: &[[f64; 2]]) -> Vec<Point2<f64>> {
    corners.iter().map(|p| Point2::new(p[0], p[1])).collect()
}

fn views(fixture: &Fixture, side: impl Fn(&Pair) -> &Vec<[f64; 2]>) -> Vec<View> {
    fixture
        .pairs
        .iter()
        .map(|pair| View {
            points_in_target: points(fixture),
            pixels: pixels(side(pair)),
        })
        .collect()
}

/// OpenCV's defaults: plumb_bob with all five coefficients free, every view kept.
fn opencv_options() -> MonoOptions {
    MonoOptions {
        rejection: None,
        ..MonoOptions::new(DistortionModel::PlumbBob)
    }
}

fn relative(got: f64, want: f64) -> f64 {
    ((got - want) / want).abs()
}

fn check_mono(calibration: &MonoCalibration, reference: &Mono) {
    assert!(
        relative(calibration.rms, reference.rms) < 1e-3,
        "RMS {} vs OpenCV {}",
        calibration.rms,
        reference.rms
    );
    // Same minimum: the RMS is not lower than OpenCV's by more than rounding.
    assert!(calibration.rms > reference.rms * (1.0 - 1e-6));
    let k = calibration.camera.intrinsics;
    for (name, got, want) in [
        ("fx", k.fx, reference.k[0]),
        ("fy", k.fy, reference.k[4]),
        ("cx", k.cx, reference.k[2]),
        ("cy", k.cy, reference.k[5]),
    ] {
        assert!(relative(got, want) < 1e-3, "{name} {got} vs OpenCV {want}");
    }
    for (got, want) in calibration
        .camera
        .distortion
        .coeffs()
        .iter()
        .zip(&reference.d)
    {
        assert!(
            (got - want).abs() < 1e-2 * want.abs().max(0.01),
            "D {got} vs OpenCV {want}"
        );
    }
    let std = calibration.std_dev.as_ref().unwrap();
    let reference_std = &reference.std_intrinsics;
    for (name, got, want) in [
        ("fx", std.fx, reference_std[0]),
        ("fy", std.fy, reference_std[1]),
        ("cx", std.cx, reference_std[2]),
        ("cy", std.cy, reference_std[3]),
        ("k1", std.distortion[0], reference_std[4]),
        ("k3", std.distortion[4], reference_std[8]),
    ] {
        assert!(
            relative(got, want) < 1e-2,
            "std {name} {got} vs OpenCV {want}"
        );
    }
    assert_eq!(calibration.views.len(), reference.per_view_rms.len());
    for (fit, want) in calibration.views.iter().zip(&reference.per_view_rms) {
        assert!(
            (fit.rms - want).abs() < 1e-3 * want,
            "view {} RMS {} vs OpenCV {want}",
            fit.index,
            fit.rms
        );
    }
}

#[test]
fn mono_reproduces_opencv_calibrate_camera() {
    let fixture = fixture();
    let [width, height] = fixture.image_size;
    let left = calibrate_mono(
        &views(&fixture, |p| &p.left),
        width,
        height,
        &opencv_options(),
    )
    .unwrap();
    check_mono(&left, &fixture.left);
    let right = calibrate_mono(
        &views(&fixture, |p| &p.right),
        width,
        height,
        &opencv_options(),
    )
    .unwrap();
    check_mono(&right, &fixture.right);
}

#[test]
fn stereo_reproduces_opencv_stereo_calibrate_with_fixed_intrinsics() {
    let fixture = fixture();
    let [width, height] = fixture.image_size;
    let left = calibrate_mono(
        &views(&fixture, |p| &p.left),
        width,
        height,
        &opencv_options(),
    )
    .unwrap();
    let right = calibrate_mono(
        &views(&fixture, |p| &p.right),
        width,
        height,
        &opencv_options(),
    )
    .unwrap();
    let pairs: Vec<StereoView> = fixture
        .pairs
        .iter()
        .map(|pair| StereoView {
            points_in_target: points(&fixture),
            left: pixels(&pair.left),
            right: pixels(&pair.right),
        })
        .collect();
    let options = StereoOptions {
        rejection: None,
        ..StereoOptions::default()
    };
    let stereo = calibrate_stereo(&left.camera, &right.camera, &pairs, &options).unwrap();
    let reference = &fixture.stereo;
    assert!(
        relative(stereo.rms, reference.rms) < 1e-3,
        "stereo RMS {} vs OpenCV {}",
        stereo.rms,
        reference.rms
    );
    let t = nalgebra::Vector3::from(reference.translation);
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_row_slice(&reference.rotation));
    let opencv = Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&r),
    );
    let got = stereo.right_from_left;
    assert!(
        relative(got.translation.vector.norm(), t.norm()) < 1e-3,
        "|T| {} vs OpenCV {}",
        got.translation.vector.norm(),
        t.norm()
    );
    assert!((got.translation.vector - t).norm() < 1e-3 * t.norm());
    assert!(got.rotation.angle_to(&opencv.rotation).to_degrees() < 0.01);
    assert_eq!(stereo.pairs.len(), fixture.pairs.len());
    assert!(
        stereo.epipolar_rms > 0.0 && stereo.epipolar_rms < 0.5,
        "{}",
        stereo.epipolar_rms
    );
}
