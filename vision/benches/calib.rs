//! The mono and stereo solves on OpenCV's corners of the 13 real stereo pairs
//! (tests/fixtures/opencv_calib_reference.json). `interop/bench_calibrate_opencv.py`
//! times the same solves against cv2.calibrateCamera and cv2.stereoCalibrate side by
//! side, on the corners of a synthetic 1280x720 session.
// A benchmark on fixed inputs: an input that fails is a bug to see at once.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point2, Point3};
use serde::Deserialize;
use std::hint::black_box;
use stereocal_vision::calib::{
    MonoOptions, StereoOptions, StereoView, View, calibrate_mono, calibrate_stereo,
};
use stereocal_vision::camera::DistortionModel;

#[derive(Deserialize)]
struct Fixture {
    image_size: [u32; 2],
    object_points: Vec<[f64; 3]>,
    pairs: Vec<Pair>,
}

#[derive(Deserialize)]
struct Pair {
    left: Vec<[f64; 2]>,
    right: Vec<[f64; 2]>,
}

fn stereo_views() -> (Fixture, Vec<StereoView>) {
    let fixture: Fixture = serde_json::from_str(include_str!(
        "../tests/fixtures/opencv_calib_reference.json"
    ))
    .expect("the fixture is valid JSON");
    let points: Vec<Point3<f64>> = fixture
        .object_points
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
    let pixels = |c: &[[f64; 2]]| c.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let views = fixture
        .pairs
        .iter()
        .map(|pair| StereoView {
            points_in_target: points.clone(),
            left: pixels(&pair.left),
            right: pixels(&pair.right),
        })
        .collect();
    (fixture, views)
}

fn calib(c: &mut Criterion) {
    let (fixture, pairs) = stereo_views();
    let [width, height] = fixture.image_size;
    let left: Vec<View> = pairs
        .iter()
        .map(|p| View {
            points_in_target: p.points_in_target.clone(),
            pixels: p.left.clone(),
        })
        .collect();
    let right: Vec<View> = pairs
        .iter()
        .map(|p| View {
            points_in_target: p.points_in_target.clone(),
            pixels: p.right.clone(),
        })
        .collect();
    // OpenCV's calibrateCamera defaults: plumb_bob, every view kept.
    let opencv_like = MonoOptions {
        rejection: None,
        ..MonoOptions::new(DistortionModel::PlumbBob)
    };
    c.bench_function("mono_left_13_views", |b| {
        b.iter(|| calibrate_mono(black_box(&left), width, height, &opencv_like))
    });
    let with_rejection = MonoOptions::new(DistortionModel::PlumbBob);
    c.bench_function("mono_left_13_views_with_rejection", |b| {
        b.iter(|| calibrate_mono(black_box(&left), width, height, &with_rejection))
    });
    let left_camera = calibrate_mono(&left, width, height, &opencv_like)
        .expect("the left views calibrate")
        .camera;
    let right_camera = calibrate_mono(&right, width, height, &opencv_like)
        .expect("the right views calibrate")
        .camera;
    let fixed = StereoOptions {
        rejection: None,
        ..StereoOptions::default()
    };
    c.bench_function("stereo_fixed_intrinsics_13_pairs", |b| {
        b.iter(|| calibrate_stereo(&left_camera, &right_camera, black_box(&pairs), &fixed))
    });
}

criterion_group!(benches, calib);
criterion_main!(benches);
