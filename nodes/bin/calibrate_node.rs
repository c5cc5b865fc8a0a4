//! `calibrate_node`: the calibrate node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    stereocal::cli::node::executable_main("calibrate_node", stereocal::calibrate::node::run)
}
