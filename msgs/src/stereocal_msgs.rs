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

#[cfg(test)]
mod tests {
    use super::srv::{RemoveSampleRequest, RemoveSampleResponse};
    use crate::RosMessage;

    /// The fields of the shipped `.srv` file, comments and blank lines left out, request
    /// and response.
    fn srv_fields(text: &str) -> Vec<String> {
        text.split("---")
            .map(|part| {
                part.lines()
                    .map(str::trim)
                    .filter(|l| !l.is_empty() && !l.starts_with('#'))
                    .map(|l| format!("{l}\n"))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_shipped_interface_has_the_fields_of_the_types() {
        let srv = srv_fields(include_str!("../ros/stereocal_msgs/srv/RemoveSample.srv"));
        assert_eq!(
            srv,
            [
                RemoveSampleRequest::DEFINITION,
                RemoveSampleResponse::DEFINITION
            ]
        );
    }
}
