//! Chessboard detection: ChESS corners and grid labelling from `calib-targets`
//! (saddle-point refiner, multiscale pyramid, the three-configuration sweep), then
//! our own board fitting, ordering and sub-pixel refinement.
//!
//! The grid detector has no board-size parameter and returns grids of any size: a
//! grid is accepted only when it is exactly the board (after trimming outer lines
//! that are not chessboard corners), which also rejects partial boards and wrong
//! board sizes. Of several grids (a second board in view) the largest in the image
//! that fits is taken. Large squares weaken the detector, so when the full image
//! gives nothing it runs again on half-resolution copies, and the corners found are
//! refined at full resolution. Images whose corner pyramid has two levels (a shorter
//! side of 256 to 511 pixels) are searched at half resolution first. Corner positions from `chess-corners` already have
//! pixel centres at integer coordinates (its pyramid and upscaling map
//! `x_src = (x_out + 0.5) / k - 0.5`), the convention of this crate.

use calib_targets_chessboard::{
    ChessboardDetector as GridDetector, ChessboardParams, DetectorConfig, GrayImageView,
    detect_corners,
};
use chess_corners::{ImageRefiner, MultiscaleConfig};
use nalgebra::Point2;

use super::contained::contained;
use super::detection::{Detection, TargetDetector};
use super::grid::{GridCorner, board_corners};
use super::subpixel::{SubpixelWindow, refine_corners};
use super::target::{Chessboard, Target};
use super::{BoardError, Gray};

/// Half-resolution retries stop below this image side, pixels.
const MIN_LEVEL_SIDE: usize = 96;

/// Finds a [`Chessboard`] in images.
#[derive(Clone, Debug)]
pub struct ChessboardDetector {
    board: Chessboard,
    target: Target,
    corner_config: DetectorConfig,
    grid_params: Vec<ChessboardParams>,
    window: SubpixelWindow,
}

impl ChessboardDetector {
    /// A detector of `board` with the default configuration.
    pub fn new(board: Chessboard) -> Result<Self, BoardError> {
        board.validate()?;
        let corner_config =
            DetectorConfig::chess_multiscale().with_refiner(ImageRefiner::saddle_point());
        let grid_params = ChessboardParams::sweep_default()
            .into_iter()
            .map(|mut params| {
                // Small boards have fewer corners than the detector's default minimum.
                params.min_labeled_corners = params.min_labeled_corners.min(board.corner_count());
                GridDetector::new(params.clone())
                    .map(|_| params)
                    .map_err(|e| BoardError::InvalidTarget(e.to_string()))
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            board,
            target: Target::Chessboard(board),
            corner_config,
            grid_params,
            window: SubpixelWindow::default(),
        })
    }

    /// Replaces the sub-pixel refinement settings.
    pub fn with_subpixel_window(mut self, window: SubpixelWindow) -> Self {
        self.window = window;
        self
    }

    /// The board.
    pub fn board(&self) -> &Chessboard {
        &self.board
    }

    /// The board's corners in target order at the resolution of `gray`, before
    /// sub-pixel refinement, and which of them the grid lacked and we predicted.
    fn find_board(&self, gray: &Gray) -> Option<(Vec<Point2<f64>>, Vec<bool>)> {
        contained(|| self.search_board(gray))
    }

    /// [`find_board`](Self::find_board), unprotected from the corner library.
    fn search_board(&self, gray: &Gray) -> Option<(Vec<Point2<f64>>, Vec<bool>)> {
        let view = GrayImageView {
            width: gray.width,
            height: gray.height,
            data: &gray.data,
        };
        let corners = detect_corners(&view, &self.corner_config);
        let mut best: Option<(f64, Vec<Point2<f64>>, Vec<bool>)> = None;
        for params in &self.grid_params {
            let Ok(detector) = GridDetector::new(params.clone()) else {
                continue;
            };
            for component in detector.detect_all(&corners) {
                let labelled: Vec<GridCorner> = component
                    .corners
                    .iter()
                    .map(|c| GridCorner {
                        u: c.grid.u,
                        v: c.grid.v,
                        position: Point2::new(c.position.x as f64, c.position.y as f64),
                    })
                    .collect();
                let Some(ordered) =
                    board_corners(&labelled, gray, self.board.cols, self.board.rows)
                else {
                    continue;
                };
                let area = quad_area(&ordered, self.board.cols, self.board.rows);
                if best.as_ref().is_none_or(|(a, _, _)| area > *a) {
                    // Corners not among the grid's own were predicted from neighbours.
                    let predicted = ordered
                        .iter()
                        .map(|p| !labelled.iter().any(|c| c.position == *p))
                        .collect();
                    best = Some((area, ordered, predicted));
                }
            }
            if best.is_some() {
                break;
            }
        }
        best.map(|(_, ordered, predicted)| (ordered, predicted))
    }

    /// [`find_board`](Self::find_board) on a copy of the image at `1 / scale` of its
    /// resolution, the corners mapped to the full image.
    fn find_board_scaled(&self, level: &Gray, scale: f64) -> Option<(Vec<Point2<f64>>, Vec<bool>)> {
        self.find_board(level).map(|(corners, predicted)| {
            let corners = corners
                .into_iter()
                .map(|p| Point2::new((p.x + 0.5) * scale - 0.5, (p.y + 0.5) * scale - 0.5))
                .collect();
            (corners, predicted)
        })
    }

    /// Levels of the corner detector's pyramid for `gray`: each level half the one
    /// before, as long as both sides stay at least the configured minimum.
    fn pyramid_levels(&self, gray: &Gray) -> usize {
        let MultiscaleConfig::Pyramid {
            levels, min_size, ..
        } = self.corner_config.multiscale
        else {
            return 1;
        };
        let mut side = gray.width.min(gray.height);
        let mut count = 0;
        while count < usize::from(levels) && side >= min_size {
            count += 1;
            side /= 2;
        }
        count
    }

    /// How clearly corner `k` is a chessboard corner: the grey levels a quarter of a
    /// square out along its four diagonals, as the smallest difference between
    /// neighbouring quadrants (an X-junction's quadrants alternate; an edge of the
    /// board or a T-junction has two equal neighbours). `None` off the image.
    fn corner_contrast(&self, gray: &Gray, corners: &[Point2<f64>], k: usize) -> Option<f64> {
        let cols = self.board.cols;
        let i = k % cols;
        let step = |a: usize, b: usize| corners[b] - corners[a];
        let du = if i + 1 < cols {
            step(k, k + 1)
        } else {
            step(k - 1, k)
        };
        let dv = if k + cols < corners.len() {
            step(k, k + cols)
        } else {
            step(k - cols, k)
        };
        let q = corners[k];
        let level = |su: f64, sv: f64| {
            let p = q + du * (0.25 * su) + dv * (0.25 * sv);
            gray.sample(p.x, p.y)
        };
        let quadrants = [
            level(1.0, 1.0)?,
            level(1.0, -1.0)?,
            level(-1.0, -1.0)?,
            level(-1.0, 1.0)?,
        ];
        Some(
            (0..4)
                .map(|n| (quadrants[n] - quadrants[(n + 1) % 4]).abs())
                .fold(f64::INFINITY, f64::min),
        )
    }

    /// Shortest side of the squares around each corner, pixels.
    fn local_squares(&self, corners: &[Point2<f64>]) -> Vec<f64> {
        let (cols, rows) = (self.board.cols, self.board.rows);
        (0..rows)
            .flat_map(|j| (0..cols).map(move |i| (i, j)))
            .map(|(i, j)| {
                let here = corners[j * cols + i];
                let mut neighbours = Vec::with_capacity(4);
                if i > 0 {
                    neighbours.push(corners[j * cols + i - 1]);
                }
                if i + 1 < cols {
                    neighbours.push(corners[j * cols + i + 1]);
                }
                if j > 0 {
                    neighbours.push(corners[(j - 1) * cols + i]);
                }
                if j + 1 < rows {
                    neighbours.push(corners[(j + 1) * cols + i]);
                }
                neighbours
                    .iter()
                    .map(|n| (n - here).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    }
}

impl TargetDetector for ChessboardDetector {
    fn target(&self) -> &Target {
        &self.target
    }

    fn detect_gray(&self, gray: &Gray) -> Option<Detection> {
        // When the corner pyramid of this image has two levels, its corners are found
        // on the half-resolution level and found again at full resolution, which our
        // sub-pixel refinement at full resolution makes redundant: the half-resolution
        // copy is searched first, and the full image only when it gives no board.
        let half_first = self.pyramid_levels(gray) == 2;
        let mut half = None;
        let mut found = None;
        if half_first {
            let level = gray.half();
            found = self.find_board_scaled(&level, 2.0);
            half = Some(level);
        }
        if found.is_none() {
            found = self.find_board(gray);
        }
        if found.is_none() {
            let (mut level, mut scale) = match half {
                Some(level) => (level.half(), 4.0),
                None => (gray.half(), 2.0),
            };
            while found.is_none() && level.width.min(level.height) >= MIN_LEVEL_SIDE {
                found = self.find_board_scaled(&level, scale);
                level = level.half();
                scale *= 2.0;
            }
        }
        let (mut corners, predicted) = found?;
        let squares = self.local_squares(&corners);
        let refined = refine_corners(gray, &mut corners, &squares, &self.window);
        // A corner the grid lacked and we predicted must prove itself a chessboard
        // corner: refined, and with the contrast of the corners the grid found.
        if predicted.iter().any(|&p| p) {
            let contrasts: Vec<Option<f64>> = (0..corners.len())
                .map(|k| self.corner_contrast(gray, &corners, k))
                .collect();
            let mut found: Vec<f64> = contrasts
                .iter()
                .zip(&predicted)
                .filter_map(|(c, &p)| (!p).then_some(*c).flatten())
                .collect();
            if found.is_empty() {
                return None;
            }
            found.sort_by(f64::total_cmp);
            let reference = found[found.len() / 2];
            let genuine =
                |k: usize| refined[k] && contrasts[k].is_some_and(|c| c >= 0.5 * reference);
            if (0..corners.len()).any(|k| predicted[k] && !genuine(k)) {
                return None;
            }
        }
        let mut sorted = squares.clone();
        sorted.sort_by(f64::total_cmp);
        Some(Detection {
            ids: (0..corners.len()).collect(),
            corners,
            square_px: sorted[sorted.len() / 2],
        })
    }
}

/// Image area of the quadrilateral spanned by the board's outer corners.
fn quad_area(ordered: &[Point2<f64>], cols: usize, rows: usize) -> f64 {
    let quad = [
        ordered[0],
        ordered[cols - 1],
        ordered[cols * rows - 1],
        ordered[(rows - 1) * cols],
    ];
    let mut twice = 0.0;
    for k in 0..4 {
        let (p, q) = (quad[k], quad[(k + 1) % 4]);
        twice += p.x * q.y - q.x * p.y;
    }
    twice.abs() / 2.0
}
