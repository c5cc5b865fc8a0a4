//! Targets from a command line in ROS camera_calibration's style:
//! `--pattern chessboard --size 9x6 --square 0.025`, or for ChArUco
//! `--pattern charuco --size 7x5 --square 0.04 --charuco_marker_size 0.03
//! --aruco_dict 5x5_100` (for ChArUco, as in camera_calibration, `--size` counts
//! squares; for a chessboard, inner corners).

use super::BoardError;
use super::target::{ArucoDictionary, Charuco, Chessboard, Target};

/// The target options of a command line, before they are checked.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PatternArgs {
    /// `--pattern` / `-p`: `chessboard` (the default) or `charuco`.
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

    /// The target these options describe.
    pub fn target(&self) -> Result<Target, BoardError> {
        let size = self
            .size
            .as_deref()
            .ok_or_else(|| BoardError::Args("--size COLSxROWS is required".to_string()))?;
        let (cols, rows) = parse_size(size)?;
        let square = self
            .square
            .as_deref()
            .ok_or_else(|| BoardError::Args("--square METRES is required".to_string()))
            .and_then(|s| parse_metres("--square", s))?;
        match self.pattern.as_deref().unwrap_or("chessboard") {
            "chessboard" => {
                if self.marker_size.is_some() || self.aruco_dict.is_some() {
                    return Err(BoardError::Args(
                        "--charuco_marker_size and --aruco_dict only apply to --pattern charuco"
                            .to_string(),
                    ));
                }
                Ok(Target::Chessboard(Chessboard::new(cols, rows, square)?))
            }
            "charuco" => {
                let marker_size = self
                    .marker_size
                    .as_deref()
                    .ok_or_else(|| {
                        BoardError::Args(
                            "--pattern charuco needs --charuco_marker_size METRES".to_string(),
                        )
                    })
                    .and_then(|s| parse_metres("--charuco_marker_size", s))?;
                let name = self.aruco_dict.as_deref().unwrap_or("4x4_50");
                let dictionary = ArucoDictionary::from_name(name).ok_or_else(|| {
                    BoardError::Args(format!(
                        "unknown ArUco dictionary {name:?}: expected one of 4x4_50 .. 7x7_1000 \
                         or aruco_orig"
                    ))
                })?;
                let board = Charuco {
                    squares_x: cols,
                    squares_y: rows,
                    square_size: square,
                    marker_size,
                    dictionary,
                };
                board.validate()?;
                Ok(Target::Charuco(board))
            }
            other => Err(BoardError::Args(format!(
                "unsupported pattern {other:?}: expected chessboard or charuco"
            ))),
        }
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
    fn bad_command_lines_say_what_is_wrong() {
        for (args, needle) in [
            (vec!["--size", "9by6", "--square", "0.025"], "COLSxROWS"),
            (vec!["--size", "9x6"], "--square"),
            (vec!["--size", "9x6", "--square", "-2"], "positive"),
            (vec!["--size", "9x6", "--square"], "needs a value"),
            (
                vec!["--pattern", "circles", "--size", "9x6", "--square", "0.02"],
                "circles",
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
}
