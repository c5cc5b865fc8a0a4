//! Rectification: the stage, the offline command, the rectify node over DDS, a stereo
//! pair rectified both ways against ground truth, and a verged pair rectified without
//! calibration.

mod cli;
mod node;
mod stage;
mod stereo_e2e;
mod uncalibrated;
