//! Maps and remap against OpenCV 4.x's own output, stored in `tests/fixtures/remap/` by
//! `interop/check_remap_opencv.py --fixture vision/tests/fixtures/remap`: for a
//! plumb_bob, a rational_polynomial and an equidistant camera_info (160x120, with a
//! rectification R and a new projection P), OpenCV's `initUndistortRectifyMap`
//! (CV_16SC2) + `remap` with a constant border. 8-bit results are bit-exact.

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Matrix3x4};
use serde_json::Value;
use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::rectify::{Interpolation, RectifyMap, RemapOptions, remap};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/remap")
}

/// The fixture's test image: the formula of `texture(..., noise=False)` in the script.
fn texture(width: usize, height: usize, channels: usize) -> Image {
    let mut samples = Vec::with_capacity(width * height * channels);
    for y in 0..height {
        for x in 0..width {
            for c in 0..channels {
                let checker = ((x / 8 + y / 8 + c) % 2) * 96;
                samples.push(((checker + x + y) % 256) as u8);
            }
        }
    }
    Image::new(width, height, channels, Samples::U8(samples)).unwrap()
}

fn numbers(params: &Value, key: &str) -> Vec<f64> {
    params[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

fn map_of(model: &str) -> RectifyMap {
    let text = std::fs::read_to_string(fixtures().join(format!("{model}.json"))).unwrap();
    let params: Value = serde_json::from_str(&text).unwrap();
    let width = params["width"].as_u64().unwrap() as usize;
    let height = params["height"].as_u64().unwrap() as usize;
    let distortion_model = DistortionModel::from_ros_name(model).unwrap();
    let camera = CameraModel {
        width: width as u32,
        height: height as u32,
        intrinsics: Intrinsics::from_matrix(&Matrix3::from_row_slice(&numbers(&params, "K"))),
        distortion: Distortion::from_coeffs(distortion_model, &numbers(&params, "D")).unwrap(),
    };
    let r = Matrix3::from_row_slice(&numbers(&params, "R"));
    let p = Matrix3x4::from_row_slice(&numbers(&params, "P"));
    RectifyMap::new(&camera, &r, &p, width, height).unwrap()
}

fn opencv_output(name: &str) -> Vec<u8> {
    image::open(fixtures().join(name)).unwrap().into_bytes()
}

fn samples(image: Image) -> Vec<u8> {
    match image.samples {
        Samples::U8(v) => v,
        Samples::U16(_) => panic!("expected 8-bit output"),
    }
}

#[test]
fn mono8_matches_opencv_for_every_model_and_interpolation() {
    let src = texture(160, 120, 1);
    for model in ["plumb_bob", "rational_polynomial", "equidistant"] {
        let map = map_of(model);
        for (name, interpolation) in [
            ("nearest", Interpolation::Nearest),
            ("bilinear", Interpolation::Bilinear),
            ("bicubic", Interpolation::Bicubic),
        ] {
            let options = RemapOptions {
                interpolation,
                ..RemapOptions::default()
            };
            let ours = samples(remap(&src, &map, options).unwrap());
            let theirs = opencv_output(&format!("{model}_{name}_mono8.png"));
            assert_eq!(ours.len(), theirs.len());
            let differing = ours.iter().zip(&theirs).filter(|(a, b)| a != b).count();
            assert_eq!(
                differing, 0,
                "{model} {name}: {differing} pixels differ from OpenCV"
            );
        }
    }
}

#[test]
fn rgb8_matches_opencv() {
    let ours = samples(
        remap(
            &texture(160, 120, 3),
            &map_of("plumb_bob"),
            RemapOptions::default(),
        )
        .unwrap(),
    );
    assert_eq!(ours, opencv_output("plumb_bob_bilinear_rgb8.png"));
}
