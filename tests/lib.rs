//! stereocal's end-to-end tests, one binary with a module per concern: bags replayed
//! through the nodes over DDS and through the offline commands, the stages they share,
//! the shipped configuration and the bundled bags.
//!
//! Every test that starts nodes does so on a ROS domain leased for it alone
//! (`stereocal_runtime::testing::DomainLease`), so tests running at the same time, in
//! this binary or another process, never see each other's nodes.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod bundled_bags;
mod calibrate;
mod camera;
mod common;
mod composition;
mod compressed;
mod depth;
mod handeye;
mod node_config;
mod play;
mod pose;
mod rectify;
