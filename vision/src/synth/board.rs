//! The calibration target: a chessboard, a ChArUco board (a chessboard with ArUco
//! markers in its white squares), or a grid of dark circles; geometry in the target
//! frame and its regions.

use calib_targets_charuco::builtins::builtin_dictionary;
use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

use super::SynthError;
use crate::board::{ArucoDictionary, CircleGrid, CircleLayout, Target};

/// A printed chessboard with a white margin around its squares.
///
/// Target frame (OpenCV's object points): origin at the first inner corner, x along a
/// row of corners, y along a column, z into the board; inner corner `(i, j)` is at
/// `(i * square_size, j * square_size, 0)`. The squares span
/// `[-square_size, cols * square_size] x [-square_size, rows * square_size]`; the
/// square touching the origin on its `-x, -y` side is black. With `markers` it is a
/// ChArUco board laid out as OpenCV's `CharucoBoard`. With `circles` it is a circle
/// grid instead: `cols x rows` circles, `square_size` their spacing, on a white board
/// reaching one spacing and the margin beyond the outer circles' centres.
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
    /// ArUco markers in the white squares (a ChArUco board); none on a chessboard.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub markers: Option<CharucoMarkers>,
    /// Dark circles instead of squares (a circle grid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub circles: Option<Circles>,
}

/// The circles of a circle grid, as [`CircleGrid`] places them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Circles {
    /// Symmetric or asymmetric.
    #[serde(with = "layout_name")]
    pub layout: CircleLayout,
    /// Diameter, metres.
    #[serde(rename = "diameter_m")]
    pub diameter: f64,
}

/// A circle layout in truth files: `circles` or `acircles`, the target's pattern name.
mod layout_name {
    use serde::{Deserialize, Deserializer, Serializer};

    use crate::board::CircleLayout;

    pub fn serialize<S: Serializer>(layout: &CircleLayout, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match layout {
            CircleLayout::Symmetric => "circles",
            CircleLayout::Asymmetric => "acircles",
        })
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<CircleLayout, D::Error> {
        match String::deserialize(d)?.as_str() {
            "circles" => Ok(CircleLayout::Symmetric),
            "acircles" => Ok(CircleLayout::Asymmetric),
            other => Err(serde::de::Error::custom(format!(
                "unknown circle layout {other:?}: expected circles or acircles"
            ))),
        }
    }
}

/// The ArUco markers of a ChArUco board, as OpenCV's `CharucoBoard` draws them: one
/// marker centred in each white square (the square diagonally outside the first inner
/// corner is black), ids counting the white squares row after row from the board's
/// top-left square, each marker a black border one bit wide around the dictionary's
/// bits (black where the code has a 1, rows top to bottom along the target's y).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(try_from = "MarkersRecord", into = "MarkersRecord")]
pub struct CharucoMarkers {
    marker_size: f64,
    dictionary: ArucoDictionary,
    /// Codes of the dictionary, by marker id: bit `r * bits + c` is the cell of row
    /// `r`, column `c`, set when black.
    codes: &'static [u64],
    /// Bits per marker side.
    bits: usize,
}

/// How markers appear in ground-truth files.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct MarkersRecord {
    #[serde(rename = "marker_size_m")]
    marker_size: f64,
    dictionary: ArucoDictionary,
}

impl CharucoMarkers {
    /// Markers of `marker_size` metres from `dictionary`.
    pub fn new(marker_size: f64, dictionary: ArucoDictionary) -> Result<Self, SynthError> {
        let invalid = || SynthError::InvalidMarkers {
            marker_size,
            dictionary: dictionary.opencv_name(),
        };
        if !(marker_size.is_finite() && marker_size > 0.0) {
            return Err(invalid());
        }
        let codes = builtin_dictionary(dictionary.opencv_name()).ok_or_else(invalid)?;
        Ok(Self {
            marker_size,
            dictionary,
            codes: codes.codes(),
            bits: codes.marker_size(),
        })
    }

    /// Side of one marker, metres.
    pub fn marker_size(&self) -> f64 {
        self.marker_size
    }

    /// The dictionary.
    pub fn dictionary(&self) -> ArucoDictionary {
        self.dictionary
    }

    /// Whether the marker's cell `(column, row)` (border included, `0..bits + 2`) is
    /// black; `None` for a marker id the dictionary lacks.
    fn cell_is_black(&self, id: usize, column: usize, row: usize) -> Option<bool> {
        let code = *self.codes.get(id)?;
        let bits = self.bits;
        if column == 0 || row == 0 || column > bits || row > bits {
            return Some(true);
        }
        Some((code >> ((row - 1) * bits + column - 1)) & 1 == 1)
    }
}

impl PartialEq for CharucoMarkers {
    fn eq(&self, other: &Self) -> bool {
        self.marker_size == other.marker_size && self.dictionary == other.dictionary
    }
}

impl TryFrom<MarkersRecord> for CharucoMarkers {
    type Error = SynthError;

    fn try_from(record: MarkersRecord) -> Result<Self, Self::Error> {
        Self::new(record.marker_size, record.dictionary)
    }
}

impl From<CharucoMarkers> for MarkersRecord {
    fn from(markers: CharucoMarkers) -> Self {
        Self {
            marker_size: markers.marker_size,
            dictionary: markers.dictionary,
        }
    }
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
    /// Inside a circle of a circle grid (black).
    Disc(u32),
    /// The white rim around a circle, up to half its radius from its edge: a pixel
    /// seeing only rim may still see the circle between its corners, so it is never
    /// shaded from its corners alone.
    Rim(u32),
    /// A cell of the marker in square `square`: `cell` counts cells along x and y
    /// from the marker's top-left, its black border included.
    MarkerCell {
        /// The square holding the marker.
        square: (i32, i32),
        /// The cell within the marker.
        cell: (i32, i32),
        /// Whether the cell is black.
        black: bool,
    },
}

impl Region {
    /// Whether the region is black (a black square or a black marker cell).
    pub(crate) fn is_black(self) -> bool {
        match self {
            Region::Square(i, j) => (i + j).rem_euclid(2) == 0,
            Region::MarkerCell { black, .. } => black,
            Region::Disc(_) => true,
            Region::Off | Region::Margin | Region::Rim(_) => false,
        }
    }

    /// Whether a pixel whose corners all see this region must still be sampled inside.
    pub(crate) fn needs_samples(self) -> bool {
        matches!(self, Region::Rim(_))
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
            markers: None,
            circles: None,
        })
    }

    /// A circle grid (see [`CircleGrid`]) on a board with a white `margin`.
    pub fn circle_grid(
        grid: &CircleGrid,
        layout: CircleLayout,
        margin: f64,
    ) -> Result<Self, SynthError> {
        let board = Self {
            circles: Some(Circles {
                layout,
                diameter: grid.diameter(),
            }),
            ..Self::new(grid.cols, grid.rows, grid.spacing, margin)?
        };
        board.checked()
    }

    /// A ChArUco board of `cols x rows` inner corners (`(cols + 1) x (rows + 1)`
    /// squares) with `markers` in its white squares: markers smaller than the squares,
    /// and a dictionary with a marker for every white square.
    pub fn charuco(
        cols: usize,
        rows: usize,
        square_size: f64,
        margin: f64,
        markers: CharucoMarkers,
    ) -> Result<Self, SynthError> {
        let board = Self {
            markers: Some(markers),
            ..Self::new(cols, rows, square_size, margin)?
        };
        board.checked()
    }

    /// The board of a calibration target, with a white margin of one square: a
    /// chessboard, or a ChArUco board with its markers.
    pub fn from_target(target: &Target) -> Result<Self, SynthError> {
        match target {
            Target::Chessboard(board) => {
                Self::new(board.cols, board.rows, board.square_size, board.square_size)
            }
            Target::Charuco(board) => Self::charuco(
                board.cols(),
                board.rows(),
                board.square_size,
                board.square_size,
                CharucoMarkers::new(board.marker_size, board.dictionary)?,
            ),
            Target::Circles(grid) => Self::circle_grid(grid, CircleLayout::Symmetric, grid.spacing),
            Target::Acircles(grid) => {
                Self::circle_grid(grid, CircleLayout::Asymmetric, grid.spacing)
            }
        }
    }

    /// The board after checking its dimensions and markers (a board built field by
    /// field or read from a file has not been checked).
    pub fn checked(&self) -> Result<Self, SynthError> {
        let board = Self {
            markers: self.markers,
            circles: self.circles,
            ..Self::new(self.cols, self.rows, self.square_size, self.margin)?
        };
        if let Some(circles) = &board.circles {
            let grid = CircleGrid {
                cols: self.cols,
                rows: self.rows,
                spacing: self.square_size,
                circle_diameter: Some(circles.diameter),
            };
            if board.markers.is_some() || grid.validate(circles.layout).is_err() {
                return Err(SynthError::InvalidCircles {
                    diameter: circles.diameter,
                    spacing: self.square_size,
                });
            }
        }
        if let Some(markers) = &board.markers {
            let white_squares = ((self.cols + 1) * (self.rows + 1)) / 2;
            if markers.marker_size >= self.square_size || markers.codes.len() < white_squares {
                return Err(SynthError::InvalidMarkers {
                    marker_size: markers.marker_size,
                    dictionary: markers.dictionary.opencv_name(),
                });
            }
        }
        Ok(board)
    }

    /// Number of inner corners.
    pub fn corner_count(&self) -> usize {
        self.cols * self.rows
    }

    /// Inner corners (circle centres) in the target frame, in OpenCV's order: row after
    /// row (`j` outer, `i` inner).
    pub fn corners(&self) -> Vec<Point3<f64>> {
        if let Some(circles) = &self.circles {
            return self.grid().object_points(circles.layout);
        }
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

    /// The circle grid the board's dimensions describe (used only with `circles`).
    fn grid(&self) -> CircleGrid {
        CircleGrid {
            cols: self.cols,
            rows: self.rows,
            spacing: self.square_size,
            circle_diameter: self.circles.map(|c| c.diameter),
        }
    }

    /// The largest `(x, y)` of an inner corner (circle centre), in the target frame.
    fn last_corner(&self) -> Point2<f64> {
        let columns = match self.circles {
            Some(Circles {
                layout: CircleLayout::Asymmetric,
                ..
            }) => 2 * self.cols - 1,
            _ => self.cols - 1,
        };
        Point2::new(
            columns as f64 * self.square_size,
            (self.rows - 1) as f64 * self.square_size,
        )
    }

    /// Centre of the grid of inner corners (circle centres), in the target frame.
    pub fn centre(&self) -> Point3<f64> {
        let last = self.last_corner();
        Point3::new(0.5 * last.x, 0.5 * last.y, 0.0)
    }

    /// Width of the squares (or of the circle grid's board without its margin) along x,
    /// metres.
    pub fn pattern_width(&self) -> f64 {
        self.last_corner().x + 2.0 * self.square_size
    }

    /// Outer corners of the printed board (margin included) in the target frame:
    /// the minimum and maximum `(x, y)`.
    pub fn extent(&self) -> (Point2<f64>, Point2<f64>) {
        let lo = -self.square_size - self.margin;
        let last = self.last_corner();
        let reach = self.square_size + self.margin;
        (
            Point2::new(lo, lo),
            Point2::new(last.x + reach, last.y + reach),
        )
    }

    /// What the board shows at `(x, y)` of the target plane.
    pub(crate) fn region(&self, x: f64, y: f64) -> Region {
        let (lo, hi) = self.extent();
        if !(x >= lo.x && x <= hi.x && y >= lo.y && y <= hi.y) {
            return Region::Off;
        }
        if let Some(circles) = &self.circles {
            return self.circle_region(circles, x, y);
        }
        // Within the extent the square indices are small, so they fit an i64.
        let i = floor(x / self.square_size);
        let j = floor(y / self.square_size);
        if i < -1 || j < -1 || i >= self.cols as i64 || j >= self.rows as i64 {
            return Region::Margin;
        }
        let square = Region::Square(i as i32, j as i32);
        match &self.markers {
            Some(markers) if !square.is_black() => self
                .marker_region(markers, i as i32, j as i32, x, y)
                .unwrap_or(square),
            _ => square,
        }
    }

    /// What a circle grid shows at `(x, y)` (within the board): the nearest circle's
    /// disc or rim, or the white margin.
    fn circle_region(&self, circles: &Circles, x: f64, y: f64) -> Region {
        let s = self.square_size;
        let row = floor(y / s + 0.5);
        let mut nearest: Option<(f64, u32)> = None;
        for j in row - 1..=row + 1 {
            if j < 0 || j >= self.rows as i64 {
                continue;
            }
            let shift = match circles.layout {
                CircleLayout::Symmetric => 0.0,
                CircleLayout::Asymmetric => (j % 2) as f64,
            };
            let pitch = match circles.layout {
                CircleLayout::Symmetric => 1.0,
                CircleLayout::Asymmetric => 2.0,
            };
            let i = floor((x / s - shift) / pitch + 0.5).clamp(0, self.cols as i64 - 1);
            let (cx, cy) = ((i as f64 * pitch + shift) * s, j as f64 * s);
            let distance = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
            let id = (j as u64 * self.cols as u64 + i as u64) as u32;
            if nearest.is_none_or(|(d, _)| distance < d) {
                nearest = Some((distance, id));
            }
        }
        let radius = 0.5 * circles.diameter;
        match nearest {
            Some((d, id)) if d <= radius => Region::Disc(id),
            Some((d, id)) if d <= 1.5 * radius => Region::Rim(id),
            _ => Region::Margin,
        }
    }

    /// The marker cell of white square `(i, j)` at `(x, y)`; `None` outside the
    /// marker.
    fn marker_region(
        &self,
        markers: &CharucoMarkers,
        i: i32,
        j: i32,
        x: f64,
        y: f64,
    ) -> Option<Region> {
        let offset = 0.5 * (self.square_size - markers.marker_size);
        let u = x - (f64::from(i) * self.square_size + offset);
        let v = y - (f64::from(j) * self.square_size + offset);
        if !(u >= 0.0 && v >= 0.0 && u < markers.marker_size && v < markers.marker_size) {
            return None;
        }
        let cells = markers.bits + 2;
        let cell_size = markers.marker_size / cells as f64;
        let column = ((u / cell_size) as usize).min(cells - 1);
        let row = ((v / cell_size) as usize).min(cells - 1);
        // OpenCV's square (a, b) counts from the board's top-left square, one square up
        // and left of ours; its white squares, (a + b) odd, are numbered row-major.
        let (a, b) = (usize::try_from(i + 1).ok()?, usize::try_from(j + 1).ok()?);
        let squares_x = self.cols + 1;
        let whites_before_row = b.div_ceil(2) * (squares_x / 2) + (b / 2) * squares_x.div_ceil(2);
        let whites_before_in_row = if b % 2 == 0 { a / 2 } else { a.div_ceil(2) };
        let id = whites_before_row + whites_before_in_row;
        Some(Region::MarkerCell {
            square: (i, j),
            cell: (column as i32, row as i32),
            black: markers.cell_is_black(id, column, row)?,
        })
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
        assert!(board.region(-d, -d).is_black());
        assert!(!board.region(d, -d).is_black());
        assert!(!board.region(-d, d).is_black());
        assert!(board.region(d, d).is_black());
        assert_eq!(board.region(-0.06, 0.0), Region::Margin);
        assert_eq!(board.region(-0.08, 0.0), Region::Off);
        assert_eq!(board.region(0.0, 0.12), Region::Margin);
    }

    #[test]
    fn charuco_markers_follow_opencv_layout() {
        let markers = CharucoMarkers::new(0.03, ArucoDictionary::Dict4x4_50).unwrap();
        let board = Chessboard::charuco(6, 4, 0.04, 0.01, markers).unwrap();
        // Cell side 0.03 / 6 = 0.005 m; the marker starts 0.005 m into its square.
        let cell = |i: f64, j: f64, column: f64, row: f64| {
            board.region(
                i * 0.04 + 0.005 + (column + 0.5) * 0.005,
                j * 0.04 + 0.005 + (row + 0.5) * 0.005,
            )
        };
        // Marker 0 sits in OpenCV's square (1, 0), our (0, -1); marker 3 in (0, 1),
        // our (-1, 0): the first white square of the second row.
        let codes = builtin_dictionary("DICT_4X4_50").unwrap().codes();
        for (id, (i, j)) in [(0usize, (0.0, -1.0)), (3, (-1.0, 0.0))] {
            assert!(cell(i, j, 0.0, 0.0).is_black(), "marker {id} border");
            for bit in 0..16 {
                let (column, row) = ((bit % 4) as f64 + 1.0, (bit / 4) as f64 + 1.0);
                let black = (codes[id] >> bit) & 1 == 1;
                assert_eq!(
                    cell(i, j, column, row).is_black(),
                    black,
                    "marker {id} bit {bit}"
                );
            }
        }
        // Black squares carry no marker; white squares stay white outside theirs.
        assert_eq!(board.region(0.02, 0.02), Region::Square(0, 0));
        assert_eq!(board.region(0.041, 0.002), Region::Square(1, 0));
        // A dictionary too small for the board, or markers as large as the squares.
        let small = CharucoMarkers::new(0.03, ArucoDictionary::Dict4x4_50).unwrap();
        assert!(Chessboard::charuco(11, 9, 0.04, 0.01, small).is_err());
        assert!(Chessboard::charuco(6, 4, 0.03, 0.01, markers).is_err());
    }

    #[test]
    fn rejects_degenerate_boards() {
        assert!(Chessboard::new(1, 5, 0.05, 0.0).is_err());
        assert!(Chessboard::new(4, 5, 0.0, 0.0).is_err());
        assert!(Chessboard::new(4, 5, 0.05, f64::NAN).is_err());
    }
}
