//! Calibration target definitions, as read from `config/boards/*.yaml`, and their
//! corners in the target frame.
//!
//! Target frame (OpenCV's object points): origin at the first inner corner, x along a
//! row of corners, y down the columns, z into the board. Inner corner `(i, j)` lies at
//! `(i * square_size, j * square_size, 0)` and has id `j * cols + i`.

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
}

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
        }
    }

    /// Corners in the target frame, by id.
    pub fn object_points(&self) -> Vec<Point3<f64>> {
        match self {
            Self::Chessboard(board) => board.object_points(),
            Self::Charuco(board) => board.object_points(),
        }
    }

    /// Side of one square, metres.
    pub fn square_size(&self) -> f64 {
        match self {
            Self::Chessboard(board) => board.square_size,
            Self::Charuco(board) => board.square_size,
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
            "pattern: charuco\nsquares_x: 7\nsquares_y: 5\nsquare_size: 0.04\n\
             marker_size: 0.05\ndictionary: DICT_5X5_100\n",
        ] {
            assert!(Target::from_yaml_str(bad).is_err(), "accepted {bad:?}");
        }
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
