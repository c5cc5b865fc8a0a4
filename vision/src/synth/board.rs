//! The chessboard calibration target: geometry in the target frame and its regions.

use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

use super::SynthError;

/// A printed chessboard with a white margin around its squares.
///
/// Target frame (OpenCV's object points): origin at the first inner corner, x along a
/// row of corners, y along a column, z into the board; inner corner `(i, j)` is at
/// `(i * square_size, j * square_size, 0)`. The squares span
/// `[-square_size, cols * square_size] x [-square_size, rows * square_size]`; the
/// square touching the origin on its `-x, -y` side is black.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Chessboard {
    /// Inner corners along x (per row).
    #[serde(rename = "inner_corners_cols")]
    pub cols: usize,
    /// Inner corners along y (per column).
    #[serde(rename = "inner_corners_rows")]
    pub rows: usize,
    /// Side of one square, metres.
    #[serde(rename = "square_size_m")]
    pub square_size: f64,
    /// Width of the white margin around the squares, metres.
    #[serde(rename = "margin_m")]
    pub margin: f64,
}

/// What a point of the target plane shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Region {
    /// Outside the board: the background shows.
    Off,
    /// The white margin.
    Margin,
    /// A square, by its indices along x and y (the square `(i, j)` spans
    /// `[i, i + 1] x [j, j + 1]` squares).
    Square(i32, i32),
}

impl Region {
    /// Whether a square is black.
    pub(crate) fn is_black_square(self) -> bool {
        matches!(self, Region::Square(i, j) if (i + j).rem_euclid(2) == 0)
    }
}

impl Chessboard {
    /// A board of `cols x rows` inner corners; both at least 2, sizes positive and
    /// finite.
    pub fn new(
        cols: usize,
        rows: usize,
        square_size: f64,
        margin: f64,
    ) -> Result<Self, SynthError> {
        let valid_size = square_size.is_finite() && square_size > 0.0;
        let valid_margin = margin.is_finite() && margin >= 0.0;
        if cols < 2 || rows < 2 || !valid_size || !valid_margin {
            return Err(SynthError::InvalidBoard {
                cols,
                rows,
                square_size,
                margin,
            });
        }
        Ok(Self {
            cols,
            rows,
            square_size,
            margin,
        })
    }

    /// Number of inner corners.
    pub fn corner_count(&self) -> usize {
        self.cols * self.rows
    }

    /// Inner corners in the target frame, in OpenCV's order: row after row
    /// (`j` outer, `i` inner).
    pub fn corners(&self) -> Vec<Point3<f64>> {
        (0..self.rows)
            .flat_map(|j| {
                (0..self.cols).map(move |i| {
                    Point3::new(
                        i as f64 * self.square_size,
                        j as f64 * self.square_size,
                        0.0,
                    )
                })
            })
            .collect()
    }

    /// Centre of the grid of inner corners, in the target frame.
    pub fn centre(&self) -> Point3<f64> {
        Point3::new(
            0.5 * (self.cols - 1) as f64 * self.square_size,
            0.5 * (self.rows - 1) as f64 * self.square_size,
            0.0,
        )
    }

    /// Outer corners of the printed board (margin included) in the target frame:
    /// the minimum and maximum `(x, y)`.
    pub fn extent(&self) -> (Point2<f64>, Point2<f64>) {
        let lo = -self.square_size - self.margin;
        (
            Point2::new(lo, lo),
            Point2::new(
                self.cols as f64 * self.square_size + self.margin,
                self.rows as f64 * self.square_size + self.margin,
            ),
        )
    }

    /// What the board shows at `(x, y)` of the target plane.
    pub(crate) fn region(&self, x: f64, y: f64) -> Region {
        let (lo, hi) = self.extent();
        if !(x >= lo.x && x <= hi.x && y >= lo.y && y <= hi.y) {
            return Region::Off;
        }
        // Within the extent the square indices are small, so they fit an i64.
        let i = floor(x / self.square_size);
        let j = floor(y / self.square_size);
        if i < -1 || j < -1 || i >= self.cols as i64 || j >= self.rows as i64 {
            return Region::Margin;
        }
        Region::Square(i as i32, j as i32)
    }
}

/// The largest integer not above `value` (which must fit an i64): truncation, one
/// less for negative non-integers; cheaper than `f64::floor` where the target has no
/// rounding instruction.
fn floor(value: f64) -> i64 {
    let truncated = value as i64;
    if (truncated as f64) > value {
        truncated - 1
    } else {
        truncated
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_follow_opencv_order() {
        let board = Chessboard::new(3, 2, 0.05, 0.02).unwrap();
        let corners = board.corners();
        assert_eq!(corners.len(), 6);
        assert_eq!(corners[1], Point3::new(0.05, 0.0, 0.0));
        assert_eq!(corners[3], Point3::new(0.0, 0.05, 0.0));
    }

    #[test]
    fn regions_around_the_first_corner_alternate() {
        let board = Chessboard::new(3, 2, 0.05, 0.02).unwrap();
        let d = 0.01;
        assert!(board.region(-d, -d).is_black_square());
        assert!(!board.region(d, -d).is_black_square());
        assert!(!board.region(-d, d).is_black_square());
        assert!(board.region(d, d).is_black_square());
        assert_eq!(board.region(-0.06, 0.0), Region::Margin);
        assert_eq!(board.region(-0.08, 0.0), Region::Off);
        assert_eq!(board.region(0.0, 0.12), Region::Margin);
    }

    #[test]
    fn rejects_degenerate_boards() {
        assert!(Chessboard::new(1, 5, 0.05, 0.0).is_err());
        assert!(Chessboard::new(4, 5, 0.0, 0.0).is_err());
        assert!(Chessboard::new(4, 5, 0.05, f64::NAN).is_err());
    }
}
