//! `std_msgs` messages.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::ros_message::ros_message;

/// `std_msgs/msg/Header`: acquisition time and the frame the data is expressed in.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Acquisition time of the data.
    pub stamp: Time,
    /// Coordinate frame of the data (e.g. the camera's optical frame).
    pub frame_id: std::string::String,
}

ros_message!(
    Header,
    "std_msgs/msg/Header",
    "builtin_interfaces/Time stamp\nstring frame_id\n",
    Time
);

/// `std_msgs/msg/String`: one string (e.g. a node's status as JSON).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct String {
    /// The text.
    pub data: std::string::String,
}

ros_message!(String, "std_msgs/msg/String", "string data\n");
