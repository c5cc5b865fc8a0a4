//! `frame_from_body` transforms as geometry_msgs poses and transforms.

use nalgebra::{Isometry3, Matrix6};
use stereocal_msgs::geometry_msgs::{
    Point, Pose, PoseWithCovariance, Quaternion, Transform, Vector3,
};

/// `frame_from_body` as a `geometry_msgs/Pose`: the body's origin and orientation in
/// the frame.
pub fn pose_msg(frame_from_body: &Isometry3<f64>) -> Pose {
    let t = frame_from_body.translation.vector;
    let q = frame_from_body.rotation.quaternion();
    Pose {
        position: Point {
            x: t.x,
            y: t.y,
            z: t.z,
        },
        orientation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    }
}

/// `parent_from_child` as a `geometry_msgs/Transform`.
pub fn transform_msg(parent_from_child: &Isometry3<f64>) -> Transform {
    let pose = pose_msg(parent_from_child);
    Transform {
        translation: Vector3 {
            x: pose.position.x,
            y: pose.position.y,
            z: pose.position.z,
        },
        rotation: pose.orientation,
    }
}

/// `frame_from_body` with its 6x6 covariance in ROS's order (position, then rotation
/// about the frame's fixed axes) as a `geometry_msgs/PoseWithCovariance`.
pub fn pose_with_covariance_msg(
    frame_from_body: &Isometry3<f64>,
    covariance: &Matrix6<f64>,
) -> PoseWithCovariance {
    PoseWithCovariance {
        pose: pose_msg(frame_from_body),
        covariance: std::array::from_fn(|i| covariance[(i / 6, i % 6)]),
    }
}
