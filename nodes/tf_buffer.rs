//! Transforms at the stamp of the data they are needed for: a [`PoseTrack`] holds one
//! frame's stamped poses in another (a robot's `base_from_tool`, one edge of a TF tree),
//! and a [`TfBuffer`] the trees of `/tf` and `/tf_static`, giving the transform between
//! any two frames of one tree. Both interpolate between the poses either side of the
//! stamp; never the latest pose, never an extrapolation.

use std::collections::HashMap;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use stereocal_msgs::geometry_msgs::TransformStamped;
use thiserror::Error;

use crate::pose::record::seconds;

/// One frame's stamped poses in another, in stamp order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseTrack {
    poses: Vec<(f64, Isometry3<f64>)>,
}

/// Stamps closer than this (seconds) are the same instant.
const SAME_STAMP_S: f64 = 1e-9;

impl PoseTrack {
    /// The track of `(stamp seconds, pose)` poses, in any order.
    pub fn new(mut poses: Vec<(f64, Isometry3<f64>)>) -> Self {
        poses.sort_by(|a, b| a.0.total_cmp(&b.0));
        Self { poses }
    }

    /// Adds a pose, keeping stamp order; one with the stamp of a pose already held
    /// replaces it.
    pub fn insert(&mut self, stamp: f64, pose: Isometry3<f64>) {
        let at = self
            .poses
            .partition_point(|(t, _)| *t < stamp - SAME_STAMP_S);
        match self.poses.get_mut(at) {
            Some(held) if (held.0 - stamp).abs() <= SAME_STAMP_S => *held = (stamp, pose),
            _ => self.poses.insert(at, (stamp, pose)),
        }
    }

    /// Forgets the poses before `stamp` except the last of them, which a lookup at
    /// `stamp` still needs.
    pub fn forget_before(&mut self, stamp: f64) {
        let before = self.poses.partition_point(|(t, _)| *t < stamp);
        self.poses.drain(..before.saturating_sub(1));
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// The pose at `stamp`: a pose with that stamp, or the interpolation
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
                "no pose on both sides of the stamp within {max_gap} s (the nearest is \
                 {nearest:.3} s away)"
            )
        } else {
            "no pose at all".to_owned()
        })
    }
}

/// Why a transform could not be looked up.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum TfError {
    /// A frame no transform names.
    #[error("unknown frame {frame:?} (frames known: {known})")]
    UnknownFrame {
        /// The frame asked for.
        frame: String,
        /// The frames the buffer holds.
        known: String,
    },
    /// The two frames are in different trees.
    #[error("no path from {target} to {source_frame}: they are in different TF trees")]
    NoPath {
        /// Target frame.
        target: String,
        /// Source frame.
        source_frame: String,
    },
    /// A transform of the path has no pose at the stamp.
    #[error("{parent} -> {child}: {reason}")]
    NotAtStamp {
        /// The edge's parent frame.
        parent: String,
        /// The edge's child frame.
        child: String,
        /// Why.
        reason: String,
    },
    /// A transform that is not a rotation and a translation.
    #[error("{parent} -> {child}: {reason}")]
    Invalid {
        /// The edge's parent frame.
        parent: String,
        /// The edge's child frame.
        child: String,
        /// What is wrong.
        reason: String,
    },
}

/// One frame's link to its parent: fixed (`/tf_static`) or stamped (`/tf`).
#[derive(Clone, Debug, PartialEq)]
enum Link {
    Static(Isometry3<f64>),
    Stamped(PoseTrack),
}

/// The transforms of `/tf` and `/tf_static`: each frame's `parent_from_child`, by
/// child, as TF trees.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TfBuffer {
    links: HashMap<String, (String, Link)>,
}

/// Largest departure of a transform's quaternion from unit length taken as rounding.
const UNIT_QUATERNION_TOLERANCE: f64 = 1e-3;

impl TfBuffer {
    /// Adds a transform of `/tf` (`is_static` false) or `/tf_static`. A frame has one
    /// parent: a transform giving it another replaces what was held.
    pub fn insert(&mut self, t: &TransformStamped, is_static: bool) -> Result<(), TfError> {
        let parent = &t.header.frame_id;
        let child = &t.child_frame_id;
        let (p, q) = (&t.transform.translation, &t.transform.rotation);
        let invalid = |reason: String| TfError::Invalid {
            parent: parent.clone(),
            child: child.clone(),
            reason,
        };
        if ![p.x, p.y, p.z, q.x, q.y, q.z, q.w]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(invalid("non-finite translation or rotation".into()));
        }
        let quaternion = Quaternion::new(q.w, q.x, q.y, q.z);
        if (quaternion.norm() - 1.0).abs() > UNIT_QUATERNION_TOLERANCE {
            return Err(invalid(format!(
                "rotation quaternion of length {:.6}, not a rotation",
                quaternion.norm()
            )));
        }
        let pose = Isometry3::from_parts(
            Translation3::new(p.x, p.y, p.z),
            UnitQuaternion::from_quaternion(quaternion),
        );
        let stamp = seconds(&t.header.stamp);
        match (self.links.get_mut(child), is_static) {
            (Some((held_parent, Link::Stamped(track))), false) if held_parent == parent => {
                track.insert(stamp, pose);
            }
            (_, true) => {
                self.links
                    .insert(child.clone(), (parent.clone(), Link::Static(pose)));
            }
            (_, false) => {
                self.links.insert(
                    child.clone(),
                    (
                        parent.clone(),
                        Link::Stamped(PoseTrack::new(vec![(stamp, pose)])),
                    ),
                );
            }
        }
        Ok(())
    }

    /// `target_from_source` at `stamp` (seconds): the path between the two frames
    /// through their common ancestor, each stamped link interpolated at the stamp
    /// between poses within `max_gap` seconds either side of it.
    pub fn lookup(
        &self,
        target: &str,
        source: &str,
        stamp: f64,
        max_gap: f64,
    ) -> Result<Isometry3<f64>, TfError> {
        let (source_chain, source_steps, target_chain, target_steps) = self.path(target, source)?;
        let ancestor_from = |chain: &[String], steps: usize| -> Result<Isometry3<f64>, TfError> {
            let mut pose = Isometry3::identity();
            for child in &chain[..steps] {
                let (parent, link) = &self.links[child];
                let parent_from_child = match link {
                    Link::Static(pose) => *pose,
                    Link::Stamped(track) => {
                        track
                            .at(stamp, max_gap)
                            .map_err(|reason| TfError::NotAtStamp {
                                parent: parent.clone(),
                                child: child.clone(),
                                reason,
                            })?
                    }
                };
                pose = parent_from_child * pose;
            }
            Ok(pose)
        };
        let ancestor_from_source = ancestor_from(&source_chain, source_steps)?;
        let ancestor_from_target = ancestor_from(&target_chain, target_steps)?;
        Ok(ancestor_from_target.inverse() * ancestor_from_source)
    }

    /// Forgets the stamped poses before `stamp` (see [`PoseTrack::forget_before`]); a
    /// live buffer calls it to keep its memory bounded.
    pub fn forget_before(&mut self, stamp: f64) {
        for (_, link) in self.links.values_mut() {
            if let Link::Stamped(track) = link {
                track.forget_before(stamp);
            }
        }
    }

    /// Forgets every `/tf` transform and keeps those of `/tf_static`, which are not sent
    /// again: what a time jump back (a replay starting over) asks for.
    pub fn forget_stamped(&mut self) {
        self.links
            .retain(|_, (_, link)| matches!(link, Link::Static(_)));
    }

    /// Refuses two frames that are unknown or in different trees; what a lookup at any
    /// stamp would refuse first.
    pub fn connects(&self, target: &str, source: &str) -> Result<(), TfError> {
        self.path(target, source).map(|_| ())
    }

    /// The chains of `source` and `target` up to their common ancestor, with the number
    /// of links of each below it.
    fn path(
        &self,
        target: &str,
        source: &str,
    ) -> Result<(Vec<String>, usize, Vec<String>, usize), TfError> {
        let target_chain = self.chain(target)?;
        let source_chain = self.chain(source)?;
        // The common ancestor: the first frame of the source's chain that the target's
        // chain also reaches.
        source_chain
            .iter()
            .enumerate()
            .find_map(|(i, frame)| target_chain.iter().position(|f| f == frame).map(|j| (i, j)))
            .map(|(i, j)| (source_chain.clone(), i, target_chain.clone(), j))
            .ok_or_else(|| TfError::NoPath {
                target: target.to_owned(),
                source_frame: source.to_owned(),
            })
    }

    /// `frame` and its ancestors, root last.
    fn chain(&self, frame: &str) -> Result<Vec<String>, TfError> {
        let known = || {
            let mut frames: Vec<&str> = self
                .links
                .iter()
                .flat_map(|(child, (parent, _))| [child.as_str(), parent.as_str()])
                .collect();
            frames.sort_unstable();
            frames.dedup();
            frames.join(", ")
        };
        let is_parent = self.links.values().any(|(parent, _)| parent == frame);
        if !self.links.contains_key(frame) && !is_parent {
            return Err(TfError::UnknownFrame {
                frame: frame.to_owned(),
                known: known(),
            });
        }
        let mut chain = vec![frame.to_owned()];
        while let Some((parent, _)) = chain.last().and_then(|f| self.links.get(f)) {
            // A cycle ends the chain where it closes.
            if chain.contains(parent) {
                break;
            }
            chain.push(parent.clone());
        }
        Ok(chain)
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
        let track = PoseTrack::new(vec![(11.0, b), (10.0, a)]);
        assert_eq!(track.at(10.0, 0.0).unwrap(), a);
        let middle = track.at(10.5, 0.6).unwrap();
        assert!((middle.translation.vector.x - 0.5).abs() < 1e-12);
        assert!((middle.rotation.angle() - 0.1).abs() < 1e-12);
        let error = track.at(10.5, 0.4).unwrap_err();
        assert!(error.contains("0.500 s away"), "{error}");
        assert!(track.at(11.2, 10.0).is_err(), "no extrapolation");
        assert!(PoseTrack::default().at(1.0, 1.0).is_err());
    }

    fn transform(parent: &str, child: &str, sec: i32, pose: &Isometry3<f64>) -> TransformStamped {
        TransformStamped {
            header: stereocal_msgs::std_msgs::Header {
                stamp: stereocal_msgs::builtin_interfaces::Time { sec, nanosec: 0 },
                frame_id: parent.to_owned(),
            },
            child_frame_id: child.to_owned(),
            transform: crate::convert::transform_msg(pose),
        }
    }

    #[test]
    fn looks_up_a_chain_through_its_common_ancestor_at_the_stamp() {
        let base_from_link =
            |angle: f64| Isometry3::new(Vector3::new(0.0, 0.0, 0.5), Vector3::z() * angle);
        let link_from_tool = Isometry3::new(Vector3::new(0.3, 0.0, 0.0), Vector3::y() * 0.4);
        let world_from_base = Isometry3::new(Vector3::new(1.0, 2.0, 0.0), Vector3::z() * 0.1);
        let mut tf = TfBuffer::default();
        tf.insert(&transform("base", "link", 10, &base_from_link(0.0)), false)
            .unwrap();
        tf.insert(&transform("base", "link", 11, &base_from_link(0.2)), false)
            .unwrap();
        tf.insert(&transform("link", "tool", 0, &link_from_tool), true)
            .unwrap();
        tf.insert(&transform("world", "base", 0, &world_from_base), true)
            .unwrap();
        let base_from_tool = tf.lookup("base", "tool", 10.5, 1.0).unwrap();
        let expected = base_from_link(0.1) * link_from_tool;
        assert!((base_from_tool.to_homogeneous() - expected.to_homogeneous()).norm() < 1e-12);
        // Down one branch and up another.
        let tool_from_world = tf.lookup("tool", "world", 10.0, 1.0).unwrap();
        let expected = (world_from_base * base_from_link(0.0) * link_from_tool).inverse();
        assert!((tool_from_world.to_homogeneous() - expected.to_homogeneous()).norm() < 1e-12);

        let error = tf
            .lookup("base", "tool", 12.0, 1.0)
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("base -> link: no pose on both sides"),
            "{error}"
        );
        tf.insert(
            &transform("camera_mount", "camera", 0, &link_from_tool),
            true,
        )
        .unwrap();
        let error = tf.lookup("base", "camera", 10.0, 1.0).unwrap_err();
        assert!(matches!(error, TfError::NoPath { .. }), "{error}");
        let error = tf
            .lookup("base", "gripper", 10.0, 1.0)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("unknown frame \"gripper\"") && error.contains("tool"),
            "{error}"
        );
        let mut bad = transform("base", "link", 12, &base_from_link(0.0));
        bad.transform.rotation.w = 2.0;
        assert!(matches!(
            tf.insert(&bad, false),
            Err(TfError::Invalid { .. })
        ));
    }
}
