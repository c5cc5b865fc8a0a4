//! The rectify pipeline stage: maps built once per camera_info, the uncalibrated
//! warning given once, sizes checked, encodings and headers kept, pixels equal to
//! vision's remap.

use nalgebra::{Matrix3x4, Rotation3};
use stereocal::convert::{
    CalibratedCamera, Encoding, image_from_msg, info_from_calibrated, info_from_raw_camera,
};
use stereocal::rectify::stage::{Rectified, Rectifier, RectifyError};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_msgs::std_msgs::Header;
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::rectify::{Interpolation, Parallelism, RectifyMap, RemapOptions, remap};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;

fn header(sec: i32) -> Header {
    Header {
        stamp: Time { sec, nanosec: 500 },
        frame_id: "left_camera_optical".to_owned(),
    }
}

fn distorted_camera() -> CameraModel {
    CameraModel {
        width: WIDTH,
        height: HEIGHT,
        intrinsics: Intrinsics {
            fx: 60.0,
            fy: 61.0,
            cx: 31.5,
            cy: 23.5,
        },
        distortion: Distortion::PlumbBob {
            coeffs: [-0.25, 0.07, 0.001, -0.002, 0.0],
        },
    }
}

/// A stereo-rectified camera_info: distortion, a small rotation and a new projection.
fn stereo_info(sec: i32) -> CameraInfo {
    let camera = CalibratedCamera {
        model: distorted_camera(),
        rectified_from_camera: *Rotation3::from_euler_angles(0.01, -0.02, 0.015).matrix(),
        projection: Matrix3x4::new(
            55.0, 0.0, 30.0, -5.5, 0.0, 55.0, 24.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        ),
    };
    info_from_calibrated(&camera, header(sec))
}

/// A checker-and-gradient pattern so that every interpolation gives different pixels.
fn pattern(encoding: Encoding, sec: i32) -> ImageMsg {
    let bpp = encoding.bytes_per_pixel() as u32;
    let step = WIDTH * bpp + 3;
    let mut data = vec![0u8; (step * HEIGHT) as usize];
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let check = if (x / 8 + y / 8).is_multiple_of(2) {
                200
            } else {
                30
            };
            for b in 0..bpp {
                let value = (check + x + 2 * y + 17 * b) % 256;
                data[(y * step + x * bpp + b) as usize] = value as u8;
            }
        }
    }
    ImageMsg {
        header: header(sec),
        height: HEIGHT,
        width: WIDTH,
        encoding: encoding.ros_name().to_owned(),
        is_bigendian: 0,
        step,
        data,
    }
}

fn rectified(outcome: Result<Rectified, RectifyError>) -> ImageMsg {
    match outcome {
        Ok(Rectified::Image(image)) => image,
        other => panic!("expected a rectified image, got {other:?}"),
    }
}

#[test]
fn maps_are_built_only_when_the_calibration_changes() {
    let mut rectifier = Rectifier::new(RemapOptions::default());
    let first = rectified(rectifier.rectify(&pattern(Encoding::Mono8, 1), &stereo_info(1)));
    for sec in 2..6 {
        // Only the header differs: same map, same pixels.
        let again = rectified(rectifier.rectify(&pattern(Encoding::Mono8, sec), &stereo_info(sec)));
        assert_eq!(again.data, first.data);
        assert_eq!(again.header.stamp.sec, sec);
    }
    assert_eq!(rectifier.map_builds(), 1);

    let mut changed = stereo_info(6);
    changed.d[0] = -0.2;
    let other = rectified(rectifier.rectify(&pattern(Encoding::Mono8, 6), &changed));
    assert_ne!(other.data, first.data);
    rectifier
        .rectify(&pattern(Encoding::Mono8, 7), &changed)
        .unwrap();
    assert_eq!(rectifier.map_builds(), 2);

    let mut moved = changed.clone();
    moved.p[2] += 1.0;
    rectifier
        .rectify(&pattern(Encoding::Mono8, 8), &moved)
        .unwrap();
    assert_eq!(rectifier.map_builds(), 3);

    // An encoding change reuses the map: the map depends on camera_info only.
    rectifier
        .rectify(&pattern(Encoding::Rgb8, 9), &moved)
        .unwrap();
    assert_eq!(rectifier.map_builds(), 3);
}

#[test]
fn uncalibrated_camera_info_publishes_nothing_and_warns_once() {
    let mut rectifier = Rectifier::new(RemapOptions::default());
    let mut uncalibrated = stereo_info(1);
    uncalibrated.k = [0.0; 9];
    let mut warnings = Vec::new();
    for sec in 0..5 {
        match rectifier.rectify(&pattern(Encoding::Mono8, sec), &uncalibrated) {
            Ok(Rectified::Uncalibrated { warning }) => warnings.extend(warning),
            other => panic!("expected nothing to publish, got {other:?}"),
        }
    }
    assert_eq!(warnings.len(), 1);
    assert!(warnings[0].contains("uncalibrated"), "{}", warnings[0]);
    assert_eq!(rectifier.map_builds(), 0);

    // Calibration arrives, then goes away again: one more warning.
    rectified(rectifier.rectify(&pattern(Encoding::Mono8, 5), &stereo_info(5)));
    let again = rectifier.rectify(&pattern(Encoding::Mono8, 6), &uncalibrated);
    assert!(matches!(
        again,
        Ok(Rectified::Uncalibrated { warning: Some(_) })
    ));
}

#[test]
fn output_keeps_encoding_and_header_and_equals_vision_remap() {
    let info = stereo_info(3);
    let camera = stereocal::convert::calibrated_camera_from_info(&info).unwrap();
    let map = RectifyMap::new(
        &camera.model,
        &camera.rectified_from_camera,
        &camera.projection,
        WIDTH as usize,
        HEIGHT as usize,
    )
    .unwrap();
    for interpolation in [
        Interpolation::Nearest,
        Interpolation::Bilinear,
        Interpolation::Bicubic,
    ] {
        let options = RemapOptions {
            interpolation,
            parallelism: Parallelism::Single,
        };
        let mut rectifier = Rectifier::new(options);
        for encoding in Encoding::ALL {
            let input = pattern(encoding, 3);
            let output = rectified(rectifier.rectify(&input, &info));
            assert_eq!(output.header, input.header);
            assert_eq!(output.encoding, encoding.ros_name());
            assert_eq!((output.width, output.height), (WIDTH, HEIGHT));
            assert_eq!(output.step, WIDTH * encoding.bytes_per_pixel() as u32);

            let (_, source) = image_from_msg(&input).unwrap();
            let expected = remap(&source, &map, options).unwrap();
            let (_, got) = image_from_msg(&output).unwrap();
            assert_eq!(got, expected, "{interpolation:?} {encoding:?}");
        }
    }
}

#[test]
fn interpolation_changes_the_pixels() {
    let info = stereo_info(1);
    let input = pattern(Encoding::Mono8, 1);
    let outputs: Vec<_> = [
        Interpolation::Nearest,
        Interpolation::Bilinear,
        Interpolation::Bicubic,
    ]
    .into_iter()
    .map(|interpolation| {
        let mut rectifier = Rectifier::new(RemapOptions {
            interpolation,
            ..RemapOptions::default()
        });
        rectified(rectifier.rectify(&input, &info)).data
    })
    .collect();
    assert_ne!(outputs[0], outputs[1]);
    assert_ne!(outputs[1], outputs[2]);
}

#[test]
fn a_raw_camera_without_distortion_gives_back_its_image() {
    let camera = CameraModel {
        distortion: Distortion::none(),
        ..distorted_camera()
    };
    let info = info_from_raw_camera(&camera, header(0));
    let mut rectifier = Rectifier::new(RemapOptions::default());
    let input = pattern(Encoding::Bgr8, 0);
    let output = rectified(rectifier.rectify(&input, &info));
    assert_eq!(
        image_from_msg(&output).unwrap(),
        image_from_msg(&input).unwrap()
    );
}

#[test]
fn size_disagreeing_with_camera_info_names_both_sizes() {
    let mut rectifier = Rectifier::new(RemapOptions::default());
    let mut info = stereo_info(0);
    info.width = 80;
    let err = rectifier
        .rectify(&pattern(Encoding::Mono8, 0), &info)
        .unwrap_err();
    assert_eq!(
        err,
        RectifyError::SizeMismatch {
            image_width: 64,
            image_height: 48,
            info_width: 80,
            info_height: 48,
        }
    );
    let message = err.to_string();
    assert!(
        message.contains("64x48") && message.contains("80x48"),
        "{message}"
    );
}

#[test]
fn bad_frames_are_errors_and_the_next_good_frame_still_rectifies() {
    let mut rectifier = Rectifier::new(RemapOptions::default());
    let info = stereo_info(0);
    let good = rectified(rectifier.rectify(&pattern(Encoding::Mono8, 0), &info));

    let mut truncated = pattern(Encoding::Mono8, 1);
    truncated.data.truncate(100);
    assert!(matches!(
        rectifier.rectify(&truncated, &info),
        Err(RectifyError::Image(_))
    ));
    let mut bayer = pattern(Encoding::Mono8, 1);
    bayer.encoding = "bayer_rggb8".to_owned();
    assert!(matches!(
        rectifier.rectify(&bayer, &info),
        Err(RectifyError::Image(_))
    ));
    let mut nan_info = info.clone();
    nan_info.r[4] = f64::NAN;
    assert!(matches!(
        rectifier.rectify(&pattern(Encoding::Mono8, 1), &nan_info),
        Err(RectifyError::CameraInfo(_))
    ));
    let mut unknown_model = info.clone();
    unknown_model.distortion_model = "fov".to_owned();
    let message = rectifier
        .rectify(&pattern(Encoding::Mono8, 1), &unknown_model)
        .unwrap_err()
        .to_string();
    assert!(message.contains("\"fov\""), "{message}");

    let after = rectified(rectifier.rectify(&pattern(Encoding::Mono8, 0), &info));
    assert_eq!(after.data, good.data);
}
