//! `pose_node`: the pose node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    stereocal::cli::node::executable_main("pose_node", stereocal::pose::node::run)
}
