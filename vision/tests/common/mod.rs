//! Helpers shared by the integration tests of stereocal-vision; each test binary
//! uses the part it needs.
#![allow(dead_code)]

pub mod opencv_fixture;
pub mod render;
