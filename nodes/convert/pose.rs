//! `frame_from_body` transforms as geometry_msgs poses and transforms.

use nalgebra::{Isometry3, Matrix6, Quaternion as NQuaternion, Translation3, UnitQuaternion};
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

/// Largest departure of a pose's quaternion from unit length that is taken as rounding
/// and normalized away; a larger one is refused.
const UNIT_QUATERNION_TOLERANCE: f64 = 1e-3;

/// The `frame_from_body` a `geometry_msgs/Pose` describes; an error says what is wrong
/// with it (a non-finite value, a quaternion that is not of unit length).
pub fn isometry_from_pose_msg(pose: &Pose) -> Result<Isometry3<f64>, String> {
    let (p, q) = (&pose.position, &pose.orientation);
    if ![p.x, p.y, p.z, q.x, q.y, q.z, q.w]
        .iter()
        .all(|v| v.is_finite())
    {
        return Err("non-finite position or orientation".into());
    }
    let quaternion = NQuaternion::new(q.w, q.x, q.y, q.z);
    let norm = quaternion.norm();
    if (norm - 1.0).abs() > UNIT_QUATERNION_TOLERANCE {
        return Err(format!(
            "orientation quaternion of length {norm:.6}, not a rotation (unit length expected)"
        ));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(p.x, p.y, p.z),
        UnitQuaternion::from_quaternion(quaternion),
    ))
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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn a_pose_message_reads_back_and_a_bad_one_is_refused() {
        let pose = Isometry3::new(Vector3::new(0.1, -0.2, 0.3), Vector3::new(0.4, 0.5, -0.6));
        let back = isometry_from_pose_msg(&pose_msg(&pose)).unwrap();
        assert!((back.to_homogeneous() - pose.to_homogeneous()).norm() < 1e-15);

        let mut nan = pose_msg(&pose);
        nan.position.y = f64::NAN;
        assert!(
            isometry_from_pose_msg(&nan)
                .unwrap_err()
                .contains("non-finite")
        );
        let mut long = pose_msg(&pose);
        long.orientation.w *= 2.0;
        let error = isometry_from_pose_msg(&long).unwrap_err();
        assert!(error.contains("not a rotation"), "{error}");
    }
}
