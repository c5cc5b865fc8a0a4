//! The robot's pose in a live session: `base_from_tool` received on a PoseStamped topic
//! or in `/tf` and `/tf_static`, looked up at a target pose's stamp (interpolated,
//! never the latest), and whether the robot stood still before that stamp. Memory stays
//! bounded: poses older than [`HISTORY_S`] before the newest are forgotten, and a stamp
//! that jumps back (a replay starting over) starts the history again.

use nalgebra::Isometry3;
use stereocal_msgs::geometry_msgs::PoseStamped;
use stereocal_msgs::tf2_msgs::TFMessage;

use crate::convert::isometry_from_pose_msg;
use crate::pose::record::seconds;
use crate::tf_buffer::{PoseTrack, TfBuffer};

/// How much history is kept before the newest pose, seconds (tf2's default cache).
pub const HISTORY_S: f64 = 10.0;
/// Longest step between the instants a stillness check looks at, seconds.
const STILLNESS_STEP_S: f64 = 0.01;
/// Most instants a stillness check looks at.
const MAX_STILLNESS_INSTANTS: usize = 200;

/// How far the robot moved over a time window: the largest departure from its pose at
/// the window's end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Largest rotation, radians.
    pub rotation_rad: f64,
    /// Largest translation, metres.
    pub translation_m: f64,
}

/// Where the robot's poses come from, and what has been received of them.
#[derive(Clone, Debug)]
pub enum RobotPoses {
    /// A PoseStamped topic of `base_from_tool`.
    Topic {
        /// The poses received.
        track: PoseTrack,
        /// The frame of the poses (the base frame), as the newest message names it.
        base_frame: Option<String>,
        /// Newest stamp received, seconds.
        newest: Option<f64>,
    },
    /// `/tf` and `/tf_static`, looked up from `base` to `tool`.
    Tf {
        /// The transforms received.
        buffer: TfBuffer,
        /// The robot's base frame.
        base: String,
        /// The robot's tool frame.
        tool: String,
        /// Newest `/tf` stamp received, seconds.
        newest: Option<f64>,
    },
}

impl RobotPoses {
    /// Poses from a PoseStamped topic.
    pub fn topic() -> Self {
        Self::Topic {
            track: PoseTrack::default(),
            base_frame: None,
            newest: None,
        }
    }

    /// Poses looked up in TF from `base` to `tool`.
    pub fn tf(base: &str, tool: &str) -> Self {
        Self::Tf {
            buffer: TfBuffer::default(),
            base: base.to_owned(),
            tool: tool.to_owned(),
            newest: None,
        }
    }

    /// Keeps a pose of the robot's topic. Errors: a pose that is not a rotation and a
    /// translation, or poses on a TF source.
    pub fn insert_pose(&mut self, message: &PoseStamped) -> Result<(), String> {
        let Self::Topic {
            track,
            base_frame,
            newest,
        } = self
        else {
            return Err("robot poses come from TF, not from a topic".into());
        };
        let stamp = seconds(&message.header.stamp);
        let pose = isometry_from_pose_msg(&message.pose)?;
        if starts_over(newest, stamp) {
            *track = PoseTrack::default();
        }
        track.insert(stamp, pose);
        track.forget_before(newest.unwrap_or(stamp) - HISTORY_S);
        *base_frame = Some(message.header.frame_id.clone());
        Ok(())
    }

    /// Keeps the transforms of a `/tf` (`is_static` false) or `/tf_static` message;
    /// returns what was wrong with those not kept.
    pub fn insert_tf(&mut self, message: &TFMessage, is_static: bool) -> Vec<String> {
        let Self::Tf { buffer, newest, .. } = self else {
            return vec!["robot poses come from a topic, not from TF".into()];
        };
        let mut errors = Vec::new();
        for transform in &message.transforms {
            if !is_static && starts_over(newest, seconds(&transform.header.stamp)) {
                buffer.forget_stamped();
            }
            if let Err(e) = buffer.insert(transform, is_static) {
                errors.push(e.to_string());
            }
        }
        if let Some(newest) = newest {
            buffer.forget_before(*newest - HISTORY_S);
        }
        errors
    }

    /// The robot's base frame as known: from the topic's newest message when the poses
    /// come from a topic.
    pub fn base_frame(&self) -> Option<&str> {
        match self {
            Self::Topic { base_frame, .. } => base_frame.as_deref(),
            Self::Tf { base, .. } => Some(base),
        }
    }

    /// Newest stamp received, seconds.
    pub fn newest(&self) -> Option<f64> {
        match self {
            Self::Topic { newest, .. } | Self::Tf { newest, .. } => *newest,
        }
    }

    /// `base_from_tool` at `stamp` (seconds), interpolated between poses within
    /// `max_gap` seconds on both sides, or why there is none.
    pub fn base_from_tool(&self, stamp: f64, max_gap: f64) -> Result<Isometry3<f64>, String> {
        match self {
            Self::Topic { track, .. } => track.at(stamp, max_gap),
            Self::Tf {
                buffer, base, tool, ..
            } => buffer
                .lookup(base, tool, stamp, max_gap)
                .map_err(|e| e.to_string()),
        }
    }

    /// How far the robot moved over the `window` seconds before `stamp`, or why that is
    /// not known (no pose for part of the window).
    pub fn motion_before(&self, stamp: f64, window: f64, max_gap: f64) -> Result<Motion, String> {
        let end = self.base_from_tool(stamp, max_gap)?;
        let steps = ((window / STILLNESS_STEP_S).ceil() as usize).clamp(1, MAX_STILLNESS_INSTANTS);
        let mut motion = Motion {
            rotation_rad: 0.0,
            translation_m: 0.0,
        };
        for k in 0..steps {
            let at = stamp - window * (1.0 - k as f64 / steps as f64);
            let pose = self
                .base_from_tool(at, max_gap)
                .map_err(|e| format!("the robot's pose {:.3} s before: {e}", stamp - at))?;
            let end_from_pose = end.inverse() * pose;
            motion.rotation_rad = motion.rotation_rad.max(end_from_pose.rotation.angle());
            motion.translation_m = motion
                .translation_m
                .max(end_from_pose.translation.vector.norm());
        }
        Ok(motion)
    }
}

/// Records `stamp` as the newest; whether it jumped back by more than the history, so
/// what is held belongs to another run of time.
fn starts_over(newest: &mut Option<f64>, stamp: f64) -> bool {
    let jumped = newest.is_some_and(|n| stamp < n - HISTORY_S);
    if jumped || newest.is_none_or(|n| stamp > n) {
        *newest = Some(stamp);
    }
    jumped
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};
    use stereocal_msgs::builtin_interfaces::Time;
    use stereocal_msgs::geometry_msgs::TransformStamped;
    use stereocal_msgs::std_msgs::Header;

    use crate::convert::{pose_msg, transform_msg};

    fn stamp(t: f64) -> Time {
        Time {
            sec: t.floor() as i32,
            nanosec: ((t - t.floor()) * 1e9).round() as u32,
        }
    }

    /// Start of the poses, seconds.
    const T0: f64 = 100.0;

    fn pose_at(t: f64) -> Isometry3<f64> {
        // Still until 2 s after T0, then turning at 0.1 rad/s and moving at 10 mm/s.
        let moving = (t - T0 - 2.0).max(0.0);
        Isometry3::from_parts(
            Vector3::new(0.4 + 0.01 * moving, 0.0, 0.3).into(),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.1 * moving)),
        )
    }

    #[test]
    fn a_topic_gives_the_pose_at_the_stamp_and_whether_the_robot_was_still() {
        let mut robot = RobotPoses::topic();
        for k in 0..=40 {
            let t = T0 + 0.1 * f64::from(k);
            let message = PoseStamped {
                header: Header {
                    stamp: stamp(t),
                    frame_id: "base".into(),
                },
                pose: pose_msg(&pose_at(t)),
            };
            robot.insert_pose(&message).unwrap();
        }
        assert_eq!(robot.base_frame(), Some("base"));
        assert!((robot.newest().unwrap() - (T0 + 4.0)).abs() < 1e-6);
        let at = robot.base_from_tool(T0 + 3.05, 0.06).unwrap();
        assert!((at.translation.vector.x - pose_at(T0 + 3.05).translation.vector.x).abs() < 1e-9);
        // Never extrapolated.
        assert!(robot.base_from_tool(T0 + 4.05, 0.06).is_err());

        let still = robot.motion_before(T0 + 1.9, 1.0, 0.11).unwrap();
        assert!(
            still.rotation_rad < 1e-9 && still.translation_m < 1e-9,
            "{still:?}"
        );
        let moving = robot.motion_before(T0 + 3.0, 0.5, 0.11).unwrap();
        assert!((moving.rotation_rad - 0.05).abs() < 1e-6, "{moving:?}");
        assert!((moving.translation_m - 0.005).abs() < 1e-3, "{moving:?}");
        // Before the first pose the window is not covered.
        let unknown = robot.motion_before(T0 + 0.5, 1.0, 0.11).unwrap_err();
        assert!(unknown.contains("before"), "{unknown}");

        // A non-unit quaternion is refused by name.
        let mut bad = PoseStamped::default();
        bad.pose.orientation.w = 2.0;
        assert!(robot.insert_pose(&bad).is_err());
        // A stamp far back starts the history again.
        let mut again = PoseStamped::default();
        again.pose.orientation.w = 1.0;
        again.header.stamp = stamp(0.0);
        robot.insert_pose(&again).unwrap();
        assert!(robot.base_from_tool(T0 + 3.0, 0.11).is_err());
    }

    #[test]
    fn tf_chains_are_looked_up_and_history_stays_bounded() {
        let mut robot = RobotPoses::tf("base", "tool");
        let fixed = Isometry3::translation(0.0, 0.0, 0.1);
        let statics = TFMessage {
            transforms: vec![TransformStamped {
                header: Header {
                    stamp: stamp(0.0),
                    frame_id: "flange".into(),
                },
                child_frame_id: "tool".into(),
                transform: transform_msg(&fixed),
            }],
        };
        assert!(robot.insert_tf(&statics, true).is_empty());
        for k in 0..=300 {
            let t = 0.1 * f64::from(k);
            let message = TFMessage {
                transforms: vec![TransformStamped {
                    header: Header {
                        stamp: stamp(t),
                        frame_id: "base".into(),
                    },
                    child_frame_id: "flange".into(),
                    transform: transform_msg(&pose_at(t)),
                }],
            };
            assert!(robot.insert_tf(&message, false).is_empty());
        }
        let at = robot.base_from_tool(25.0, 0.11).unwrap();
        let expected = pose_at(25.0) * fixed;
        assert!((at.translation.vector - expected.translation.vector).norm() < 1e-9);
        // Older than the history: forgotten.
        assert!(robot.base_from_tool(5.0, 0.11).is_err());
        let RobotPoses::Tf { buffer, .. } = &robot else {
            unreachable!()
        };
        assert!(buffer.connects("base", "tool").is_ok());
        // A frame no transform names: said by name, with the frames there are.
        let mut elsewhere = RobotPoses::tf("flange", "camera");
        assert!(elsewhere.insert_tf(&statics, true).is_empty());
        let unknown = elsewhere.base_from_tool(1.0, 0.1).unwrap_err();
        assert!(
            unknown.contains("\"camera\"") && unknown.contains("flange, tool"),
            "{unknown}"
        );
    }
}
