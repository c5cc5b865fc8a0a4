//! Tests of stereocal-vision, one binary with a module per concern: camera models
//! against OpenCV and finite differences, target detection on real and synthetic
//! images, calibration against OpenCV and ground truth, two-view geometry against
//! ground truth, rectification (calibrated and uncalibrated), remap fixtures, and the
//! synthetic scenes' own truth.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod board_opencv_stereo;
mod board_synthetic;
mod calib_opencv;
mod calib_rational;
mod calib_synthetic;
mod camera_jacobians;
mod camera_opencv;
mod camera_undistort;
mod charuco;
mod circles;
mod common;
mod geometry_synthetic;
mod pnp_opencv_failures;
mod rectify_uncalibrated;
mod remap_opencv_fixture;
mod stereo_rectify_geometry;
mod stereo_rectify_opencv;
mod stereo_synthetic;
mod synth_scenes;
mod synth_truth;
