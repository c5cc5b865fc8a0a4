//! Stereo depth: a rectified pair and its camera_infos in, a disparity map
//! (stereo_msgs/DisparityImage) and points out. [`stage`] is the code that
//! `disparity_node` and the offline command `stereocal depth` run on every pair.

pub mod node;
pub mod stage;
