//! Rectification: [`node`] (`rectify_node`, image_proc's RectifyNode) and the offline
//! `stereocal rectify` both hand frames to the [`stage`]; [`row_alignment`] measures on
//! rectified pixels how well a stereo pair's rows agree, [`scene`] opens a synthetic
//! stereo scene with its ground truth, and [`replay`] plays a bag through rectify nodes
//! running as their own processes. [`matches`] pairs the points uncalibrated
//! rectification estimates the epipolar geometry from, [`homography`] warps its images.

pub mod homography;
pub mod matches;
pub mod node;
pub mod replay;
pub mod row_alignment;
pub mod scene;
pub mod stage;
