//! How fast the board moves between two offered frames: the mean image motion of the
//! corners both frames detected, in pixels per second (ROS camera_calibration's
//! `is_slow_moving` measures the same mean per frame; per second it does not depend on
//! the frame rate).

use stereocal_msgs::builtin_interfaces::Time;
use stereocal_vision::board::Detection;

/// Frames further apart than this, seconds, are not compared: the board may have been
/// put down and picked up in between.
pub const MAX_INTERVAL: f64 = 1.0;

/// Mean speed of the corners in `current` (at `stamp`) since `previous` (at
/// `previous_stamp`), pixels per second, over the corner ids both detected. `None` when
/// the frames are not in order, are [`MAX_INTERVAL`] or more apart, or share no corner.
pub fn board_speed(
    previous: &Detection,
    previous_stamp: Time,
    current: &Detection,
    stamp: Time,
) -> Option<f64> {
    let interval = (stamp.as_nanos() - previous_stamp.as_nanos()) as f64 * 1e-9;
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
        let t0 = Time::from_nanos(5_000_000_000);
        let t1 = Time::from_nanos(5_100_000_000);
        let before = detection(Vector2::zeros(), &[0, 1, 2, 3]);
        let after = detection(Vector2::new(3.0, 4.0), &[0, 1, 2, 3]);
        let speed = board_speed(&before, t0, &after, t1).unwrap();
        assert!((speed - 50.0).abs() < 1e-9, "{speed}");
        // Only the shared ids count.
        let partial = detection(Vector2::new(6.0, 8.0), &[2, 3, 7]);
        let speed = board_speed(&before, t0, &partial, t1).unwrap();
        assert!((speed - 100.0).abs() < 1e-9, "{speed}");
    }

    #[test]
    fn frames_too_far_apart_or_out_of_order_are_not_compared() {
        let before = detection(Vector2::zeros(), &[0, 1]);
        let after = detection(Vector2::new(1.0, 0.0), &[0, 1]);
        let t0 = Time::from_nanos(1_000_000_000);
        assert_eq!(board_speed(&before, t0, &after, t0), None);
        assert_eq!(
            board_speed(&before, t0, &after, Time::from_nanos(2_000_000_000)),
            None
        );
        assert_eq!(
            board_speed(&before, t0, &after, Time::from_nanos(900_000_000)),
            None
        );
        let other = detection(Vector2::zeros(), &[5]);
        assert_eq!(
            board_speed(&before, t0, &other, Time::from_nanos(1_500_000_000)),
            None
        );
    }
}
