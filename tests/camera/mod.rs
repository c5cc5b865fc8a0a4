//! camera_node: its capture stage driven directly with a scripted device, and the node
//! on its test pattern over DDS (topics, stamps, `set_camera_info`, a missing device,
//! simulated time, a stereo pair's stamp differences, a composition with rectify_node,
//! and the calibration loop from calibrate_node's `~/commit`).

mod calibration_loop;
mod composed;
mod node;
mod stage;
