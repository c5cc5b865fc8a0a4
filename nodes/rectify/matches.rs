//! Matched points of a stereo pair, for the fundamental matrix of uncalibrated
//! rectification: the target's corners found in left and right images of the same stamp,
//! matched by their point on the target, or correspondences read from a text file.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, bail};
use nalgebra::{Point2, Point3};
use stereocal_msgs::builtin_interfaces::Time;

use crate::calibrate::stage::{CameraFrames, FrameCorners};

/// A left pixel and its match in the right image (pixel centres at integer
/// coordinates).
pub type Match = (Point2<f64>, Point2<f64>);

/// Corners of the target matched between two cameras.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetMatches {
    /// The matched pixels, pair after pair in stamp order.
    pub points: Vec<Match>,
    /// Stereo pairs (left and right frames of one stamp) that gave at least one match.
    pub pairs: usize,
}

/// The corners of the target seen in both a left and a right frame of the same stamp,
/// matched by their point on the target (a ChArUco board partly in view gives the
/// corners both cameras saw).
pub fn match_target_corners(left: &CameraFrames, right: &CameraFrames) -> TargetMatches {
    let right_views = found_views(right);
    let mut points = Vec::new();
    let mut pairs = 0;
    for (stamp, left_view) in found_views(left) {
        let Some(right_view) = right_views.get(&stamp) else {
            continue;
        };
        let before = points.len();
        for (point, left_pixel) in &left_view {
            if let Some((_, right_pixel)) = right_view.iter().find(|(p, _)| p == point) {
                points.push((*left_pixel, *right_pixel));
            }
        }
        pairs += usize::from(points.len() > before);
    }
    TargetMatches { points, pairs }
}

/// Frames of `camera` in which the target was found.
pub fn frames_with_target(camera: &CameraFrames) -> usize {
    camera
        .frames
        .iter()
        .filter(|f| matches!(f.corners, FrameCorners::Found(_)))
        .count()
}

/// Reads a `--points` file: one correspondence a line, `left_x left_y right_x
/// right_y` in pixels (pixel centres at integer coordinates), separated by commas
/// and/or white space; empty lines and lines starting with `#` are skipped.
pub fn read_points_file(path: &Path) -> anyhow::Result<Vec<Match>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_points(&text).with_context(|| format!("--points {}", path.display()))
}

/// The correspondences of a `--points` file's text (see [`read_points_file`]).
pub fn parse_points(text: &str) -> anyhow::Result<Vec<Match>> {
    let mut points = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        let values: Vec<f64> = fields
            .iter()
            .map(|f| f.parse::<f64>())
            .collect::<Result<_, _>>()
            .ok()
            .filter(|v: &Vec<f64>| v.len() == 4 && v.iter().all(|x| x.is_finite()))
            .with_context(|| {
                format!(
                    "line {}: {line:?}: expected four finite numbers, left_x left_y right_x right_y",
                    index + 1
                )
            })?;
        points.push((
            Point2::new(values[0], values[1]),
            Point2::new(values[2], values[3]),
        ));
    }
    if points.is_empty() {
        bail!("no correspondences: expected lines of left_x left_y right_x right_y");
    }
    Ok(points)
}

type CornerView = Vec<(Point3<f64>, Point2<f64>)>;

/// A camera's frames where the target was found: per stamp, each corner's target point
/// and pixel.
fn found_views(camera: &CameraFrames) -> BTreeMap<Time, CornerView> {
    camera
        .frames
        .iter()
        .filter_map(|f| match &f.corners {
            FrameCorners::Found(view) => Some((
                f.stamp,
                view.points_in_target
                    .iter()
                    .copied()
                    .zip(view.pixels.iter().copied())
                    .collect(),
            )),
            FrameCorners::Unusable(_) => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::stage::Frame;
    use stereocal_vision::calib::View;

    #[test]
    fn a_points_file_takes_commas_spaces_and_comments() {
        let points =
            parse_points("# left_x left_y right_x right_y\n\n1, 2, 3, 4\n5 6\t7,8\n").unwrap();
        assert_eq!(
            points,
            vec![
                (Point2::new(1.0, 2.0), Point2::new(3.0, 4.0)),
                (Point2::new(5.0, 6.0), Point2::new(7.0, 8.0)),
            ]
        );
    }

    #[test]
    fn a_bad_points_file_names_the_line() {
        for (text, expected) in [
            ("1 2 3 4\n1 2 3\n", "line 2"),
            ("1 2 3 4\n1 2 3 4 5\n", "line 2"),
            ("1 2 3 nan\n", "line 1"),
            ("1 2 x 4\n", "line 1"),
            ("# nothing\n", "no correspondences"),
        ] {
            let e = format!("{:#}", parse_points(text).unwrap_err());
            assert!(e.contains(expected), "{text:?}: {e}");
        }
    }

    /// Corners seen in one frame: each one's x on the target, and its pixel.
    type Seen = Vec<(f64, Point2<f64>)>;

    fn camera(frames: Vec<(i32, Seen)>) -> CameraFrames {
        CameraFrames {
            name: "camera".to_owned(),
            width: 640,
            height: 480,
            frames: frames
                .into_iter()
                .map(|(sec, corners)| Frame {
                    stamp: Time { sec, nanosec: 0 },
                    corners: if corners.is_empty() {
                        FrameCorners::Unusable("no board".to_owned())
                    } else {
                        FrameCorners::Found(View {
                            points_in_target: corners
                                .iter()
                                .map(|(x, _)| Point3::new(*x, 0.0, 0.0))
                                .collect(),
                            pixels: corners.iter().map(|(_, p)| *p).collect(),
                        })
                    },
                })
                .collect(),
        }
    }

    #[test]
    fn corners_match_by_stamp_and_target_point() {
        let p = |x: f64| Point2::new(x, x);
        let left = camera(vec![
            (1, vec![(0.0, p(1.0)), (0.1, p(2.0)), (0.2, p(3.0))]),
            (2, vec![(0.0, p(4.0))]),
            (3, vec![(0.0, p(5.0))]),
        ]);
        let right = camera(vec![
            (1, vec![(0.2, p(13.0)), (0.0, p(11.0))]),
            (2, vec![]),
            (4, vec![(0.0, p(15.0))]),
        ]);
        let matched = match_target_corners(&left, &right);
        assert_eq!(matched.pairs, 1);
        assert_eq!(matched.points, vec![(p(1.0), p(11.0)), (p(3.0), p(13.0))]);
        assert_eq!(frames_with_target(&left), 3);
        assert_eq!(frames_with_target(&right), 2);
    }
}
