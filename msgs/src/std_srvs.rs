//! `std_srvs` services.

/// `std_srvs/srv` services.
pub mod srv {
    use serde::{Deserialize, Serialize};

    use crate::ros_message::ros_message;

    /// Request of `std_srvs/srv/Trigger`. The request has no fields; like every empty
    /// ROS 2 structure it carries one placeholder byte on the wire.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct TriggerRequest {
        /// Always 0; present because IDL structures cannot be empty.
        pub structure_needs_at_least_one_member: u8,
    }

    ros_message!(TriggerRequest, "std_srvs/srv/Trigger_Request", "");

    /// Response of `std_srvs/srv/Trigger`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct TriggerResponse {
        /// Whether the action succeeded.
        pub success: bool,
        /// Informational text, e.g. an error message.
        pub message: String,
    }

    ros_message!(
        TriggerResponse,
        "std_srvs/srv/Trigger_Response",
        "bool success\nstring message\n"
    );
}
