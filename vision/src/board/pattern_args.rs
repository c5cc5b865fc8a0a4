//! Targets from a command line in ROS camera_calibration's style:
//! `--pattern chessboard --size 9x6 --square 0.025`, for ChArUco
//! `--pattern charuco --size 7x5 --square 0.04 --charuco_marker_size 0.03
//! --aruco_dict 5x5_100`, for circle grids `--pattern acircles --size 4x11 --square
//! 0.02` (as in camera_calibration, `--size` counts squares of a ChArUco board, inner
//! corners of a chessboard, circles per row and rows of a circle grid). [`target_from_parts`] builds the same
//! targets from values parsed elsewhere (a node's parameters).

use super::BoardError;
use super::target::{ArucoDictionary, Charuco, Chessboard, CircleGrid, CircleLayout, Target};

/// The target options of a command line, before they are checked.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PatternArgs {
    /// `--pattern` / `-p`: `chessboard` (the default), `charuco`, `circles` or
    /// `acircles`.
    pub pattern: Option<String>,
    /// `--size` / `-s`: `COLSxROWS`.
    pub size: Option<String>,
    /// `--square` / `-q`: square side, metres.
    pub square: Option<String>,
    /// `--charuco_marker_size` / `-m`: marker side, metres.
    pub marker_size: Option<String>,
    /// `--aruco_dict` / `-d`: dictionary (`4x4_50`, `DICT_5X5_100`, `aruco_orig`);
    /// camera_calibration's default is `4x4_50`.
    pub aruco_dict: Option<String>,
}

impl PatternArgs {
    /// Collects the target options from `args` (`--size 9x6` or `--size=9x6`, long or
    /// short names). Any other argument is an error that names it.
    pub fn parse<I, S>(args: I) -> Result<Self, BoardError>
    where
        I: IntoIterator<Item = S>,
        S: AsRef<str>,
    {
        let mut parsed = Self::default();
        let mut args = args.into_iter();
        while let Some(arg) = args.next() {
            let arg = arg.as_ref();
            let (name, inline) = match arg.split_once('=') {
                Some((name, value)) if name.starts_with('-') => (name, Some(value.to_string())),
                _ => (arg, None),
            };
            let slot = match name {
                "--pattern" | "-p" => &mut parsed.pattern,
                "--size" | "-s" => &mut parsed.size,
                "--square" | "-q" => &mut parsed.square,
                "--charuco_marker_size" | "-m" => &mut parsed.marker_size,
                "--aruco_dict" | "-d" => &mut parsed.aruco_dict,
                _ => {
                    return Err(BoardError::Args(format!(
                        "unknown argument {arg:?}: expected --pattern, --size, --square, \
                         --charuco_marker_size or --aruco_dict"
                    )));
                }
            };
            let value = match inline {
                Some(value) => value,
                None => args
                    .next()
                    .map(|v| v.as_ref().to_string())
                    .ok_or_else(|| BoardError::Args(format!("{name} needs a value")))?,
            };
            *slot = Some(value);
        }
        Ok(parsed)
    }

    /// The target these options describe. An error about one option names it.
    pub fn target(&self) -> Result<Target, BoardError> {
        let size = self
            .size
            .as_deref()
            .ok_or_else(|| BoardError::Args("--size COLSxROWS is required".to_string()))?;
        let size = parse_size(size)?;
        let square = self
            .square
            .as_deref()
            .ok_or_else(|| BoardError::Args("--square METRES is required".to_string()))
            .and_then(|s| parse_metres("--square", s))?;
        let pattern = self.pattern.as_deref().unwrap_or("chessboard");
        if pattern != "charuco" && (self.marker_size.is_some() || self.aruco_dict.is_some()) {
            return Err(BoardError::Args(
                "--charuco_marker_size and --aruco_dict only apply to --pattern charuco"
                    .to_string(),
            ));
        }
        let marker_size = self
            .marker_size
            .as_deref()
            .map(|s| parse_metres("--charuco_marker_size", s))
            .transpose()?;
        target_from_parts(
            pattern,
            size,
            square,
            marker_size,
            self.aruco_dict.as_deref(),
        )
        .map_err(|(part, e)| BoardError::Args(format!("{}: {e}", option_name(part))))
    }
}

/// The part of a target's description that an error of [`target_from_parts`] is
/// about, for the caller to name as its command-line option or parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetPart {
    /// The pattern's name.
    Pattern,
    /// The board's size, `(COLS, ROWS)`.
    Size,
    /// The square side.
    Square,
    /// The ChArUco marker side.
    MarkerSize,
    /// The ArUco dictionary's name.
    Dictionary,
}

/// The target `pattern` (`chessboard`, `charuco`, `circles` or `acircles`) describes.
/// `(cols, rows)` counts inner corners of a chessboard, squares of a ChArUco board, and
/// circles per row and rows of a circle grid (as ROS camera_calibration does);
/// `square` is the square side (a circle grid's spacing) in metres. A ChArUco board
/// also needs `marker_size` (metres, smaller than `square`) and takes `dictionary`
/// (camera_calibration's default `4x4_50` when `None`); other targets ignore both.
/// An error says which part of the description is wrong.
pub fn target_from_parts(
    pattern: &str,
    (cols, rows): (usize, usize),
    square: f64,
    marker_size: Option<f64>,
    dictionary: Option<&str>,
) -> Result<Target, (TargetPart, BoardError)> {
    let wrong = |part, message: String| (part, BoardError::Args(message));
    if !(square.is_finite() && square > 0.0) {
        return Err(wrong(
            TargetPart::Square,
            format!("{square} is not a positive side length in metres (required, e.g. 0.025)"),
        ));
    }
    match pattern {
        "chessboard" => Chessboard::new(cols, rows, square)
            .map(Target::Chessboard)
            .map_err(|e| (TargetPart::Size, e)),
        "circles" => CircleGrid::new(cols, rows, square, CircleLayout::Symmetric)
            .map(Target::Circles)
            .map_err(|e| (TargetPart::Size, e)),
        "acircles" => CircleGrid::new(cols, rows, square, CircleLayout::Asymmetric)
            .map(Target::Acircles)
            .map_err(|e| (TargetPart::Size, e)),
        "charuco" => {
            let marker_size = marker_size.ok_or_else(|| {
                wrong(
                    TargetPart::MarkerSize,
                    "a ChArUco board needs the marker side in metres".to_string(),
                )
            })?;
            if !(marker_size.is_finite() && marker_size > 0.0 && marker_size < square) {
                return Err(wrong(
                    TargetPart::MarkerSize,
                    format!(
                        "{marker_size} is not a marker side in metres between 0 and square \
                         ({square})"
                    ),
                ));
            }
            let name = dictionary.unwrap_or("4x4_50");
            let dictionary = ArucoDictionary::from_name(name).ok_or_else(|| {
                wrong(
                    TargetPart::Dictionary,
                    format!(
                        "unknown ArUco dictionary {name:?}: expected one of 4x4_50 .. 7x7_1000 \
                         or aruco_orig"
                    ),
                )
            })?;
            let board = Charuco {
                squares_x: cols,
                squares_y: rows,
                square_size: square,
                marker_size,
                dictionary,
            };
            board.validate().map_err(|e| (TargetPart::Size, e))?;
            Ok(Target::Charuco(board))
        }
        other => Err(wrong(
            TargetPart::Pattern,
            format!(
                "unsupported pattern {other:?}: expected chessboard, charuco, circles or \
                 acircles"
            ),
        )),
    }
}

/// The command-line option that sets `part`.
fn option_name(part: TargetPart) -> &'static str {
    match part {
        TargetPart::Pattern => "--pattern",
        TargetPart::Size => "--size",
        TargetPart::Square => "--square",
        TargetPart::MarkerSize => "--charuco_marker_size",
        TargetPart::Dictionary => "--aruco_dict",
    }
}

/// Parses the target options of `args` into a target (see [`PatternArgs`]).
pub fn parse_pattern_args<I, S>(args: I) -> Result<Target, BoardError>
where
    I: IntoIterator<Item = S>,
    S: AsRef<str>,
{
    PatternArgs::parse(args)?.target()
}

/// Parses `COLSxROWS` (`9x6`; `X` and `*` also accepted).
pub fn parse_size(text: &str) -> Result<(usize, usize), BoardError> {
    let bad = || BoardError::Args(format!("board size {text:?} is not COLSxROWS, e.g. 9x6"));
    let (cols, rows) = text.trim().split_once(['x', 'X', '*']).ok_or_else(bad)?;
    let cols = cols.trim().parse().map_err(|_| bad())?;
    let rows = rows.trim().parse().map_err(|_| bad())?;
    Ok((cols, rows))
}

fn parse_metres(name: &str, text: &str) -> Result<f64, BoardError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| {
            BoardError::Args(format!(
                "{name} {text:?} is not a positive number of metres"
            ))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_style_chessboard() {
        let target = parse_pattern_args([
            "--pattern",
            "chessboard",
            "--size",
            "9x6",
            "--square",
            "0.025",
        ])
        .unwrap();
        assert_eq!(
            target,
            Target::Chessboard(Chessboard::new(9, 6, 0.025).unwrap())
        );
        assert_eq!(
            parse_pattern_args(["-s", "8x5", "-q=0.03"]).unwrap(),
            Target::Chessboard(Chessboard::new(8, 5, 0.03).unwrap())
        );
    }

    #[test]
    fn ros_style_charuco() {
        let target = parse_pattern_args([
            "--pattern=charuco",
            "--size",
            "7x5",
            "--square",
            "0.04",
            "--charuco_marker_size",
            "0.03",
        ])
        .unwrap();
        let Target::Charuco(board) = target else {
            panic!("not a ChArUco board");
        };
        assert_eq!((board.cols(), board.rows()), (6, 4));
        assert_eq!(board.dictionary, ArucoDictionary::Dict4x4_50);
    }

    #[test]
    fn ros_style_circle_grids() {
        let target = parse_pattern_args([
            "--pattern",
            "acircles",
            "--size",
            "4x11",
            "--square",
            "0.02",
        ])
        .unwrap();
        assert_eq!(
            target,
            Target::Acircles(CircleGrid::new(4, 11, 0.02, CircleLayout::Asymmetric).unwrap())
        );
        let target = parse_pattern_args(["-p", "circles", "-s", "7x5", "-q", "0.03"]).unwrap();
        assert_eq!(target.object_points().len(), 35);
    }

    #[test]
    fn bad_command_lines_say_what_is_wrong() {
        for (args, needle) in [
            (vec!["--size", "9by6", "--square", "0.025"], "COLSxROWS"),
            (vec!["--size", "9x6"], "--square"),
            (vec!["--size", "9x6", "--square", "-2"], "positive"),
            (vec!["--size", "9x6", "--square"], "needs a value"),
            (
                vec!["--pattern", "dots", "--size", "9x6", "--square", "0.02"],
                "dots",
            ),
            (
                vec!["--pattern", "acircles", "--size", "4x2", "--square", "0.02"],
                "3 rows",
            ),
            (
                vec![
                    "--pattern",
                    "circles",
                    "-s",
                    "4x5",
                    "-q",
                    "0.02",
                    "-m",
                    "0.01",
                ],
                "only apply to --pattern charuco",
            ),
            (
                vec!["--size", "9x6", "--square", "0.02", "--fps", "3"],
                "--fps",
            ),
            (vec!["--size", "1x6", "--square", "0.02"], "2x2"),
            (
                vec!["--pattern", "charuco", "--size", "7x5", "--square", "0.04"],
                "marker",
            ),
        ] {
            let error = parse_pattern_args(&args).unwrap_err().to_string();
            assert!(error.contains(needle), "{args:?}: {error}");
        }
    }

    #[test]
    fn target_errors_name_the_wrong_part() {
        for (pattern, size, square, marker, dictionary, part) in [
            ("dots", (9, 6), 0.02, None, None, TargetPart::Pattern),
            ("acircles", (1, 6), 0.02, None, None, TargetPart::Size),
            ("chessboard", (1, 6), 0.02, None, None, TargetPart::Size),
            ("charuco", (2, 5), 0.04, Some(0.03), None, TargetPart::Size),
            ("chessboard", (9, 6), -1.0, None, None, TargetPart::Square),
            (
                "charuco",
                (7, 5),
                f64::NAN,
                Some(0.03),
                None,
                TargetPart::Square,
            ),
            ("charuco", (7, 5), 0.04, None, None, TargetPart::MarkerSize),
            (
                "charuco",
                (7, 5),
                0.04,
                Some(0.04),
                None,
                TargetPart::MarkerSize,
            ),
            (
                "charuco",
                (7, 5),
                0.04,
                Some(0.03),
                Some("9x9_1"),
                TargetPart::Dictionary,
            ),
        ] {
            let result = target_from_parts(pattern, size, square, marker, dictionary);
            assert_eq!(
                result.map_err(|(part, _)| part),
                Err(part),
                "{pattern} {size:?} {square} {marker:?} {dictionary:?}"
            );
        }
        assert_eq!(
            target_from_parts("chessboard", (9, 6), 0.025, Some(0.5), Some("bad")),
            Ok(Target::Chessboard(Chessboard::new(9, 6, 0.025).unwrap()))
        );
        let error = parse_pattern_args(["--pattern=charuco", "-s", "7x5", "-q", "0.04"])
            .unwrap_err()
            .to_string();
        assert!(error.starts_with("--charuco_marker_size: "), "{error}");
    }
}
