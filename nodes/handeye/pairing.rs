//! Robot poses at the stamps of target poses: interpolated between the robot poses
//! either side of the stamp, never the latest one and never extrapolated.

use nalgebra::Isometry3;

/// A robot's stamped poses, `base_from_tool`, in stamp order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RobotTrack {
    poses: Vec<(f64, Isometry3<f64>)>,
}

/// Stamps closer than this (seconds) are the same instant.
const SAME_STAMP_S: f64 = 1e-9;

impl RobotTrack {
    /// The track of `(stamp seconds, base_from_tool)` poses, in any order.
    pub fn new(mut poses: Vec<(f64, Isometry3<f64>)>) -> Self {
        poses.sort_by(|a, b| a.0.total_cmp(&b.0));
        Self { poses }
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// `base_from_tool` at `stamp`: a pose with that stamp, or the interpolation
    /// (straight line, constant-rate rotation) between the poses either side of it when
    /// both are within `max_gap` seconds. The error says how far the nearest pose is.
    pub fn at(&self, stamp: f64, max_gap: f64) -> Result<Isometry3<f64>, String> {
        let after = self
            .poses
            .partition_point(|(t, _)| *t < stamp - SAME_STAMP_S);
        if let Some((t, pose)) = self.poses.get(after)
            && (t - stamp).abs() <= SAME_STAMP_S
        {
            return Ok(*pose);
        }
        let before = after.checked_sub(1).and_then(|i| self.poses.get(i));
        let next = self.poses.get(after);
        if let (Some((t0, p0)), Some((t1, p1))) = (before, next)
            && stamp - t0 <= max_gap
            && t1 - stamp <= max_gap
        {
            let s = (stamp - t0) / (t1 - t0);
            let translation = p0.translation.vector.lerp(&p1.translation.vector, s);
            let rotation = p0.rotation.slerp(&p1.rotation, s);
            return Ok(Isometry3::from_parts(translation.into(), rotation));
        }
        let nearest = [before, next]
            .into_iter()
            .flatten()
            .map(|(t, _)| (t - stamp).abs())
            .fold(f64::INFINITY, f64::min);
        Err(if nearest.is_finite() {
            format!(
                "no robot pose on both sides of the stamp within {max_gap} s (the nearest is \
                 {nearest:.3} s away)"
            )
        } else {
            "no robot pose at all".to_owned()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn interpolates_between_the_poses_either_side_and_never_extrapolates() {
        let a = Isometry3::new(Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.0, 0.0, 0.0));
        let b = Isometry3::new(Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, 0.0, 0.2));
        let track = RobotTrack::new(vec![(11.0, b), (10.0, a)]);
        assert_eq!(track.at(10.0, 0.0).unwrap(), a);
        let middle = track.at(10.5, 0.6).unwrap();
        assert!((middle.translation.vector.x - 0.5).abs() < 1e-12);
        assert!((middle.rotation.angle() - 0.1).abs() < 1e-12);
        let error = track.at(10.5, 0.4).unwrap_err();
        assert!(error.contains("0.500 s away"), "{error}");
        assert!(track.at(11.2, 10.0).is_err(), "no extrapolation");
        assert!(RobotTrack::default().at(1.0, 1.0).is_err());
    }
}
