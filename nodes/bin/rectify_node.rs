//! `rectify_node`: the rectify node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    stereocal::cli::node::executable_main("rectify_node", stereocal::rectify::node::run)
}
