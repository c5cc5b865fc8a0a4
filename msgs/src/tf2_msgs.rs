//! `tf2_msgs` messages.

use serde::{Deserialize, Serialize};

use crate::geometry_msgs::TransformStamped;
use crate::ros_message::ros_message;

/// `tf2_msgs/msg/TFMessage`: the message on `/tf` and `/tf_static`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TFMessage {
    /// Transforms, each `parent_from_child`.
    pub transforms: Vec<TransformStamped>,
}

ros_message!(
    TFMessage,
    "tf2_msgs/msg/TFMessage",
    "geometry_msgs/TransformStamped[] transforms\n",
    TransformStamped
);
