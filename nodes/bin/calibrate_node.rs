//! `calibrate_node`: the calibrate node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    match stereocal::calibrate::node::run(std::env::args().skip(1)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("calibrate_node: {e:#}");
            ExitCode::FAILURE
        }
    }
}
