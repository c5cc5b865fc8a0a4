//! The ROS 2 node runtime: what `ros2 run` and `ros2 launch` expect from an executable,
//! and the one skeleton every stereocal node is built on. It knows ROS messages
//! (`stereocal-msgs`) and nothing of images or geometry.
//!
//! [`args`] parses `--ros-args` (remaps, parameters, params files, log levels), [`names`]
//! resolves node and topic names like rcl, [`params`] gives declared parameters their
//! start-up values (from [`params_file`]s and `-p` values typed by [`param_value`]),
//! [`param_store`] holds them while the node runs and [`param_services`] serves them
//! (the six parameter services with full descriptors, and `/parameter_events`),
//! [`clock`] is the node's clock (system, or `/clock` with `use_sim_time`), [`qos`]
//! holds the QoS profiles of DESIGN.md, [`stamp`] the one stamp type, [`sync`]
//! synchronizes a node's inputs by stamp (streams with each other, camera_info with
//! them), [`raw`] carries a message of any type as its CDR bytes, [`service`] serves
//! and calls ROS 2 services, [`queue`] is the bounded
//! drop-oldest queue between receiving and processing, [`sequence_gaps`] counts frames
//! lost before reception, [`logging`] writes to stderr and `/rosout`, [`throttle`] keeps
//! repeated warnings rare, [`shutdown`] turns SIGINT/SIGTERM into a clean stop,
//! [`publisher`] publishes to the nodes of this process by reference and over DDS to
//! the others, [`transport`] sets up the DDS participant, [`camera_info_url`] resolves
//! camera_info_manager's URLs, and [`node`] puts it together into a running ROS 2 node
//! on `ROS_DOMAIN_ID` with its parameter services. [`skeleton`] runs a node:
//! subscribe, synchronize, queue, work, publish, shut down.
//!
//! With the `testing` feature, [`testing`] runs nodes as processes of their own on ROS
//! domains of their own, for tests and measuring tools.

pub mod args;
mod background;
pub mod camera_info_url;
pub mod clock;
mod dds_sender;
pub mod error;
mod frame_memory;
mod frame_work;
mod intra;
pub mod logging;
pub mod names;
pub mod node;
pub mod param_services;
pub mod param_store;
pub mod param_value;
pub mod params;
pub mod params_file;
mod priority;
pub mod publisher;
pub mod qos;
pub mod queue;
pub mod raw;
mod ready;
pub mod sequence_gaps;
pub mod service;
pub mod shutdown;
pub mod skeleton;
pub mod stamp;
pub mod sync;
#[cfg(feature = "testing")]
pub mod testing;
pub mod throttle;
pub mod transport;

pub use error::{Result, RuntimeError};
