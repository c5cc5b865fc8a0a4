//! The pose stream of a robot in a hand-eye session, as its driver publishes it: the arm
//! stands still at each frame's pose for a while before and after the frame (where an
//! operator or a script takes the sample) and moves at a constant rate in between, its
//! pose published at a fixed rate on a grid of stamps.

use nalgebra::Isometry3;

/// How the robot moves between the frames of a session.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotMotion {
    /// Poses published per second.
    pub rate_hz: f64,
    /// How long the robot stands still before each frame, seconds.
    pub dwell_s: f64,
    /// How long it stays after each frame before moving on, seconds.
    pub hold_s: f64,
}

impl RobotMotion {
    /// 100 poses a second, still for 1 s before each frame and 0.2 s after: room for a
    /// stillness check of up to a second before each frame.
    pub const DEFAULT: Self = Self {
        rate_hz: 100.0,
        dwell_s: 1.0,
        hold_s: 0.2,
    };

    /// The robot's pose at every stamp of its stream, from `dwell_s` before the first
    /// frame to `hold_s` after the last, for `frames` given as `(stamp seconds, pose)` in
    /// stamp order. Between two frames closer than `dwell_s + hold_s` the robot jumps at
    /// the midpoint instead of moving.
    pub fn stream(&self, frames: &[(f64, Isometry3<f64>)]) -> Vec<(f64, Isometry3<f64>)> {
        let (Some(first), Some(last)) = (frames.first(), frames.last()) else {
            return Vec::new();
        };
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Vec::new();
        }
        let start = ((first.0 - self.dwell_s) * self.rate_hz).ceil() as i64;
        let end = ((last.0 + self.hold_s) * self.rate_hz).floor() as i64;
        (start..=end)
            .map(|k| {
                let t = k as f64 / self.rate_hz;
                (t, self.pose_at(frames, t))
            })
            .collect()
    }

    fn pose_at(&self, frames: &[(f64, Isometry3<f64>)], t: f64) -> Isometry3<f64> {
        let next = frames.partition_point(|(stamp, _)| *stamp < t);
        let (Some((t0, p0)), Some((t1, p1))) = (
            next.checked_sub(1).and_then(|i| frames.get(i)),
            frames.get(next),
        ) else {
            // Before the first frame or after the last: standing at it.
            return frames[next.min(frames.len() - 1)].1;
        };
        let leave = t0 + self.hold_s;
        let arrive = t1 - self.dwell_s;
        if arrive <= leave {
            return if t < 0.5 * (t0 + t1) { *p0 } else { *p1 };
        }
        if t <= leave {
            return *p0;
        }
        if t >= arrive {
            return *p1;
        }
        let s = (t - leave) / (arrive - leave);
        Isometry3::from_parts(
            p0.translation.vector.lerp(&p1.translation.vector, s).into(),
            p0.rotation.slerp(&p1.rotation, s),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn stands_still_around_each_frame_and_moves_between() {
        let a = Isometry3::new(Vector3::new(0.4, 0.0, 0.3), Vector3::new(0.0, 0.0, 0.0));
        let b = Isometry3::new(Vector3::new(0.5, 0.1, 0.3), Vector3::new(0.0, 0.0, 0.5));
        let stream = RobotMotion::DEFAULT.stream(&[(10.0, a), (12.0, b)]);
        assert_eq!(stream.len(), 321);
        assert!((stream[0].0 - 9.0).abs() < 1e-9);
        assert!((stream[320].0 - 12.2).abs() < 1e-9);
        for (t, pose) in &stream {
            if (9.0..=10.2).contains(t) {
                assert_eq!(*pose, a, "{t}");
            } else if (11.0..=12.2).contains(t) {
                assert_eq!(*pose, b, "{t}");
            } else {
                assert_ne!(*pose, a, "{t}");
                assert_ne!(*pose, b, "{t}");
            }
        }
        let middle = stream
            .iter()
            .find(|(t, _)| (t - 10.6).abs() < 1e-9)
            .unwrap()
            .1;
        assert!((middle.translation.vector.x - 0.45).abs() < 1e-9);
        assert!((middle.rotation.angle() - 0.25).abs() < 1e-9);
    }
}
