//! Conversions between ROS 2 messages and the vision types: `sensor_msgs/Image` to and
//! from [`stereocal_vision::image::Image`], and `sensor_msgs/CameraInfo` to and from a
//! [`stereocal_vision::camera::CameraModel`] with its rectification `R` and projection `P`, and
//! `nalgebra::Isometry3` poses to geometry_msgs poses and transforms.
//!
//! Every field that comes from a message is validated; a bad message gives an error
//! naming the field, the value found and the value expected.

mod camera_info;
mod compress;
mod compressed;
mod image;
mod jpeg_input;
mod mjpeg;
mod pose;

pub use camera_info::{
    CalibratedCamera, CameraInfoError, calibrated_camera_from_info, info_from_calibrated,
    info_from_raw_camera,
};
pub use compress::{CompressError, Compression, compressed_from_image_msg};
pub use compressed::{
    Codec, CompressedError, Format, ImageKind, base_topic, image_msg_from_compressed,
};
pub use image::{Encoding, ImageMsgError, decode_image_into, image_from_msg, msg_from_image};
pub use pose::{isometry_from_pose_msg, pose_msg, pose_with_covariance_msg, transform_msg};
