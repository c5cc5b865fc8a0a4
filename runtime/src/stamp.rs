//! The one stamp type of the runtime: a message's header stamp,
//! `builtin_interfaces/Time`, which every synchronized input, queued frame and published
//! result carries. [`Stamped`] gives it for the messages that have a header.

use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::geometry_msgs::{PoseStamped, TransformStamped};
use stereocal_msgs::sensor_msgs::{CameraInfo, CompressedImage, Image};
use stereocal_msgs::stereo_msgs::DisparityImage;

/// A message stamped with the time of the data it carries.
pub trait Stamped {
    /// The header stamp.
    fn stamp(&self) -> Time;
}

macro_rules! stamped_by_header {
    ($($message:ty),*) => {
        $(impl Stamped for $message {
            fn stamp(&self) -> Time {
                self.header.stamp
            }
        })*
    };
}

stamped_by_header!(
    Image,
    CompressedImage,
    CameraInfo,
    PoseStamped,
    TransformStamped,
    DisparityImage
);
