//! The stereocal node runtime: ROS 2 glue (parameters, remapping, QoS, TF), rosbag2
//! bag source and sink, conversions between messages and vision types, and the
//! pipeline stages that nodes and the offline CLI share.

pub mod bag;
pub mod calibrate_node;
pub mod calibration_advice;
pub mod calibration_report;
pub mod calibration_session;
pub mod calibration_stage;
pub mod cli;
pub mod convert;
pub mod measure;
pub mod rectify_node;
pub mod rectify_stage;
pub mod replay;
pub mod row_alignment;
pub mod runtime;
pub mod stereo_scene;
