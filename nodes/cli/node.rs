//! `stereocal node NAME [--ros-args ...]`: runs one of the nodes in this process,
//! exactly as its own executable would be run by `ros2 launch`, or several of them
//! (`stereocal node compose FILE`); and the `main` of the node executables.

use std::path::PathBuf;
use std::process::ExitCode;

/// The nodes `stereocal node` runs.
#[derive(clap::Subcommand, Debug)]
pub enum NodeCommand {
    /// The rectify node: `image` + `camera_info` in, `image_rect` out.
    Rectify {
        /// ROS arguments, as for the `rectify_node` executable.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// The calibrate node: collects samples from `image` (or `left/image` and
    /// `right/image`), calibrates and commits on `~/calibrate` and `~/commit`.
    Calibrate {
        /// ROS arguments, as for the `calibrate_node` executable.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// The pose node: `image` + `camera_info` in, the target's pose (`target_pose`,
    /// `target_pose_with_covariance`, `/tf`) out.
    Pose {
        /// ROS arguments, as for the `pose_node` executable.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// The hand-eye node: target poses (`image` + `camera_info`, or `target_pose`) and
    /// robot poses (`/tf`, or `robot_pose`) in, samples on `~/take_sample`, the result
    /// on `~/compute` to `/tf_static`.
    Handeye {
        /// ROS arguments, as for the `handeye_node` executable.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// The disparity node: `left/image_rect` + `right/image_rect` and their camera_infos
    /// in, `disparity` out, as stereo_image_proc's DisparityNode.
    Disparity {
        /// ROS arguments, as for the `disparity_node` executable.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// The point cloud node: `left/image_rect_color`, `disparity` and the camera_infos
    /// in, `points2` out, as stereo_image_proc's PointCloudNode.
    #[command(name = "point_cloud")]
    PointCloud {
        /// ROS arguments, as for the `point_cloud_node` executable.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// The camera node: a V4L2 camera (or its test pattern) to `image_raw`,
    /// `image_raw/compressed` and `camera_info`, with `set_camera_info`.
    Camera {
        /// ROS arguments, as for the `camera_node` executable.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// Several nodes in this process, as a composition file lists them, like a
    /// component container.
    Compose {
        /// The composition file (YAML: `nodes: [{node: rectify, args: [...]}, ...]`).
        file: PathBuf,
        /// ROS arguments for every node (`--ros-args --params-file P ...`).
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
}

/// Runs the node until SIGINT/SIGTERM, with the parallel pool sized for nodes.
pub fn run(command: NodeCommand) -> anyhow::Result<()> {
    size_parallel_pool();
    match command {
        NodeCommand::Rectify { args } => crate::rectify::node::run(args),
        NodeCommand::Calibrate { args } => crate::calibrate::node::run(args),
        NodeCommand::Pose { args } => crate::pose::node::run(args),
        NodeCommand::Handeye { args } => crate::handeye::node::run(args),
        NodeCommand::Disparity { args } => crate::depth::node::run(args),
        NodeCommand::PointCloud { args } => crate::depth::point_cloud_node::run(args),
        NodeCommand::Camera { args } => crate::camera::node::run(args),
        NodeCommand::Compose { file, args } => crate::composition::run(&file, &args),
    }
}

/// Sizes the process's pool for parallel work (remap rows, stereo sweeps, detection)
/// for nodes: one thread more than the machine has cores, unless `RAYON_NUM_THREADS`
/// says otherwise. A node's parallel work shares the cores with the threads that
/// receive, queue and send its messages; with exactly one pool thread per core, a
/// parallel loop seems to wait whenever those threads interrupt one of its threads.
/// Measured: the composed rectify pair at 1920x1080 rgb8 on two cores took p90
/// 10.2-10.9 ms with two pool threads, 5.8-7.1 ms with three, four or six. Does nothing
/// once the pool exists.
pub fn size_parallel_pool() {
    if std::env::var_os("RAYON_NUM_THREADS").is_some() {
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    // The pool already exists when something ran in parallel before: keep it.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(cores + 1)
        .build_global();
}

/// The `main` of node executable `name`: sizes the parallel pool for nodes, runs
/// `node` with the process's command line (without the program name) and exits 0, or
/// prints why it stopped and exits 1.
pub fn executable_main(
    name: &str,
    node: impl FnOnce(std::iter::Skip<std::env::Args>) -> anyhow::Result<()>,
) -> ExitCode {
    size_parallel_pool();
    match node(std::env::args().skip(1)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{name}: {e:#}");
            ExitCode::FAILURE
        }
    }
}
