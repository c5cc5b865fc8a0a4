//! The commands of the `stereocal` binary, one module per command; each exposes its
//! clap arguments and a `run` function.

pub mod calibrate;
pub mod demo;
pub mod depth;
pub mod handeye;
pub mod image_topics;
pub mod node;
mod output_bag;
mod pipeline;
pub mod play;
pub mod pose;
pub mod rectify;
pub mod rectify_uncalibrated;
pub mod synth;
pub mod synth_depth;
