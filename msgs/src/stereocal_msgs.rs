//! `stereocal_msgs`: the interfaces of stereocal's own that no standard ROS 2 package
//! has. Their definitions are in `msgs/ros/stereocal_msgs`, a ROS 2 interface package
//! that a ROS 2 workspace builds so that `ros2 service call`, rclpy and rclcpp can use
//! them.

/// `stereocal_msgs/srv` services.
pub mod srv {
    use serde::{Deserialize, Serialize};

    use crate::ros_message::ros_message;

    /// Request of `stereocal_msgs/srv/RemoveSample`: forget one collected sample.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct RemoveSampleRequest {
        /// The sample's index, from 0, in the order the samples were taken (as
        /// `~/status` lists them).
        pub index: u32,
    }

    ros_message!(
        RemoveSampleRequest,
        "stereocal_msgs/srv/RemoveSample_Request",
        "uint32 index\n"
    );

    /// Response of `stereocal_msgs/srv/RemoveSample`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct RemoveSampleResponse {
        /// Whether the sample was removed.
        pub success: bool,
        /// What was removed, or why nothing was.
        pub message: String,
        /// Samples kept after the call.
        pub samples: u32,
    }

    ros_message!(
        RemoveSampleResponse,
        "stereocal_msgs/srv/RemoveSample_Response",
        "bool success\nstring message\nuint32 samples\n"
    );
}
