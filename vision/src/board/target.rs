//! Calibration target definitions, as read from `config/boards/*.yaml`, and their
//! points (corners, or circle centres) in the target frame.
//!
//! Target frame (OpenCV's object points): origin at the first inner corner (or circle),
//! x along a row, y down the columns, z into the board. Inner corner `(i, j)` lies at
//! `(i * square_size, j * square_size, 0)` and has id `j * cols + i`; circle grids
//! follow OpenCV's `calibration.cpp` sample (see [`CircleGrid`]).

use std::path::Path;

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use super::BoardError;

/// A calibration target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "pattern", rename_all = "snake_case")]
pub enum Target {
    /// A plain chessboard.
    Chessboard(Chessboard),
    /// A ChArUco board: a chessboard with ArUco markers in its white squares.
    Charuco(Charuco),
    /// A symmetric grid of dark circles (OpenCV's `CALIB_CB_SYMMETRIC_GRID`).
    Circles(CircleGrid),
    /// An asymmetric grid of dark circles (OpenCV's `CALIB_CB_ASYMMETRIC_GRID`):
    /// every other row shifted by half the pitch of a row.
    Acircles(CircleGrid),
}

/// The two layouts of a circle grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CircleLayout {
    /// Rows and columns `spacing` apart.
    Symmetric,
    /// Circles `2 * spacing` apart along a row, rows `spacing` apart, odd rows shifted
    /// by `spacing`.
    Asymmetric,
}

/// A grid of `cols x rows` dark circles on a light board, sized as ROS
/// camera_calibration and OpenCV size them: `cols` circles per row, `rows` rows, and
/// `spacing` (camera_calibration's `--square`) the unit of their positions.
///
/// Circle `(i, j)` (column `i`, row `j`) has id `j * cols + i` and lies at
/// `(i * spacing, j * spacing, 0)` in a symmetric grid, at
/// `((2 i + j % 2) * spacing, j * spacing, 0)` in an asymmetric one, OpenCV's object
/// points for both. An asymmetric grid with an odd number of rows (OpenCV's 4x11) looks
/// different turned half round, so its first circle is always the same one; a
/// symmetric grid, or an asymmetric one with an even number of rows, looks the same,
/// and the detector takes the first circle to be the one with the board's x axis
/// pointing most to the image's right.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircleGrid {
    /// Circles per row (along x).
    pub cols: usize,
    /// Rows of circles (along y).
    pub rows: usize,
    /// Unit of the circles' positions, metres: the distance between neighbouring
    /// circles of a symmetric grid; half the distance between neighbouring circles
    /// of a row of an asymmetric one.
    pub spacing: f64,
    /// Diameter of a circle, metres; [`DEFAULT_DIAMETER_RATIO`] times `spacing` (the
    /// default of OpenCV's `gen_pattern.py`) when not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub circle_diameter: Option<f64>,
}

/// A circle's diameter as a fraction of the grid's spacing when the target does not
/// give it: OpenCV's `gen_pattern.py` draws circles of radius `spacing / 5`.
pub const DEFAULT_DIAMETER_RATIO: f64 = 0.4;

/// A chessboard of `cols x rows` inner corners (`(cols + 1) x (rows + 1)` squares).
///
/// The square diagonally outside the first corner (on its `-x, -y` side) is black;
/// seen from the front, square `(a, b)` (square `(0, 0)` being that one) is black
/// when `a + b` is even.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Chessboard {
    /// Inner corners per row (along x).
    pub cols: usize,
    /// Inner corners per column (along y).
    pub rows: usize,
    /// Side of one square, metres.
    pub square_size: f64,
}

/// A ChArUco board of `squares_x x squares_y` squares, markers in the white squares,
/// laid out as OpenCV's `CharucoBoard` (the top-left square is black). Its
/// chessboard corners are the `(squares_x - 1) x (squares_y - 1)` inner corners, with
/// the same frame and ids as a [`Chessboard`] of that size (OpenCV puts the origin at
/// the board's outer corner instead: one square up and left).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Charuco {
    /// Squares along x.
    pub squares_x: usize,
    /// Squares along y.
    pub squares_y: usize,
    /// Side of one square, metres.
    pub square_size: f64,
    /// Side of one marker, metres.
    pub marker_size: f64,
    /// Marker dictionary.
    pub dictionary: ArucoDictionary,
}

/// The predefined ArUco dictionaries (OpenCV's names, as in `DICT_4X4_50`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum ArucoDictionary {
    #[serde(rename = "DICT_4X4_50")]
    Dict4x4_50,
    #[serde(rename = "DICT_4X4_100")]
    Dict4x4_100,
    #[serde(rename = "DICT_4X4_250")]
    Dict4x4_250,
    #[serde(rename = "DICT_4X4_1000")]
    Dict4x4_1000,
    #[serde(rename = "DICT_5X5_50")]
    Dict5x5_50,
    #[serde(rename = "DICT_5X5_100")]
    Dict5x5_100,
    #[serde(rename = "DICT_5X5_250")]
    Dict5x5_250,
    #[serde(rename = "DICT_5X5_1000")]
    Dict5x5_1000,
    #[serde(rename = "DICT_6X6_50")]
    Dict6x6_50,
    #[serde(rename = "DICT_6X6_100")]
    Dict6x6_100,
    #[serde(rename = "DICT_6X6_250")]
    Dict6x6_250,
    #[serde(rename = "DICT_6X6_1000")]
    Dict6x6_1000,
    #[serde(rename = "DICT_7X7_50")]
    Dict7x7_50,
    #[serde(rename = "DICT_7X7_100")]
    Dict7x7_100,
    #[serde(rename = "DICT_7X7_250")]
    Dict7x7_250,
    #[serde(rename = "DICT_7X7_1000")]
    Dict7x7_1000,
    #[serde(rename = "DICT_ARUCO_ORIGINAL")]
    ArucoOriginal,
}

impl ArucoDictionary {
    /// All dictionaries, in OpenCV's enumeration order.
    pub const ALL: [Self; 17] = [
        Self::Dict4x4_50,
        Self::Dict4x4_100,
        Self::Dict4x4_250,
        Self::Dict4x4_1000,
        Self::Dict5x5_50,
        Self::Dict5x5_100,
        Self::Dict5x5_250,
        Self::Dict5x5_1000,
        Self::Dict6x6_50,
        Self::Dict6x6_100,
        Self::Dict6x6_250,
        Self::Dict6x6_1000,
        Self::Dict7x7_50,
        Self::Dict7x7_100,
        Self::Dict7x7_250,
        Self::Dict7x7_1000,
        Self::ArucoOriginal,
    ];

    /// The short name ROS camera_calibration's `--aruco_dict` takes (`4x4_50`,
    /// `aruco_orig`).
    pub fn ros_name(self) -> String {
        match self {
            Self::ArucoOriginal => "aruco_orig".to_string(),
            other => {
                let full = other.opencv_name();
                full.trim_start_matches("DICT_").to_ascii_lowercase()
            }
        }
    }

    /// OpenCV's name (`DICT_4X4_50`).
    pub fn opencv_name(self) -> &'static str {
        match self {
            Self::Dict4x4_50 => "DICT_4X4_50",
            Self::Dict4x4_100 => "DICT_4X4_100",
            Self::Dict4x4_250 => "DICT_4X4_250",
            Self::Dict4x4_1000 => "DICT_4X4_1000",
            Self::Dict5x5_50 => "DICT_5X5_50",
            Self::Dict5x5_100 => "DICT_5X5_100",
            Self::Dict5x5_250 => "DICT_5X5_250",
            Self::Dict5x5_1000 => "DICT_5X5_1000",
            Self::Dict6x6_50 => "DICT_6X6_50",
            Self::Dict6x6_100 => "DICT_6X6_100",
            Self::Dict6x6_250 => "DICT_6X6_250",
            Self::Dict6x6_1000 => "DICT_6X6_1000",
            Self::Dict7x7_50 => "DICT_7X7_50",
            Self::Dict7x7_100 => "DICT_7X7_100",
            Self::Dict7x7_250 => "DICT_7X7_250",
            Self::Dict7x7_1000 => "DICT_7X7_1000",
            Self::ArucoOriginal => "DICT_ARUCO_ORIGINAL",
        }
    }

    /// The dictionary named `name`, in ROS (`4x4_50`, `aruco_orig`) or OpenCV
    /// (`DICT_4X4_50`) spelling, case-insensitive.
    pub fn from_name(name: &str) -> Option<Self> {
        let upper = name.trim().to_ascii_uppercase();
        Self::ALL.into_iter().find(|d| {
            let full = d.opencv_name();
            upper == full
                || upper == full.trim_start_matches("DICT_")
                || upper == d.ros_name().to_ascii_uppercase()
        })
    }
}

impl Chessboard {
    /// A chessboard of `cols x rows` inner corners (each at least 2) with squares of
    /// `square_size` metres (positive, finite).
    pub fn new(cols: usize, rows: usize, square_size: f64) -> Result<Self, BoardError> {
        let board = Self {
            cols,
            rows,
            square_size,
        };
        board.validate()?;
        Ok(board)
    }

    /// Checks the dimensions (a deserialized board has not been checked yet).
    pub fn validate(&self) -> Result<(), BoardError> {
        if self.cols < 2 || self.rows < 2 {
            return Err(BoardError::InvalidTarget(format!(
                "a chessboard needs at least 2x2 inner corners, got {}x{}",
                self.cols, self.rows
            )));
        }
        check_size("square_size", self.square_size)
    }

    /// Number of inner corners.
    pub fn corner_count(&self) -> usize {
        self.cols * self.rows
    }

    /// Inner corners in the target frame, by id (row after row).
    pub fn object_points(&self) -> Vec<Point3<f64>> {
        grid_points(self.cols, self.rows, self.square_size)
    }
}

impl Charuco {
    /// Checks the dimensions: at least 3x3 squares, positive sizes, markers smaller
    /// than squares.
    pub fn validate(&self) -> Result<(), BoardError> {
        if self.squares_x < 3 || self.squares_y < 3 {
            return Err(BoardError::InvalidTarget(format!(
                "a ChArUco board needs at least 3x3 squares, got {}x{}",
                self.squares_x, self.squares_y
            )));
        }
        check_size("square_size", self.square_size)?;
        check_size("marker_size", self.marker_size)?;
        if self.marker_size >= self.square_size {
            return Err(BoardError::InvalidTarget(format!(
                "ChArUco marker size {} m must be smaller than the square size {} m",
                self.marker_size, self.square_size
            )));
        }
        Ok(())
    }

    /// Inner chessboard corners along x.
    pub fn cols(&self) -> usize {
        self.squares_x - 1
    }

    /// Inner chessboard corners along y.
    pub fn rows(&self) -> usize {
        self.squares_y - 1
    }

    /// Inner chessboard corners in the target frame, by id (row after row).
    pub fn object_points(&self) -> Vec<Point3<f64>> {
        grid_points(self.cols(), self.rows(), self.square_size)
    }
}

impl CircleGrid {
    /// A grid of `cols x rows` circles `spacing` metres apart (see [`CircleGrid`]),
    /// of the default diameter.
    pub fn new(
        cols: usize,
        rows: usize,
        spacing: f64,
        layout: CircleLayout,
    ) -> Result<Self, BoardError> {
        let grid = Self {
            cols,
            rows,
            spacing,
            circle_diameter: None,
        };
        grid.validate(layout)?;
        Ok(grid)
    }

    /// Checks the dimensions: at least 2x2 circles (3x3 in all for an asymmetric grid,
    /// whose shifted rows need a neighbour), a positive spacing, and circles that do
    /// not touch their neighbours.
    pub fn validate(&self, layout: CircleLayout) -> Result<(), BoardError> {
        if self.cols < 2 || self.rows < 2 {
            return Err(BoardError::InvalidTarget(format!(
                "a circle grid needs at least 2x2 circles, got {}x{}",
                self.cols, self.rows
            )));
        }
        if layout == CircleLayout::Asymmetric && self.rows < 3 {
            return Err(BoardError::InvalidTarget(format!(
                "an asymmetric circle grid needs at least 3 rows, got {}x{}",
                self.cols, self.rows
            )));
        }
        check_size("spacing", self.spacing)?;
        if let Some(diameter) = self.circle_diameter {
            check_size("circle_diameter", diameter)?;
        }
        let nearest = self.neighbour_distance(layout);
        if self.diameter() >= nearest {
            return Err(BoardError::InvalidTarget(format!(
                "circles of {} m diameter touch their neighbours {nearest} m away",
                self.diameter()
            )));
        }
        Ok(())
    }

    /// Diameter of a circle, metres.
    pub fn diameter(&self) -> f64 {
        self.circle_diameter
            .unwrap_or(DEFAULT_DIAMETER_RATIO * self.spacing)
    }

    /// Distance between a circle's centre and its nearest neighbour's, metres.
    pub fn neighbour_distance(&self, layout: CircleLayout) -> f64 {
        match layout {
            CircleLayout::Symmetric => self.spacing,
            CircleLayout::Asymmetric => self.spacing * std::f64::consts::SQRT_2,
        }
    }

    /// Number of circles.
    pub fn circle_count(&self) -> usize {
        self.cols * self.rows
    }

    /// Circle centres in the target frame, by id (row after row).
    pub fn object_points(&self, layout: CircleLayout) -> Vec<Point3<f64>> {
        match layout {
            CircleLayout::Symmetric => grid_points(self.cols, self.rows, self.spacing),
            CircleLayout::Asymmetric => (0..self.rows)
                .flat_map(|j| {
                    (0..self.cols).map(move |i| {
                        Point3::new(
                            (2 * i + j % 2) as f64 * self.spacing,
                            j as f64 * self.spacing,
                            0.0,
                        )
                    })
                })
                .collect(),
        }
    }
}

impl Target {
    /// Reads a target from a YAML file (`config/boards/*.yaml`) and validates it.
    pub fn from_yaml_file(path: &Path) -> Result<Self, BoardError> {
        let text = std::fs::read_to_string(path).map_err(|e| BoardError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_yaml_str(&text).map_err(|e| match e {
            BoardError::Parse(message) => {
                BoardError::Parse(format!("{}: {message}", path.display()))
            }
            other => other,
        })
    }

    /// Parses a target from YAML text and validates it.
    pub fn from_yaml_str(text: &str) -> Result<Self, BoardError> {
        let target: Self =
            serde_yaml::from_str(text).map_err(|e| BoardError::Parse(e.to_string()))?;
        target.validate()?;
        Ok(target)
    }

    /// The target as YAML text.
    pub fn to_yaml_string(&self) -> Result<String, BoardError> {
        serde_yaml::to_string(self).map_err(|e| BoardError::Parse(e.to_string()))
    }

    /// Checks the dimensions.
    pub fn validate(&self) -> Result<(), BoardError> {
        match self {
            Self::Chessboard(board) => board.validate(),
            Self::Charuco(board) => board.validate(),
            Self::Circles(grid) => grid.validate(CircleLayout::Symmetric),
            Self::Acircles(grid) => grid.validate(CircleLayout::Asymmetric),
        }
    }

    /// Corners (or circle centres) in the target frame, by id.
    pub fn object_points(&self) -> Vec<Point3<f64>> {
        match self {
            Self::Chessboard(board) => board.object_points(),
            Self::Charuco(board) => board.object_points(),
            Self::Circles(grid) => grid.object_points(CircleLayout::Symmetric),
            Self::Acircles(grid) => grid.object_points(CircleLayout::Asymmetric),
        }
    }

    /// Side of one square (a circle grid's spacing), metres.
    pub fn square_size(&self) -> f64 {
        match self {
            Self::Chessboard(board) => board.square_size,
            Self::Charuco(board) => board.square_size,
            Self::Circles(grid) | Self::Acircles(grid) => grid.spacing,
        }
    }

    /// The circle grid and its layout, for a circle-grid target.
    pub fn circle_grid(&self) -> Option<(&CircleGrid, CircleLayout)> {
        match self {
            Self::Circles(grid) => Some((grid, CircleLayout::Symmetric)),
            Self::Acircles(grid) => Some((grid, CircleLayout::Asymmetric)),
            Self::Chessboard(_) | Self::Charuco(_) => None,
        }
    }

    /// A short description for messages: `9x6 chessboard`, `4x11 asymmetric circle
    /// grid`.
    pub fn describe(&self) -> String {
        match self {
            Self::Chessboard(b) => format!("{}x{} chessboard", b.cols, b.rows),
            Self::Charuco(b) => format!("{}x{} ChArUco board", b.squares_x, b.squares_y),
            Self::Circles(g) => format!("{}x{} circle grid", g.cols, g.rows),
            Self::Acircles(g) => format!("{}x{} asymmetric circle grid", g.cols, g.rows),
        }
    }
}

fn check_size(name: &str, value: f64) -> Result<(), BoardError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(BoardError::InvalidTarget(format!(
            "{name} must be a positive number of metres, got {value}"
        )))
    }
}

fn grid_points(cols: usize, rows: usize, square: f64) -> Vec<Point3<f64>> {
    (0..rows)
        .flat_map(|j| {
            (0..cols).map(move |i| Point3::new(i as f64 * square, j as f64 * square, 0.0))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_points_follow_opencv_order() {
        let board = Chessboard::new(9, 6, 0.025).unwrap();
        let points = board.object_points();
        assert_eq!(points.len(), 54);
        assert_eq!(points[1], Point3::new(0.025, 0.0, 0.0));
        assert_eq!(points[9], Point3::new(0.0, 0.025, 0.0));
        assert_eq!(points[53], Point3::new(0.2, 0.125, 0.0));
    }

    #[test]
    fn yaml_round_trip_and_validation() {
        let text = "pattern: chessboard\ncols: 9\nrows: 6\nsquare_size: 0.025\n";
        let target = Target::from_yaml_str(text).unwrap();
        assert_eq!(
            target,
            Target::Chessboard(Chessboard::new(9, 6, 0.025).unwrap())
        );
        assert_eq!(
            Target::from_yaml_str(&target.to_yaml_string().unwrap()).unwrap(),
            target
        );
        let charuco = "pattern: charuco\nsquares_x: 7\nsquares_y: 5\nsquare_size: 0.04\n\
                       marker_size: 0.03\ndictionary: DICT_5X5_100\n";
        let Target::Charuco(board) = Target::from_yaml_str(charuco).unwrap() else {
            panic!("not a ChArUco board");
        };
        assert_eq!(board.dictionary, ArucoDictionary::Dict5x5_100);
        assert_eq!(board.object_points().len(), 24);

        for bad in [
            "pattern: chessboard\ncols: 1\nrows: 6\nsquare_size: 0.025\n",
            "pattern: chessboard\ncols: 9\nrows: 6\nsquare_size: -1\n",
            "pattern: chessboard\ncols: 9\nrows: 6\nsquare: 0.025\n",
            "pattern: circles\ncols: 9\nrows: 6\nsquare_size: 0.025\n",
            "pattern: acircles\ncols: 4\nrows: 2\nspacing: 0.02\n",
            "pattern: circles\ncols: 4\nrows: 5\nspacing: 0.02\ncircle_diameter: 0.02\n",
            "pattern: charuco\nsquares_x: 7\nsquares_y: 5\nsquare_size: 0.04\n\
             marker_size: 0.05\ndictionary: DICT_5X5_100\n",
        ] {
            assert!(Target::from_yaml_str(bad).is_err(), "accepted {bad:?}");
        }
    }

    #[test]
    fn circle_grids_follow_opencv_object_points() {
        let text = "pattern: acircles\ncols: 4\nrows: 11\nspacing: 0.02\n";
        let target = Target::from_yaml_str(text).unwrap();
        let Target::Acircles(grid) = target else {
            panic!("not an asymmetric grid");
        };
        assert_eq!(grid.diameter(), 0.4 * 0.02);
        // OpenCV's sample: Point3f((2 * j + i % 2) * squareSize, i * squareSize, 0),
        // i the row and j the column.
        let points = target.object_points();
        assert_eq!(points.len(), 44);
        assert_eq!(points[1], Point3::new(0.04, 0.0, 0.0));
        assert_eq!(points[4], Point3::new(0.02, 0.02, 0.0));
        assert_eq!(points[43], Point3::new(0.12, 0.2, 0.0));
        let symmetric =
            Target::Circles(CircleGrid::new(4, 3, 0.03, CircleLayout::Symmetric).unwrap());
        assert_eq!(symmetric.object_points()[5], Point3::new(0.03, 0.03, 0.0));
        assert_eq!(
            Target::from_yaml_str(&symmetric.to_yaml_string().unwrap()).unwrap(),
            symmetric
        );
    }

    #[test]
    fn dictionary_names() {
        assert_eq!(
            ArucoDictionary::from_name("4x4_50"),
            Some(ArucoDictionary::Dict4x4_50)
        );
        assert_eq!(
            ArucoDictionary::from_name("DICT_6X6_250"),
            Some(ArucoDictionary::Dict6x6_250)
        );
        assert_eq!(
            ArucoDictionary::from_name("aruco_orig"),
            Some(ArucoDictionary::ArucoOriginal)
        );
        assert_eq!(ArucoDictionary::Dict7x7_1000.ros_name(), "7x7_1000");
        assert_eq!(ArucoDictionary::from_name("8x8_50"), None);
    }
}
