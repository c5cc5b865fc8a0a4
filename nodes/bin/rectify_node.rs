//! `rectify_node`: the rectify node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    match stereocal::rectify::node::run(std::env::args().skip(1)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("rectify_node: {e:#}");
            ExitCode::FAILURE
        }
    }
}
