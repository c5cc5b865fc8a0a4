//! One frame's pose result as data: what `stereocal pose --json` prints per image and
//! what `pose_node`'s `~/status` reports of the last frame.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};
use stereocal_msgs::builtin_interfaces::Time;

use super::stage::{FramePose, PoseRejection};
use crate::calibrate::result::row_major;

/// A transform `a_from_b` as JSON: the rotation's 9 entries row by row and the
/// translation in metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformRecord {
    /// Rotation matrix, row-major.
    pub rotation: [f64; 9],
    /// Translation, metres.
    pub translation: [f64; 3],
}

/// The transform a record holds.
pub fn isometry_of(record: &TransformRecord) -> Isometry3<f64> {
    let rotation = Rotation3::from_matrix(&Matrix3::from_row_slice(&record.rotation));
    let [x, y, z] = record.translation;
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
}

impl TransformRecord {
    /// The record of `a_from_b`.
    pub fn new(a_from_b: &Isometry3<f64>) -> Self {
        let t = a_from_b.translation.vector;
        Self {
            rotation: row_major(a_from_b.rotation.to_rotation_matrix().matrix()),
            translation: [t.x, t.y, t.z],
        }
    }
}

/// One image's result, stamped with the image's stamp.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FrameRecord {
    /// The target's pose in the image.
    Pose {
        /// Image stamp, seconds.
        stamp: f64,
        /// The pose.
        camera_from_target: TransformRecord,
        /// RMS reprojection error, pixels.
        rms: f64,
        /// Row-major 6x6 covariance: position (metres), then rotation about the camera
        /// frame's fixed axes (radians).
        covariance: Vec<f64>,
    },
    /// No pose, and why.
    Rejected {
        /// Image stamp, seconds.
        stamp: f64,
        /// The reason.
        rejected: String,
    },
}

impl FrameRecord {
    /// The record of a frame stamped `stamp` with this outcome.
    pub fn new(stamp: &Time, outcome: &Result<FramePose, PoseRejection>) -> Self {
        let stamp = seconds(stamp);
        match outcome {
            Ok(pose) => Self::Pose {
                stamp,
                camera_from_target: TransformRecord::new(&pose.estimate.camera_from_target),
                rms: pose.estimate.rms_px,
                covariance: pose
                    .estimate
                    .covariance
                    .transpose()
                    .iter()
                    .copied()
                    .collect(),
            },
            Err(reason) => Self::Rejected {
                stamp,
                rejected: reason.to_string(),
            },
        }
    }

    /// The image stamp, seconds.
    pub fn stamp(&self) -> f64 {
        match self {
            Self::Pose { stamp, .. } | Self::Rejected { stamp, .. } => *stamp,
        }
    }
}

/// A ROS time as seconds.
pub fn seconds(stamp: &Time) -> f64 {
    f64::from(stamp.sec) + f64::from(stamp.nanosec) * 1e-9
}
