//! `handeye_node`: the hand-eye node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    stereocal::cli::node::executable_main("handeye_node", stereocal::handeye::node::run)
}
