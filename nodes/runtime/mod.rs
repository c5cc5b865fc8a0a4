//! The node runtime: what `ros2 run` and `ros2 launch` expect from an executable.
//!
//! [`args`] parses `--ros-args` (remaps, parameters, params files, log levels), [`names`]
//! resolves node and topic names like rcl, [`params`] gives declared parameters their
//! start-up values (from [`params_file`]s and `-p` values typed by [`param_value`]),
//! [`qos`] holds the QoS profiles of DESIGN.md, [`sync`] pairs images with camera_info by
//! stamp (and a stereo pair's images with each other), [`service`] serves and calls ROS 2
//! services, [`queue`] is the bounded drop-oldest queue between receiving and processing,
//! [`sequence_gaps`] counts frames lost before reception, [`logging`] writes to stderr
//! and `/rosout`, [`shutdown`] turns SIGINT/SIGTERM into a clean stop, and [`node`] puts
//! it together into a running ROS 2 node on `ROS_DOMAIN_ID` with its parameter services.

pub mod args;
pub mod error;
pub mod logging;
pub mod names;
pub mod node;
pub mod param_value;
pub mod params;
pub mod params_file;
pub mod qos;
pub mod queue;
pub mod sequence_gaps;
pub mod service;
pub mod shutdown;
pub mod sync;
pub mod throttle;
pub mod transport;

pub use error::{Result, RuntimeError};
