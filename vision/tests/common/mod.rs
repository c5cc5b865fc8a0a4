//! Helpers shared by the tests of stereocal-vision.

pub mod opencv_fixture;
pub mod render;
