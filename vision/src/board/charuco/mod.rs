//! ChArUco detection: ChESS corners from `chess-corners` (saddle-point refiner; on the
//! image, then on a copy upscaled twice, which finds boards of small squares and fine
//! marker bits the first pass breaks up; of the board's region alone when the corners
//! of the first pass fix it), grid labelling, marker decoding and board
//! alignment from `calib-targets-charuco` (its three-configuration sweep; the result
//! with the most markers and corners, completed by the results that agree with it).
//!
//! The corners are the saddle points the crate fits, not refined further: the
//! gradient-orthogonality refiner of [`refine_corners`](super::refine_corners) must
//! keep its window inside the gap between a corner and the markers (an eighth of a
//! square on the usual boards), and with so few pixels it is noisier than the saddle
//! fit: a synthetic stereo session calibrates to within 0.1-0.18 px of the true
//! intrinsics with the crate's corners against 0.2-0.25 px with refined ones.
//!
//! The crate numbers ChArUco corners as OpenCV does (row-major over the inner
//! corners), which is our [`Target`] corner id, and reports positions with pixel
//! centres at integer coordinates, the convention of this crate. Its markers follow
//! OpenCV's `CharucoBoard` (modern, non-legacy pattern: the top-left square black).
//! A partly visible board gives the corners it shows; a detection needs at least
//! [`MIN_CHARUCO_CORNERS`] corners, not all on one line of the board.

use calib_targets_charuco::{
    CharucoBoardSpec, CharucoDetector as BoardDetector, CharucoParams, GrayImageView, MarkerLayout,
    builtins::builtin_dictionary,
};
use calib_targets_chessboard::default_chess_config;
use chess_corners::{ImageRefiner, UpscaleConfig};
use nalgebra::Point2;

mod board_region;
mod corner_pass;

use board_region::Region;
use calib_targets_chessboard::ChessCorner;
use corner_pass::CornerPass;

use super::contained::contained;
use super::detection::{Detection, TargetDetector};
use super::target::{Charuco, Target};
use super::{BoardError, Gray};

/// Fewest corners a ChArUco detection may have.
pub const MIN_CHARUCO_CORNERS: usize = 6;

/// Two results agree on a corner when they place it this close, pixels.
const AGREEMENT_PX: f64 = 0.5;

/// A corner's id and image position.
type IdCorner = (usize, Point2<f64>);

/// Finds a [`Charuco`] board, whole or in part, in images.
#[derive(Debug)]
pub struct CharucoDetector {
    board: Charuco,
    target: Target,
    corner_passes: [CornerPass; 2],
    detectors: Vec<BoardDetector>,
}

impl CharucoDetector {
    /// A detector of `board` with the default configuration.
    pub fn new(board: Charuco) -> Result<Self, BoardError> {
        board.validate()?;
        let name = board.dictionary.opencv_name();
        let dictionary = builtin_dictionary(name).ok_or_else(|| {
            BoardError::Unsupported(format!("the ArUco dictionary {name} is not available"))
        })?;
        let (squares_x, squares_y) = (
            u32::try_from(board.squares_x).map_err(|e| BoardError::InvalidTarget(e.to_string()))?,
            u32::try_from(board.squares_y).map_err(|e| BoardError::InvalidTarget(e.to_string()))?,
        );
        let spec = CharucoBoardSpec::new(
            squares_y,
            squares_x,
            board.square_size as f32,
            (board.marker_size / board.square_size) as f32,
            dictionary,
        )
        .with_marker_layout(MarkerLayout::OpenCvCharuco);
        // The multiscale pyramid that serves chessboards loses ChArUco grids (the
        // ChArUco configurations' corner-strength floor is tuned for one scale); the
        // saddle-point refiner places the crate's corners far better than its default.
        let corner_config = default_chess_config().with_refiner(ImageRefiner::saddle_point());
        let corner_passes = [
            CornerPass::new(corner_config),
            CornerPass::new(corner_config.with_upscale(UpscaleConfig::Fixed(2))),
        ];
        let detectors = CharucoParams::sweep_for_board(&spec)
            .into_iter()
            .map(|mut params| {
                params.chess = corner_config;
                BoardDetector::new(params).map_err(|e| BoardError::InvalidTarget(e.to_string()))
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            target: Target::Charuco(board.clone()),
            board,
            corner_passes,
            detectors,
        })
    }

    /// The board.
    pub fn board(&self) -> &Charuco {
        &self.board
    }

    /// The board's corners found in `gray`, by ascending id: of the corner passes and
    /// the sweep's configurations, the result that aligned the most markers (then
    /// corners), completed by the others that agree with it; the upscaled pass runs
    /// only when the first misses corners, on the board's region when the first pass's
    /// corners fix it (see [`board_region`]), and the sweep of a pass stops at the first
    /// configuration that gives every corner (the others would find the same corners
    /// at the same positions, and nothing to add).
    fn find_corners(&self, gray: &Gray) -> Option<(Vec<usize>, Vec<Point2<f64>>)> {
        contained(|| self.search_corners(gray))
    }

    /// [`find_corners`](Self::find_corners), unprotected from the detector library.
    fn search_corners(&self, gray: &Gray) -> Option<(Vec<usize>, Vec<Point2<f64>>)> {
        let view = GrayImageView {
            width: gray.width,
            height: gray.height,
            data: &gray.data,
        };
        let count = self.board.cols() * self.board.rows();
        let mut results: Vec<((usize, usize), usize, Vec<IdCorner>)> = Vec::new();
        for (pass_index, pass) in self.corner_passes.iter().enumerate() {
            if results.iter().any(|(_, _, corners)| corners.len() == count) {
                break;
            }
            // Past the first pass, the corner search keeps to the board's region
            // when the corners found so far fix it.
            let region = results
                .iter()
                .max_by_key(|(quality, _, _)| *quality)
                .and_then(|(_, _, corners)| {
                    board_region::board_region(
                        corners,
                        self.board.cols(),
                        self.board.rows(),
                        gray.width,
                        gray.height,
                    )
                });
            let chess = match region {
                Some(region) => Self::detect_in(pass, gray, region),
                None => pass.detect(&view),
            };
            for detector in &self.detectors {
                let Ok(found) = detector.detect_with_corners(&view, &chess) else {
                    continue;
                };
                let mut corners: Vec<IdCorner> = found
                    .corners
                    .iter()
                    .filter_map(|c| {
                        let id = usize::try_from(c.id).ok().filter(|&id| id < count)?;
                        let p = Point2::new(f64::from(c.position.x), f64::from(c.position.y));
                        (p.x.is_finite() && p.y.is_finite()).then_some((id, p))
                    })
                    .collect();
                corners.sort_by_key(|(id, _)| *id);
                corners.dedup_by_key(|(id, _)| *id);
                let whole = corners.len() == count;
                results.push(((found.markers.len(), corners.len()), pass_index, corners));
                if whole {
                    break;
                }
            }
        }
        // The best result, completed with the corners of the others that agree with it
        // on every corner they share (the passes break a board up differently).
        // A corner found at the image's own resolution is placed more accurately than
        // one found on the upscaled copy: the merged results of the first pass give
        // their positions to the corners they hold (a synthetic stereo session
        // calibrates 0.27 px off the true principal point with upscaled positions,
        // 0.15 px without).
        results.sort_by_key(|r| std::cmp::Reverse(r.0));
        let mut corners = results.first()?.2.clone();
        let mut merged = vec![false; results.len()];
        merged[0] = true;
        for (k, (_, _, other)) in results.iter().enumerate().skip(1) {
            let agrees =
                other.iter().all(
                    |(id, p)| match corners.binary_search_by_key(id, |(i, _)| *i) {
                        Ok(at) => (corners[at].1 - p).norm() <= AGREEMENT_PX,
                        Err(_) => true,
                    },
                );
            if agrees {
                merged[k] = true;
                corners.extend(other.iter().copied());
                corners.sort_by_key(|(id, _)| *id);
                corners.dedup_by_key(|(id, _)| *id);
            }
        }
        for ((_, pass_index, found), _) in results.iter().zip(&merged).filter(|(_, m)| **m) {
            if *pass_index == 0 {
                for (id, p) in found {
                    if let Ok(at) = corners.binary_search_by_key(id, |(i, _)| *i) {
                        corners[at].1 = *p;
                    }
                }
            }
        }
        Some(corners.into_iter().unzip())
    }

    /// The corners `pass` finds in `region` of `gray`, in the image's coordinates.
    fn detect_in(pass: &CornerPass, gray: &Gray, region: Region) -> Vec<ChessCorner> {
        let Some(data) = region.crop(&gray.data, gray.width) else {
            return Vec::new();
        };
        let view = GrayImageView {
            width: region.x1 - region.x0,
            height: region.y1 - region.y0,
            data: &data,
        };
        let mut corners = pass.detect(&view);
        for corner in &mut corners {
            corner.position.x += region.x0 as f32;
            corner.position.y += region.y0 as f32;
        }
        corners
    }

    /// Shortest distance from each corner to a detected neighbour on the board's
    /// grid, pixels; corners with no detected neighbour take the median of the others.
    fn local_squares(&self, ids: &[usize], corners: &[Point2<f64>]) -> Vec<f64> {
        let cols = self.board.cols();
        let position = |id: usize| ids.binary_search(&id).ok().map(|k| corners[k]);
        let mut squares: Vec<Option<f64>> = ids
            .iter()
            .zip(corners)
            .map(|(&id, here)| {
                let (i, j) = (id % cols, id / cols);
                let mut neighbours = Vec::with_capacity(4);
                if i > 0 {
                    neighbours.push(id - 1);
                }
                if i + 1 < cols {
                    neighbours.push(id + 1);
                }
                if j > 0 {
                    neighbours.push(id - cols);
                }
                neighbours.push(id + cols);
                neighbours
                    .into_iter()
                    .filter_map(position)
                    .map(|n| (n - here).norm())
                    .reduce(f64::min)
            })
            .collect();
        let mut known: Vec<f64> = squares.iter().flatten().copied().collect();
        known.sort_by(f64::total_cmp);
        let median = known.get(known.len() / 2).copied().unwrap_or(0.0);
        squares.iter_mut().map(|s| s.unwrap_or(median)).collect()
    }
}

/// Whether the corners `ids` of a board with `cols` corners per row all lie on one
/// straight line of the board (too little to fix a pose or a homography).
fn collinear(ids: &[usize], cols: usize) -> bool {
    let point = |id: usize| ((id % cols) as i64, (id / cols) as i64);
    let Some((&first, rest)) = ids.split_first() else {
        return true;
    };
    let a = point(first);
    let Some(b) = rest.iter().map(|&id| point(id)).find(|&p| p != a) else {
        return true;
    };
    rest.iter().all(|&id| {
        let c = point(id);
        (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0) == 0
    })
}

impl TargetDetector for CharucoDetector {
    fn target(&self) -> &Target {
        &self.target
    }

    fn detect_gray(&self, gray: &Gray) -> Option<Detection> {
        let (ids, corners) = self.find_corners(gray)?;
        if ids.len() < MIN_CHARUCO_CORNERS || collinear(&ids, self.board.cols()) {
            return None;
        }
        let mut sorted = self.local_squares(&ids, &corners);
        sorted.sort_by(f64::total_cmp);
        Some(Detection {
            square_px: sorted[sorted.len() / 2],
            corners,
            ids,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collinear_corners_are_recognised() {
        // 6 corners per row.
        assert!(collinear(&[0, 1, 2, 3, 4, 5], 6));
        assert!(collinear(&[2, 8, 14, 20], 6));
        assert!(collinear(&[0, 7, 14, 21], 6));
        assert!(collinear(&[3], 6));
        assert!(!collinear(&[0, 1, 2, 3, 4, 6], 6));
    }
}
