//! How fast the board moves between two offered frames: the mean image motion of the
//! corners both frames detected, in pixels per second (ROS camera_calibration's
//! `is_slow_moving` measures the same mean per frame; per second it does not depend on
//! the frame rate).

use crate::board::Detection;

/// Frames further apart than this, seconds, are not compared: the board may have been
/// put down and picked up in between.
pub const MAX_INTERVAL: f64 = 1.0;

/// Mean speed of the corners in `current` since `previous`, taken `interval` seconds
/// earlier, pixels per second, over the corner ids both detected. `None` when the frames
/// are not in order, are [`MAX_INTERVAL`] or more apart, or share no corner.
pub fn board_speed(previous: &Detection, current: &Detection, interval: f64) -> Option<f64> {
    if !(interval > 0.0 && interval < MAX_INTERVAL) {
        return None;
    }
    let mut total = 0.0;
    let mut count = 0usize;
    for (id, corner) in current.ids.iter().zip(&current.corners) {
        let Some(k) = previous.ids.iter().position(|p| p == id) else {
            continue;
        };
        let Some(before) = previous.corners.get(k) else {
            continue;
        };
        total += (corner - before).norm();
        count += 1;
    }
    (count > 0).then(|| total / count as f64 / interval)
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point2, Vector2};

    use super::*;

    fn detection(shift: Vector2<f64>, ids: &[usize]) -> Detection {
        Detection {
            corners: ids
                .iter()
                .map(|&id| Point2::new(10.0 * id as f64, 5.0) + shift)
                .collect(),
            ids: ids.to_vec(),
            square_px: 10.0,
        }
    }

    #[test]
    fn speed_is_mean_corner_motion_over_the_interval() {
        let before = detection(Vector2::zeros(), &[0, 1, 2, 3]);
        let after = detection(Vector2::new(3.0, 4.0), &[0, 1, 2, 3]);
        let speed = board_speed(&before, &after, 0.1).unwrap();
        assert!((speed - 50.0).abs() < 1e-9, "{speed}");
        // Only the shared ids count.
        let partial = detection(Vector2::new(6.0, 8.0), &[2, 3, 7]);
        let speed = board_speed(&before, &partial, 0.1).unwrap();
        assert!((speed - 100.0).abs() < 1e-9, "{speed}");
    }

    #[test]
    fn frames_too_far_apart_or_out_of_order_are_not_compared() {
        let before = detection(Vector2::zeros(), &[0, 1]);
        let after = detection(Vector2::new(1.0, 0.0), &[0, 1]);
        assert_eq!(board_speed(&before, &after, 0.0), None);
        assert_eq!(board_speed(&before, &after, 1.0), None);
        assert_eq!(board_speed(&before, &after, -0.1), None);
        let other = detection(Vector2::zeros(), &[5]);
        assert_eq!(board_speed(&before, &other, 0.5), None);
    }
}
