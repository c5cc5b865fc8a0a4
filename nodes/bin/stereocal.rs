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
    /// Rectify every image topic of a bag that has a camera_info into <ns>/image_rect.
    Rectify(RectifyArgs),
    /// Render a synthetic scene with exact ground truth into a rosbag2 bag.
    Synth(stereocal::cli::synth::SynthArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Rectify(args) => stereocal::cli::rectify::run(&args),
        Command::Synth(args) => stereocal::cli::synth::run(&args),
    }
}
