//! Stereo depth: a rectified pair and its camera_infos in, a disparity map
//! (stereo_msgs/DisparityImage) out. [`stage`] is the code the offline command
//! `stereocal depth` runs on every pair.

pub mod stage;
