//! `geometry_msgs` messages. Units are metres; rotations are unit quaternions.

use serde::{Deserialize, Serialize};
use serde_big_array::BigArray;

use crate::ros_message::ros_message;
use crate::std_msgs::Header;

/// `geometry_msgs/msg/Vector3`: a free vector.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

ros_message!(
    Vector3,
    "geometry_msgs/msg/Vector3",
    "float64 x\nfloat64 y\nfloat64 z\n"
);

/// `geometry_msgs/msg/Point`: a position.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x coordinate.
    pub x: f64,
    /// y coordinate.
    pub y: f64,
    /// z coordinate.
    pub z: f64,
}

ros_message!(
    Point,
    "geometry_msgs/msg/Point",
    "float64 x\nfloat64 y\nfloat64 z\n"
);

/// `geometry_msgs/msg/Quaternion`: a rotation as `x i + y j + z k + w`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// i component.
    pub x: f64,
    /// j component.
    pub y: f64,
    /// k component.
    pub z: f64,
    /// Real component.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity rotation, as ROS 2 initialises it.
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

ros_message!(
    Quaternion,
    "geometry_msgs/msg/Quaternion",
    "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"
);

/// `geometry_msgs/msg/Pose`: `frame_from_body` as a position and an orientation.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position of the body's origin in the frame.
    pub position: Point,
    /// Orientation of the body in the frame.
    pub orientation: Quaternion,
}

ros_message!(
    Pose,
    "geometry_msgs/msg/Pose",
    "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
    Point,
    Quaternion
);

/// `geometry_msgs/msg/PoseStamped`: a pose in `header.frame_id` at `header.stamp`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Time and the frame the pose is expressed in.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

ros_message!(
    PoseStamped,
    "geometry_msgs/msg/PoseStamped",
    "std_msgs/Header header\ngeometry_msgs/Pose pose\n",
    Header,
    Pose
);

/// `geometry_msgs/msg/PoseWithCovariance`: a pose with the covariance of its error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6x6 covariance of `(x, y, z, rotation about X, rotation about Y,
    /// rotation about Z)`, the rotations about the frame's fixed axes (metres, radians).
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

impl Default for PoseWithCovariance {
    fn default() -> Self {
        Self {
            pose: Pose::default(),
            covariance: [0.0; 36],
        }
    }
}

ros_message!(
    PoseWithCovariance,
    "geometry_msgs/msg/PoseWithCovariance",
    "geometry_msgs/Pose pose\nfloat64[36] covariance\n",
    Pose
);

/// `geometry_msgs/msg/PoseWithCovarianceStamped`: a pose with covariance in
/// `header.frame_id` at `header.stamp`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    /// Time and the frame the pose is expressed in.
    pub header: Header,
    /// The pose and its covariance.
    pub pose: PoseWithCovariance,
}

ros_message!(
    PoseWithCovarianceStamped,
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "std_msgs/Header header\ngeometry_msgs/PoseWithCovariance pose\n",
    Header,
    PoseWithCovariance
);

/// `geometry_msgs/msg/Transform`: `parent_from_child` as translation and rotation.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Child origin in the parent frame.
    pub translation: Vector3,
    /// Rotation of the child frame in the parent frame.
    pub rotation: Quaternion,
}

ros_message!(
    Transform,
    "geometry_msgs/msg/Transform",
    "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
    Vector3,
    Quaternion
);

/// `geometry_msgs/msg/TransformStamped`: `header.frame_id`\_from\_`child_frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Time and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// `parent_from_child`.
    pub transform: Transform,
}

ros_message!(
    TransformStamped,
    "geometry_msgs/msg/TransformStamped",
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
    Header,
    Transform
);
