//! `rosgraph_msgs` messages.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::ros_message::ros_message;

/// `rosgraph_msgs/msg/Clock`: simulated time, published on `/clock` by a simulator or
/// by a bag replay (`ros2 bag play --clock`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Clock {
    /// The current simulated time.
    pub clock: Time,
}

ros_message!(
    Clock,
    "rosgraph_msgs/msg/Clock",
    "builtin_interfaces/Time clock\n",
    Time
);
