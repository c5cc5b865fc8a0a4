//! `disparity_node`: the disparity node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    stereocal::cli::node::executable_main("disparity_node", stereocal::depth::node::run)
}
