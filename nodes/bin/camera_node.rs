//! `camera_node`: the camera node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    stereocal::cli::node::executable_main("camera_node", stereocal::camera::node::run)
}
