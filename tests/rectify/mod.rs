//! Rectification: the stage, the offline command, the rectify node over DDS, and a
//! stereo pair rectified both ways against ground truth.

mod cli;
mod node;
mod stage;
mod stereo_e2e;
