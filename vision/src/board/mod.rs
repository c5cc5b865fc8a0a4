//! Calibration targets (chessboard, ChArUco, symmetric and asymmetric circle grids) and their detection in images.
//!
//! Targets are defined in `config/boards/*.yaml` or on a command line in ROS
//! camera_calibration's style (`--pattern chessboard --size 9x6 --square 0.025`).
//! Detectors implement [`TargetDetector`]: an image in, the target's corners out, in
//! target order, with pixel centres at integer coordinates.

mod charuco;
mod chessboard;
mod circles;
mod contained;
mod detection;
mod gray;
mod grid;
mod pattern_args;
mod subpixel;
mod target;

pub use charuco::{CharucoDetector, MIN_CHARUCO_CORNERS};
pub use chessboard::ChessboardDetector;
pub use circles::{CircleGridDetector, CircleGridMiss, circle_centre_errors};
pub use detection::{Detection, TargetDetector};
pub use gray::Gray;
pub use pattern_args::{
    PatternArgs, TargetPart, parse_pattern_args, parse_size, target_from_parts,
};
pub use subpixel::{SubpixelWindow, refine_corners};
pub use target::{
    ArucoDictionary, Charuco, Chessboard, CircleGrid, CircleLayout, DEFAULT_DIAMETER_RATIO, Target,
};

use thiserror::Error;

/// Why a target could not be defined or an image not searched.
#[derive(Debug, Error, PartialEq)]
pub enum BoardError {
    /// The target's dimensions are unusable.
    #[error("invalid target: {0}")]
    InvalidTarget(String),
    /// A target file could not be parsed.
    #[error("cannot parse target definition: {0}")]
    Parse(String),
    /// A target file could not be read.
    #[error("cannot read target file {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A command line's target options are wrong.
    #[error("{0}")]
    Args(String),
    /// The image's samples do not match its size.
    #[error(
        "image of {width}x{height}x{channels} has {samples} samples: expected a non-empty \
         image with width * height * channels samples"
    )]
    BadImage {
        /// Declared width.
        width: usize,
        /// Declared height.
        height: usize,
        /// Declared channels.
        channels: usize,
        /// Samples present.
        samples: usize,
    },
    /// The image has a channel count detection cannot use.
    #[error("images with {0} channels are not supported: expected 1 (mono), 3 (colour) or 4")]
    UnsupportedChannels(usize),
    /// The detector cannot detect this kind of target.
    #[error("{0}")]
    Unsupported(String),
}

/// The detector of `target`: a [`ChessboardDetector`], a [`CharucoDetector`] or a
/// [`CircleGridDetector`].
pub fn detector_for(target: &Target) -> Result<Box<dyn TargetDetector + Send + Sync>, BoardError> {
    Ok(match target {
        Target::Chessboard(board) => Box::new(ChessboardDetector::new(*board)?),
        Target::Charuco(board) => Box::new(CharucoDetector::new(board.clone())?),
        Target::Circles(_) | Target::Acircles(_) => Box::new(CircleGridDetector::new(target)?),
    })
}
