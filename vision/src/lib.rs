//! Geometry and image core of stereocal. Knows nothing of ROS: usable on its own.
//!
//! Conventions: pixel centres at integer coordinates (OpenCV and ROS); metres,
//! radians and seconds; transforms named `a_from_b` map points in frame b to frame a.

pub mod board;
pub mod calib;
pub mod camera;
pub mod channel_order;
pub mod geometry;
pub mod handeye;
pub mod image;
pub mod pnp;
pub mod rectify;
mod rotation;
pub mod stereo;
pub mod synth;
