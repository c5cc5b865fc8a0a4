//! Stereo rectification (Bouguet), undistort/rectify maps and remap.

mod map;
mod remap;
mod stereo;

pub use map::{INTER_BITS, INTER_TAB_SIZE, MapError, RectifyMap};
pub use remap::{Interpolation, Parallelism, RemapError, RemapOptions, remap, remap_into};
pub use stereo::{
    StereoLayout, StereoRectification, StereoRectifyError, StereoRectifyOptions,
    fisheye_stereo_rectify, stereo_rectify,
};
