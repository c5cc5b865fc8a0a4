//! `stereo_msgs` messages.

use serde::{Deserialize, Serialize};

use crate::ros_message::ros_message;
use crate::sensor_msgs::{Image, RegionOfInterest};
use crate::std_msgs::Header;

/// `stereo_msgs/msg/DisparityImage`: a disparity map (`32FC1` image) with the
/// rectified stereo geometry needed to turn it into depth (`z = f * t / d`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct DisparityImage {
    /// Time and the left camera's optical frame.
    pub header: Header,
    /// The disparities, encoding `32FC1`.
    pub image: Image,
    /// Focal length in pixels.
    pub f: f32,
    /// Baseline in metres.
    pub t: f32,
    /// Window within which disparities are valid.
    pub valid_window: RegionOfInterest,
    /// Smallest disparity searched, in pixels.
    pub min_disparity: f32,
    /// Largest disparity searched, in pixels.
    pub max_disparity: f32,
    /// Smallest disparity increment, in pixels.
    pub delta_d: f32,
}

ros_message!(
    DisparityImage,
    "stereo_msgs/msg/DisparityImage",
    "std_msgs/Header header\nsensor_msgs/Image image\nfloat32 f\nfloat32 t\nsensor_msgs/RegionOfInterest valid_window\nfloat32 min_disparity\nfloat32 max_disparity\nfloat32 delta_d\n",
    Header,
    Image,
    RegionOfInterest
);
