//! Tests of the rosbag2 reader and writer, one module per concern.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod damage;
mod interop;
mod memory;
mod roundtrip;
