//! ROS 2 message types of stereocal, their CDR encoding and `ros2msg` schemas, and
//! camera_info files.
//!
//! Modules are named for ROS packages (`sensor_msgs::Image`, `std_msgs::Header`, ...);
//! every struct has the exact field order and types of its ROS 2 definition, so
//! [`cdr::to_bytes`] (or any CDR serde serializer) gives the bytes ROS 2 puts on the
//! wire, and each implements [`RosMessage`] for its type name and schema.
//! [`CameraInfoFile`] reads and writes the camera_info files of ROS's
//! `camera_calibration_parsers`.

pub mod atomic_file;
pub mod builtin_interfaces;
pub mod camera_info_file;
pub mod cdr;
pub mod geometry_msgs;
pub mod rcl_interfaces;
pub mod ros_message;
pub mod rosgraph_msgs;
pub mod sensor_msgs;
pub mod std_msgs;
pub mod std_srvs;
pub mod stereo_msgs;
pub mod stereocal_msgs;
pub mod tf2_msgs;

pub use camera_info_file::{CameraInfoFile, CameraInfoFileError};
pub use ros_message::RosMessage;
