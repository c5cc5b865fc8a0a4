//! camera_node's `~/status` (std_msgs/String, reliable, transient local): JSON published
//! at start-up, whenever the device's state changes, and once a second while it runs:
//!
//! `{"device", "state": {"state": "opening" | "streaming" (with "mode") | "waiting"
//! (with "reason" and "retry_in_s")}, "frames": {"captured", "dropped" (from the
//! device's sequence gaps), "bad_frames" (not convertible: a corrupt or truncated JPEG,
//! a short buffer)}, "published", "last_bad_frame" (its reason, or null), "camera_info":
//! {"url", "calibrated", "problem"}, "control_errors" (the device's refusals of control
//! parameters), "stereo_sync" (with a partner camera: see [`super::stereo_sync`]; or
//! null)}`.

use serde::Serialize;

use super::connection::DeviceState;
use super::output::FrameCounts;
use super::stereo_sync::SyncReport;

/// The camera_info part of the status.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CameraInfoStatus {
    /// `camera_info_url` as given.
    pub url: String,
    /// Whether a calibration of the captured size is published.
    pub calibrated: bool,
    /// Why not, when it is not.
    pub problem: Option<String>,
}

/// Everything `~/status` says.
#[derive(Clone, Debug, Serialize)]
pub struct CameraStatus {
    /// The device path, or `test_pattern`.
    pub device: String,
    /// The device's state.
    pub state: DeviceState,
    /// Frame counters.
    pub frames: FrameCounts,
    /// Frames published on `image_raw` or `image_raw/compressed`.
    pub published: u64,
    /// Why the last bad frame was bad.
    pub last_bad_frame: Option<String>,
    /// The calibration.
    pub camera_info: CameraInfoStatus,
    /// The device's refusals of control parameters, newest last.
    pub control_errors: Vec<String>,
    /// How this camera's stamps compare with its stereo partner's.
    pub stereo_sync: Option<SyncReport>,
}

impl CameraStatus {
    /// The message text.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }
}
