//! The `stereocal` command line: offline processing of bags, synthetic scenes and the demo.

use clap::{Parser, Subcommand};
use stereocal::cli::rectify::RectifyArgs;

/// Stereo camera calibration, rectification and pose, offline on rosbag2 bags.
#[derive(Parser)]
#[command(name = "stereocal", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Calibrate a camera or a stereo pair from a bag of chessboard images, and write
    /// camera_info YAML files (and stereo.yaml for a pair).
    Calibrate(stereocal::cli::calibrate::CalibrateArgs),
    /// The main job on the bundled stereo bag: rectify it offline and through two
    /// rectify nodes over DDS, and measure row alignment against ground truth.
    Demo(stereocal::cli::demo::DemoArgs),
    /// Rectify every image topic of a bag that has a camera_info into <ns>/image_rect.
    Rectify(RectifyArgs),
    /// Render a synthetic scene with exact ground truth into a rosbag2 bag.
    Synth(stereocal::cli::synth::SynthCommand),
    /// Run a node in this process, exactly as its own executable would be run by
    /// `ros2 launch` (e.g. `stereocal node rectify --ros-args -r __ns:=/left`).
    Node {
        #[command(subcommand)]
        node: NodeCommand,
    },
}

#[derive(Subcommand)]
enum NodeCommand {
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
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Calibrate(args) => stereocal::cli::calibrate::run(&args),
        Command::Demo(args) => stereocal::cli::demo::run(&args),
        Command::Rectify(args) => stereocal::cli::rectify::run(&args),
        Command::Synth(args) => stereocal::cli::synth::run_command(&args),
        Command::Node {
            node: NodeCommand::Rectify { args },
        } => stereocal::rectify_node::run(args),
        Command::Node {
            node: NodeCommand::Calibrate { args },
        } => stereocal::calibrate_node::run(args),
    }
}
