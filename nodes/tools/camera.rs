//! The synthetic camera the measuring tools publish: a calibrated camera_info of any
//! size and checkerboard images, stamped with the wall clock.

use std::time::{SystemTime, UNIX_EPOCH};

use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs::Header;

use super::ImageSize;

/// The camera's optical frame.
pub const FRAME_ID: &str = "camera_optical";

/// A camera_info such as a calibrated camera of this size publishes: focal length
/// about a 70 degree field of view, principal point off centre, barrel distortion
/// with tangential terms, and the small rotation of a rectified stereo left camera.
pub fn camera_info(size: ImageSize, stamp: Time) -> CameraInfo {
    let (w, h) = (f64::from(size.width), f64::from(size.height));
    let f = 0.71 * w;
    let (cx, cy) = ((w - 1.0) / 2.0 + 0.004 * w, (h - 1.0) / 2.0 - 0.005 * h);
    let (sy, cy_) = 0.012_f64.sin_cos();
    let (sx, cx_) = (-0.004_f64).sin_cos();
    // Rotation about y, then about x.
    let r = [
        cy_,
        0.0,
        sy,
        sx * sy,
        cx_,
        -sx * cy_,
        -cx_ * sy,
        sx,
        cx_ * cy_,
    ];
    let fp = 0.93 * f;
    CameraInfo {
        header: Header {
            stamp,
            frame_id: FRAME_ID.into(),
        },
        width: size.width,
        height: size.height,
        distortion_model: "plumb_bob".into(),
        d: vec![-0.291, 0.094, 0.0011, -0.0007, -0.0135],
        k: [f, 0.0, cx, 0.0, 1.002 * f, cy, 0.0, 0.0, 1.0],
        r,
        p: [
            fp,
            0.0,
            (w - 1.0) / 2.0,
            0.0,
            0.0,
            fp,
            (h - 1.0) / 2.0,
            0.0,
            0.0,
            0.0,
            1.0,
            0.0,
        ],
        ..CameraInfo::default()
    }
}

/// Pixels of camera image `pattern`: a checkerboard with gradients, different per
/// pattern and channel.
pub fn pixels(size: ImageSize, pattern: usize) -> Vec<u8> {
    let channels = size.channels as usize;
    let step = size.width as usize * channels;
    let shift = pattern * 17;
    (0..size.height as usize)
        .flat_map(|y| {
            (0..step).map(move |i| {
                let (x, c) = (i / channels, i % channels);
                let checker = (((x + shift) / 40 + y / 40) % 2) * 150;
                (checker + (x * 3 + y * 5 + c * 40 + shift) % 100) as u8
            })
        })
        .collect()
}

/// An image of `size` stamped `stamp` with pixels `data`.
pub fn image(size: ImageSize, stamp: Time, data: Vec<u8>) -> Image {
    Image {
        header: Header {
            stamp,
            frame_id: FRAME_ID.into(),
        },
        height: size.height,
        width: size.width,
        encoding: size.encoding().into(),
        is_bigendian: 0,
        step: size.width * size.channels,
        data,
    }
}

/// The wall clock now, as a stamp.
pub fn now() -> Time {
    let since = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    Time::from_nanos(i64::try_from(since.as_nanos()).unwrap_or(i64::MAX))
}
