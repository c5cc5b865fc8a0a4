//! The `stereocal` command line: offline processing of bags, synthetic scenes, the demo,
//! and the nodes run in this process.

use clap::{Parser, Subcommand};
use stereocal::cli;

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
    Calibrate(cli::calibrate::CalibrateArgs),
    /// Hand-eye calibration of a recorded session: target poses paired with robot poses
    /// by stamp, every method, the best chosen; writes DIR/handeye.yaml.
    Handeye(cli::handeye::HandEyeArgs),
    /// The disparity of every rectified stereo pair of a bag, written as
    /// <ns>/disparity and <ns>/points2.
    Depth(cli::depth::DepthArgs),
    /// The main job on the bundled stereo bag: rectify it offline and through two
    /// rectify nodes over DDS, and measure row alignment against ground truth.
    Demo(cli::demo::DemoArgs),
    /// Publish a bag's messages over ROS 2 at their recorded pace, optionally with
    /// /clock, like `ros2 bag play`.
    Play(cli::play::PlayArgs),
    /// Estimate a calibration target's pose in every image of a bag, and write it as
    /// <ns>/target_pose and /tf.
    Pose(cli::pose::PoseArgs),
    /// Rectify every image topic of a bag that has a camera_info into <ns>/image_rect.
    Rectify(cli::rectify::RectifyArgs),
    /// Render a synthetic scene with exact ground truth into a rosbag2 bag.
    Synth(cli::synth::SynthCommand),
    /// Run a node in this process, exactly as its own executable would be run by
    /// `ros2 launch` (e.g. `stereocal node rectify --ros-args -r __ns:=/left`).
    Node {
        #[command(subcommand)]
        node: cli::node::NodeCommand,
    },
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Calibrate(args) => cli::calibrate::run(&args),
        Command::Demo(args) => cli::demo::run(&args),
        Command::Depth(args) => cli::depth::run(&args),
        Command::Play(args) => cli::play::run(&args),
        Command::Pose(args) => cli::pose::run(&args),
        Command::Handeye(args) => cli::handeye::run(&args),
        Command::Rectify(args) => cli::rectify::run(&args),
        Command::Synth(args) => cli::synth::run_command(&args),
        Command::Node { node } => cli::node::run(node),
    }
}
