//! Synthetic scenes with exact ground truth: a chessboard, ChArUco or circle-grid target rendered through a
//! camera model (anti-aliased, with defocus, noise, vignetting, uneven light and a
//! cluttered background), stereo rigs and robot-arm hand-eye sessions with bad frames
//! on request, hand-eye sessions as detected corners without rendering (for noise
//! sweeps), and a saddle-point fit that measures rendered corners.
//!
//! Everything is seeded (ChaCha8 for the scene, SplitMix64 per image row for sensor
//! noise): the same spec gives the same bytes.

mod background;
mod board;
mod corner_session;
pub mod depth;
mod photometry;
mod poses;
mod rays;
mod render;
mod robot_stream;
mod saddle;
mod scene;
mod truth;

pub use background::Background;
pub use board::{CharucoMarkers, Chessboard, Circles};
pub use corner_session::{CornerSession, CornerSessionSpec, corner_session, corner_session_camera};
pub use photometry::Photometry;
pub use poses::{Coverage, PoseRanges, PoseSampler};
pub use render::{PixelFormat, Renderer, Shot};
pub use robot_stream::RobotMotion;
pub use saddle::{SaddleFit, saddle_point, saddle_point_through_lens};
pub(crate) use scene::gaussian;
pub use scene::{
    HandEye, RigLayout, RobotNoise, Scene, SceneKind, SceneSpec, StereoRig, synthetic_camera,
};
pub use truth::{
    CameraRecord, CornerRecord, ExtrinsicsRecord, FrameKind, FrameRecord, GroundTruth,
    MotionRecord, StampRecord, TransformRecord, ViewRecord, corner_truth,
};

use thiserror::Error;

/// Why a synthetic scene could not be made.
#[derive(Debug, Error, PartialEq)]
pub enum SynthError {
    /// The board's dimensions are unusable.
    #[error(
        "invalid chessboard {cols}x{rows} inner corners, square {square_size} m, margin {margin} m: \
         expected at least 2x2 corners, a positive square size and a non-negative margin"
    )]
    InvalidBoard {
        /// Inner corners along x.
        cols: usize,
        /// Inner corners along y.
        rows: usize,
        /// Square size, metres.
        square_size: f64,
        /// Margin, metres.
        margin: f64,
    },
    /// A ChArUco board's markers are unusable.
    #[error(
        "invalid ChArUco markers of {marker_size} m from {dictionary}: expected a positive \
         size smaller than the squares and a dictionary with a marker for every white square"
    )]
    InvalidMarkers {
        /// Marker side, metres.
        marker_size: f64,
        /// The dictionary.
        dictionary: &'static str,
    },
    /// A circle grid's circles are unusable.
    #[error(
        "invalid circle grid: circles of {diameter} m at a spacing of {spacing} m (expected \
         a positive diameter smaller than the distance between neighbours, no markers, and \
         at least 3 rows in an asymmetric grid)"
    )]
    InvalidCircles {
        /// Circle diameter, metres.
        diameter: f64,
        /// Spacing, metres.
        spacing: f64,
    },
    /// The image size is too small to hold a board.
    #[error("image size {width}x{height} is too small: expected at least 64x64")]
    ImageTooSmall {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
    /// The share of bad frames is not a fraction.
    #[error("bad-frame fraction {0} is not within [0, 1]")]
    BadFraction(f64),
    /// A pose sampler was given no camera.
    #[error("a pose sampler needs at least one camera")]
    NoCamera,
    /// No pose satisfied the view's constraints.
    #[error("could not place the target in view for frame {index}")]
    NoPose {
        /// The frame.
        index: usize,
    },
}
