//! Tests of stereocal-msgs, one binary with a module per concern: camera_info files,
//! CDR bytes and schemas against stored fixtures, and the bytes ros2-client puts on
//! the wire.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod camera_info_file;
mod cdr_fixtures;
mod ros2_client_path;
mod schemas;
