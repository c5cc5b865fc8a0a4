//! The node runtime: what `ros2 run` and `ros2 launch` expect from an executable.
//!
//! [`args`] parses `--ros-args` (remaps, parameters, params files, log levels), [`names`]
//! resolves node and topic names like rcl, [`params`] gives declared parameters their
//! start-up values, [`qos`] holds the QoS profiles of DESIGN.md, [`queue`] the bounded
//! drop-oldest queue between receiving and processing, [`logging`] writes to stderr and
//! `/rosout`, [`shutdown`] turns SIGINT/SIGTERM into a clean stop, and [`node`] puts it
//! together into a running ROS 2 node.

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
pub mod shutdown;
pub mod sync;
pub mod transport;

pub use error::{Result, RuntimeError};
