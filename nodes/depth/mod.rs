//! Stereo depth: a rectified pair and its camera_infos in, a disparity map
//! (stereo_msgs/DisparityImage) and points (sensor_msgs/PointCloud2) out. [`stage`] is
//! the code that `disparity_node` and the offline command `stereocal depth` run on every
//! pair; [`cloud`] makes the clouds of `point_cloud_node` and `stereocal depth`.

pub mod cloud;
pub mod node;
pub mod point_cloud_node;
pub mod stage;
