//! camera_node, a V4L2 camera driver with camera_info_manager's semantics: [`node`]
//! (parameters, topics, the capture loop), [`device`] (the one small interface to a
//! capture device), [`v4l2`] (it on a V4L2 device), [`test_pattern`] (it on a
//! synthetic test pattern), [`connection`] (opening, and opening again with back-off),
//! [`output`] (frames to messages, and their counts), [`yuyv`] (YUYV to rgb8 and mono8
//! as OpenCV converts), [`stamps`] (V4L2 buffer timestamps on the ROS clock),
//! [`controls`] (V4L2 controls as parameters), [`camera_info`] (the calibration and
//! `set_camera_info`), [`stereo_sync`] (a stereo pair's stamp differences) and
//! [`status`] (`~/status`).

pub mod camera_info;
pub mod connection;
pub mod controls;
pub mod device;
pub mod node;
pub mod output;
pub mod stamps;
pub mod status;
pub mod stereo_sync;
pub mod test_pattern;
#[cfg(feature = "v4l2")]
pub mod v4l2;
pub mod yuyv;
