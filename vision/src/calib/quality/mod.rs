//! How good a frame of a calibration target is, measured on the image alone.
//!
//! [`FrameChecks`] is the one judgement every calibration applies to a frame in which
//! the board was found, the offline command and the live node alike: its
//! [`sharpness`](edge_blur) (the width of the squares' edges; a direction tells motion
//! blur from defocus) and its [`motion`](board_speed) since the previous frame. The
//! [`coverage`](sample_params) of a view (ROS camera_calibration's X, Y, size and skew)
//! tells a live session which views add something, and [`RegionCoverage`] where a
//! calibration's corners fell.
//!
//! Conventions: pixels with pixel centres at integer coordinates; times in seconds.

mod coverage;
mod motion;
mod regions;
mod sharpness;

pub use coverage::{
    ENOUGH_SAMPLES, MONO_RANGES, NOVELTY_DISTANCE, STEREO_RANGES, SampleParams, is_new, progress,
    sample_params,
};
pub use motion::{MAX_INTERVAL, board_speed};
pub use regions::RegionCoverage;
pub use sharpness::{EdgeBlur, circle_blur, edge_blur};

use thiserror::Error;

use crate::board::{CircleLayout, Detection, Gray, Target};

/// Default [`FrameChecks::max_blur`]: edges wider than this (10-90 %, pixels) are
/// refused. The 26 images of OpenCV's stereo sample measure 2.25-3.0 px, synth's sharp
/// frames 1.5-2.25 px; synth's defocused frames that are still detected measure 11 px
/// and more (a defocus of sigma 3 px, 7.8 px), a board sliding 15 mm during the exposure
/// 8.5 px across its motion.
pub const DEFAULT_MAX_BLUR: f64 = 5.0;

/// One family of edges this many times wider than the other marks the blur as motion
/// blur rather than defocus.
const MOTION_BLUR_RATIO: f64 = 1.6;

/// The layout of a target's edges that [`edge_blur`] or [`circle_blur`] measures
/// across.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EdgeLayout {
    /// The squares of a chessboard or ChArUco board.
    Squares {
        /// Inner corners per row.
        cols: usize,
        /// Inner corners per column.
        rows: usize,
        /// Fraction of a white square's side, from each edge, free of markers: 0.5 on
        /// a chessboard, `(square - marker) / (2 square)` on a ChArUco board.
        clear: f64,
    },
    /// The circles of a circle grid.
    Circles {
        /// Circles per row.
        cols: usize,
        /// Rows of circles.
        rows: usize,
        /// Layout of the grid.
        layout: CircleLayout,
    },
}

impl EdgeLayout {
    /// The layout of `target`.
    pub fn of(target: &Target) -> Self {
        match target {
            Target::Chessboard(board) => Self::Squares {
                cols: board.cols,
                rows: board.rows,
                clear: 0.5,
            },
            Target::Charuco(board) => Self::Squares {
                cols: board.cols(),
                rows: board.rows(),
                clear: (board.square_size - board.marker_size) / (2.0 * board.square_size),
            },
            Target::Circles(grid) => Self::Circles {
                cols: grid.cols,
                rows: grid.rows,
                layout: CircleLayout::Symmetric,
            },
            Target::Acircles(grid) => Self::Circles {
                cols: grid.cols,
                rows: grid.rows,
                layout: CircleLayout::Asymmetric,
            },
        }
    }

    /// The target's points per row and rows: `(cols, rows)` of its ids.
    pub fn grid(&self) -> (usize, usize) {
        match *self {
            Self::Squares { cols, rows, .. } | Self::Circles { cols, rows, .. } => (cols, rows),
        }
    }
}

/// Why a frame with the board found is not fit for calibration. The message says what
/// to do.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FrameRefusal {
    /// The board moved too fast since the previous frame.
    #[error("board moving at {speed:.0} px/s (limit {limit:.0} px/s): hold the board still")]
    Moving {
        /// Mean corner speed, pixels per second.
        speed: f64,
        /// [`FrameChecks::max_board_speed`].
        limit: f64,
    },
    /// The board's edges are too wide.
    #[error(
        "board edges {width:.1} px wide (limit {limit:.1} px), {}",
        if *motion { "motion blur: hold the board still, or shorten the exposure" } else { "out of focus: focus the lens, or bring the board into the depth of field" }
    )]
    Blurred {
        /// The wider family's 10-90 % edge width, pixels.
        width: f64,
        /// [`FrameChecks::max_blur`].
        limit: f64,
        /// Whether one family of edges is much wider than the other (motion blur).
        motion: bool,
    },
}

/// The checks a frame with the board found must pass to serve a calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameChecks {
    /// Pixels per second of mean corner motion since the previous frame (if that frame
    /// is less than [`MAX_INTERVAL`] older); faster boards are refused. `<= 0` disables.
    /// ROS camera_calibration's max_chessboard_speed (which counts pixels per frame).
    pub max_board_speed: f64,
    /// Frames whose board edges are wider than this (10-90 % edge width in pixels, the
    /// wider of the two edge directions; see [`edge_blur`]) are refused. `<= 0` disables.
    pub max_blur: f64,
}

impl Default for FrameChecks {
    /// Board speed unchecked, [`DEFAULT_MAX_BLUR`].
    fn default() -> Self {
        Self {
            max_board_speed: 0.0,
            max_blur: DEFAULT_MAX_BLUR,
        }
    }
}

impl FrameChecks {
    /// Refuses `current` when the board moved faster than
    /// [`max_board_speed`](Self::max_board_speed) since `previous`, the same camera's
    /// detection `interval` seconds earlier. Frames too far apart, or sharing no corner,
    /// pass.
    pub fn check_motion(
        &self,
        previous: &Detection,
        current: &Detection,
        interval: f64,
    ) -> Result<(), FrameRefusal> {
        if self.max_board_speed <= 0.0 {
            return Ok(());
        }
        match board_speed(previous, current, interval) {
            Some(speed) if speed > self.max_board_speed => Err(FrameRefusal::Moving {
                speed,
                limit: self.max_board_speed,
            }),
            _ => Ok(()),
        }
    }

    /// Refuses `detection` (a board of `layout` found in `gray`) when its edges are wider
    /// than [`max_blur`](Self::max_blur). A board whose edges cannot be measured passes.
    pub fn check_sharpness(
        &self,
        gray: &Gray,
        detection: &Detection,
        layout: &EdgeLayout,
    ) -> Result<(), FrameRefusal> {
        if self.max_blur <= 0.0 {
            return Ok(());
        }
        let blur = match *layout {
            EdgeLayout::Squares { cols, rows, clear } => {
                edge_blur(gray, detection, cols, rows, clear)
            }
            EdgeLayout::Circles { cols, layout, .. } => circle_blur(gray, detection, cols, layout),
        };
        match blur {
            Some(blur) if blur.width() > self.max_blur => Err(FrameRefusal::Blurred {
                width: blur.width(),
                limit: self.max_blur,
                motion: blur.is_directional(MOTION_BLUR_RATIO),
            }),
            _ => Ok(()),
        }
    }
}
