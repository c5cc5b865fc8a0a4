//! camera_node: its capture stage driven directly with a scripted device, and the node
//! on its test pattern over DDS (topics, stamps, `set_camera_info`, a missing device,
//! and the calibration loop from calibrate_node's `~/commit`).

mod calibration_loop;
mod node;
mod stage;
