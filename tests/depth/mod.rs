//! Stereo depth: `stereocal depth` and its stage on rendered rectified pairs, and
//! `disparity_node` over DDS.

mod cli;
mod node;
