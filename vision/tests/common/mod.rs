//! Helpers shared by the integration tests of stereocal-vision.

pub mod opencv_fixture;
