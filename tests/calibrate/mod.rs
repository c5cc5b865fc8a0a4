//! Calibration: the offline command, the calibrate node over DDS, the live session, the
//! report, and the one result schema they share.

mod charuco;
mod circles;
mod cli;
mod node;
mod node_params;
mod report;
mod session;
mod status;
