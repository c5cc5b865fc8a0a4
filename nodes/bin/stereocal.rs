//! The `stereocal` command line: offline processing of bags, synthetic scenes and the demo.

use clap::{Parser, Subcommand};

/// Stereo camera calibration, rectification and pose, offline on rosbag2 bags.
#[derive(Parser)]
#[command(name = "stereocal", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {}
}
