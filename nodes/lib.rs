//! stereocal's nodes, offline commands and the pipeline stages they share, one module
//! per capability: [`rectify`] and [`calibrate`] (each with its node, stage and what
//! serves them), [`pose`] and [`handeye`], [`camera`] (the V4L2 camera driver), [`convert`] between ROS messages and vision
//! types, [`tf_buffer`] for transforms at a stamp, [`composition`] running several
//! nodes in one process, [`cli`] with one module per `stereocal` command, and [`tools`]
//! shared by the measuring binaries.
//!
//! The node runtime is the `stereocal-runtime` crate, bags the `stereocal-rosbag` crate,
//! geometry and images the `stereocal-vision` crate.

pub mod calibrate;
pub mod camera;
pub mod cli;
pub mod composition;
pub mod convert;
pub mod depth;
pub mod draw;
pub mod handeye;
pub mod image_transport;
pub mod pose;
pub mod rectify;
pub mod target_params;
pub mod tf_buffer;
pub mod tools;
