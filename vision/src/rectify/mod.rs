//! Stereo rectification (Bouguet, and Hartley's uncalibrated method), undistort/rectify
//! maps and remap.

mod map;
mod remap;
mod stereo;
mod uncalibrated;

pub use map::{INTER_BITS, INTER_TAB_SIZE, MapError, RectifyMap};
pub use remap::{
    Interpolation, Parallelism, RemapError, RemapOptions, remap, remap_into, remap_u8_into,
};
pub use stereo::{
    StereoLayout, StereoRectification, StereoRectifyError, StereoRectifyOptions,
    fisheye_stereo_rectify, stereo_rectify,
};
pub use uncalibrated::{
    MIN_UNCALIBRATED_POINTS, UncalibratedRectification, UncalibratedRectifyError,
    rectify_uncalibrated,
};
