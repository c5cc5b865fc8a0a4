//! `point_cloud_node`: the point cloud node as its own executable, for `ros2 launch`.

use std::process::ExitCode;

fn main() -> ExitCode {
    stereocal::cli::node::executable_main(
        "point_cloud_node",
        stereocal::depth::point_cloud_node::run,
    )
}
