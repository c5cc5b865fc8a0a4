//! The offline commands of the `stereocal` binary, one module per command; each exposes
//! its clap `Args` and a `run` function.

pub mod calibrate;
pub mod demo;
pub mod rectify;
pub mod synth;
